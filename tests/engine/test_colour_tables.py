"""The shipped copy of colour-science's datasets is colour-science's, and the sRGB formulas are its numbers.

camsim reads colour-science's tables from ``assets/colour-science/tables.npz``
(importing colour-science costs 1.5-2 s of CPU). Each table is compared here
with the installed colour-science to the bit, read by colour-science's own
accessors (not by the writer's code), so a copy written from another version
of the library, or a table read under the wrong key, fails.
"""

import subprocess
import sys

import colour
import numpy as np
import pytest

from camsim_core.datasets import colour_science as cst
from camsim_core.datasets.colour_science import colourchecker_names, srgb_to_linear, table, xyz_to_srgb
from camsim_core.errors import ParameterError

D_SERIES = colour.colorimetry.datasets.illuminants.SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES
#: camsim's name -> colour-science's (wavelengths, values), read with colour-science's own accessors.
EXPECTED = {
    "cie1931": lambda: colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"],
    "stockman-sharpe": lambda: colour.MSDS_CMFS["Stockman & Sharpe 2 Degree Cone Fundamentals"],
    "D65": lambda: colour.SDS_ILLUMINANTS["D65"],
    "A": lambda: colour.SDS_ILLUMINANTS["A"],
    "crt-brainard-1997": lambda: colour.MSDS_DISPLAY_PRIMARIES["Typical CRT Brainard 1997"],
    "mallett2019": lambda: colour.recovery.MSDS_BASIS_FUNCTIONS_sRGB_MALLETT2019,
}


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_each_table_is_colour_sciences_to_the_bit(name):
    w, v = table(name)
    ref = EXPECTED[name]()
    np.testing.assert_array_equal(w, ref.wavelengths)
    np.testing.assert_array_equal(v, ref.values)
    assert not v.flags.writeable  # shared by every caller: nobody may change it


def test_the_daylight_basis_and_the_colorchecker_are_colour_sciences():
    w, s = table("daylight-basis")
    for k, key in enumerate(("S0", "S1", "S2")):
        np.testing.assert_array_equal(w, D_SERIES[key].wavelengths)
        np.testing.assert_array_equal(s[:, k], D_SERIES[key].values)
    sds = colour.SDS_COLOURCHECKERS["BabelColor Average"]
    w, r = table("babelcolor")
    assert colourchecker_names() == tuple(sds) and len(sds) == 24
    for k, patch in enumerate(sds):
        np.testing.assert_array_equal(w, sds[patch].wavelengths)
        np.testing.assert_array_equal(r[:, k], sds[patch].values)


def test_the_file_names_the_colour_science_it_was_written_from():
    assert str(cst._file()["colour_version"]) == colour.__version__


def test_an_unknown_table_is_refused_by_name():
    with pytest.raises(ParameterError, match="unknown colour-science table 'D50'"):
        table("D50")


def test_xyz_to_srgb_is_colour_sciences_inside_and_outside_the_gamut():
    xyz = np.random.default_rng(7).uniform(-0.3, 1.4, (2000, 3))
    xyz[:4] = [[0.95047, 1.0, 1.08883], [0, 0, 0], [0.0031308, 0.0031308, 0.0031308], [0.1, 0.2, 0.3]]
    for encode in (True, False):
        np.testing.assert_allclose(xyz_to_srgb(xyz, encode), colour.XYZ_to_sRGB(xyz, apply_cctf_encoding=encode),
                                   rtol=0, atol=1e-12)
    # the standard's white is D65 of Y = 1: it encodes to 1 in every channel
    np.testing.assert_allclose(xyz_to_srgb([0.9504559, 1.0, 1.0890578]), 1.0, atol=2e-4)


def test_srgb_decoding_is_colour_sciences_and_inverts_the_encoding():
    v = np.concatenate([np.linspace(-0.1, 1.1, 1201), [0.04045, 12.92 * 0.0031308]])
    np.testing.assert_allclose(srgb_to_linear(v), colour.cctf_decoding(v, function="sRGB"), rtol=0, atol=1e-14)
    lin = np.linspace(0, 1, 101)
    np.testing.assert_allclose(srgb_to_linear(colour.cctf_encoding(lin, function="sRGB")), lin, atol=1e-12)


def test_the_ideal_image_path_imports_no_colour_science():
    """What a server's first page computes (the default scene's ideal image and preview, a camera's sensor
    colours, the Macbeth chart, D65) reads the shipped tables: colour-science is not imported."""
    code = ("import sys, camsim_core as cs\n"
            "from camsim_core.metrics import cielab\n"
            "from camsim_core.preview import sensor_colors\n"
            "from camsim_core.scene.preview import scene_srgb\n"
            "scene = cs.load_scene('cacaphony290'); cam = cs.load_camera('kodak-dcs200')\n"
            "mon = cs.load_monitor('simtoolbox-test')\n"
            "rendered = cs.render(cs.demosaic(cs.simulate(scene, cam)), mon)\n"
            "ideal = cs.ideal_image(scene, cam, mon)\n"
            "from camsim_core.rendering import white_xyz\n"
            "print(float(cielab.delta_e(rendered, ideal, white_xyz(mon), monitor=mon).mean()))\n"
            "scene_srgb(scene, max_side=64); sensor_colors(cam.sensors.values, cam.sensors.wavelengths)\n"
            "cs.load_scene('macbeth'); cs.load_monitor('brainard-crt')\n"
            "print(sorted(m for m in sys.modules if m == 'colour' or m.startswith('colour.')))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    mean_de, modules = out.stdout.strip().splitlines()[-2:]
    assert float(mean_de) > 0 and modules == "[]"
