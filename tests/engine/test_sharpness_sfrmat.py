"""camsim's slanted-edge MTF against Burns' sfrmat, the field's reference e-SFR, run in GNU Octave on the same edges.

``data/sfrmat/edges.npz`` holds the edges (area-sampled steps, Gaussian-blurred point-sampled edges, a
noisy one, a diffraction-limited f/11 edge on imx174's pixel, the Kodak DCS-200's demosaiced green
plane); ``data/sfrmat/reference.json`` what ISETCam's ``ISO12233.m`` and Burns' ``sfrmat5`` made of
them (provenance and the exact calls in the file; ``data/sfrmat/make_reference.py`` made both, once,
with Octave; this test needs no Octave).

Both references depart from camsim by two documented filters, divided out here before comparing:

* neither corrects the box of its 1/4 px ESF bins, sinc(f_x / 4) with f_x the frequency along the
  pixel row (0.975 at Nyquist); camsim divides it out (module docstring, step 5);
* ISO12233.m does not correct its 3-point derivative [0.5 0 -0.5] on the 4x ESF, sinc(f_x / 2)
  (0.90 at Nyquist), and gives its frequencies along the pixel row, f_x = f cos(angle); sfrmat5 corrects
  the derivative (``fir2fix``) and gives frequencies perpendicular to the edge, as camsim does.

What is left is the methods' own difference (camsim places each bin's mean at its samples' mean
distance, windows the LSF over the band of bins every row covers rather than over the whole row, and
fits the edge in a 65 px window): measured at most 0.0048 of MTF up to Nyquist, 0.8 % of MTF50 and
0.0011 degree of edge angle on the noiseless edges (the largest, 0.0048, on the 5 degree area-sampled step
at Nyquist, where camsim reads 0.0035 below sinc and the adjusted sfrmat5 0.0008 above it). The
tolerances below are those plus about half again; each fails when camsim's sinc^2 correction is dropped
or halved, or its distances are taken along the row (the README in data/sfrmat lists the checks made).
"""

import functools
import json
from pathlib import Path

import numpy as np
import pytest

from camsim_core.metrics import mtf50, mtf_at, slanted_edge_mtf
from camsim_core.metrics.sharpness import edge_angle

DATA = Path(__file__).parent / "data" / "sfrmat"
REF = json.loads((DATA / "reference.json").read_text())
IMAGES = REF["images"]
NAMES = list(IMAGES)
NOISY = {n for n in NAMES if "noise_sigma" in IMAGES[n]}
REFERENCES = ("sfrmat5", "iso12233")

CURVE_TOL = 0.0075        # max |MTF difference| up to Nyquist, noiseless edges (measured <= 0.0048)
CURVE_TOL_NOISY = 0.025   # the noisy edge (sigma 0.01 on a 0.6 step): measured 0.016, noise in both estimates
MTF50_REL = 0.012         # MTF50 (measured <= 0.8 %: the 5 degree step's, 0.0044 at 0.59 cycles/px)
NYQUIST_TOL = 0.0065      # MTF at Nyquist (measured <= 0.0048)
ANGLE_TOL = 0.005         # degrees, noiseless (measured <= 0.0011, the diffraction edge's wide LSF)
ANGLE_TOL_NOISY = 0.2     # degrees: sfrmat's whole-row centroids read the noisy edge 0.10 degree off


@functools.lru_cache(maxsize=None)
def _edges():
    with np.load(DATA / "edges.npz") as z:
        return {k: z[k] for k in z.files}


@functools.lru_cache(maxsize=None)
def _camsim(name):
    return slanted_edge_mtf(_edges()[name])


def _reference(name, which, adjusted=True):
    """The reference's curve (frequency, mtf); ``adjusted``: on camsim's footing (the filters above divided out)."""
    r = IMAGES[name][which]
    f, m = np.asarray(r["frequency"]), np.asarray(r["mtf"])
    if not adjusted:
        return f, m
    cos = np.cos(np.radians(r["angle_deg"]))
    if which == "sfrmat5":  # f perpendicular to the edge; bins 1/4 px along the row
        return f, m / np.sinc(f * cos / 4)
    # ISO12233.m: f along the row; 3-point derivative and binning box uncorrected
    return f / cos, m / (np.sinc(f / 2) * np.sinc(f / 4))


def _first_crossing(f, m):
    below = np.nonzero(m < 0.5)[0]
    i = below[0]
    return f[i - 1] + (m[i - 1] - 0.5) * (f[i] - f[i - 1]) / (m[i - 1] - m[i])


def test_reference_files_hold_what_they_say():
    edges = _edges()
    assert set(edges) == set(NAMES) and len(NAMES) >= 10
    for name in NAMES:
        assert list(edges[name].shape) == IMAGES[name]["shape"] and edges[name].dtype == np.float32
        for which in REFERENCES:
            r = IMAGES[name][which]
            f, m = _reference(name, which, adjusted=False)
            assert f[0] == 0 and m[0] == pytest.approx(1) and f[-1] <= 1.0 + 1e-9 and f[-1] > 0.9
            assert r["oversampling"] == 4
            # the stored MTF50 and MTF at Nyquist are the curve's (before its rounding to 9 digits), by the rule
            # camsim's functions use
            assert r["mtf50"] == pytest.approx(mtf50(f, m), abs=1e-7)
            assert r["mtf_nyquist"] == pytest.approx(mtf_at(f, m), abs=1e-7)
    for which in REFERENCES:
        prov = REF["references"][which]
        assert len(prov["commit"]) == 40 and prov["call"] and prov["repository"].startswith("https://github.com/")
    assert REF["octave"].startswith("GNU Octave")


@pytest.mark.parametrize("which", REFERENCES)
@pytest.mark.parametrize("name", NAMES)
def test_mtf_curve_matches_sfrmat_up_to_nyquist(name, which):
    f, m = _camsim(name)
    fr, mr = _reference(name, which)
    upto = f <= 0.5
    diff = np.abs(m[upto] - np.interp(f[upto], fr, mr)).max()
    assert diff < (CURVE_TOL_NOISY if name in NOISY else CURVE_TOL), f"{name} vs {which}: {diff:.4f}"


@pytest.mark.parametrize("which", REFERENCES)
@pytest.mark.parametrize("name", NAMES)
def test_mtf50_and_mtf_at_nyquist_match_sfrmat(name, which):
    f, m = _camsim(name)
    fr, mr = _reference(name, which)
    assert mtf50(f, m) == pytest.approx(_first_crossing(fr, mr), rel=MTF50_REL)
    # the noisy edge's MTF at Nyquist is its noise's (the edge's own is 0.007): each estimate reads its own
    assert mtf_at(f, m) == pytest.approx(np.interp(0.5, fr, mr), abs=0.015 if name in NOISY else NYQUIST_TOL)


@pytest.mark.parametrize("name", NAMES)
def test_edge_angle_matches_sfrmat(name):
    ref = IMAGES[name]["sfrmat5"]["angle_deg"]
    assert IMAGES[name]["iso12233"]["angle_deg"] == pytest.approx(ref, abs=1e-3)  # the same fit in both
    got = edge_angle(_edges()[name])
    assert got == pytest.approx(ref, abs=ANGLE_TOL_NOISY if name in NOISY else ANGLE_TOL)
    if name in NOISY:  # camsim's narrower centroid window: nearer the true slant than sfrmat's whole rows
        assert abs(got - IMAGES[name]["angle"]) < abs(ref - IMAGES[name]["angle"])


@pytest.mark.parametrize("name", sorted(set(NAMES) - NOISY))
def test_as_published_sfrmat5_differs_only_by_its_uncorrected_binning(name):
    # compared with sfrmat5's own numbers, camsim reads higher by the 1/4 px bin box sfrmat5 leaves in
    # (at most 2.5 % of the MTF at Nyquist) and never lower by more than the methods' difference
    f, m = _camsim(name)
    fr, mr = _reference(name, "sfrmat5", adjusted=False)
    upto = f <= 0.5
    d = m[upto] - np.interp(f[upto], fr, mr)
    assert d.min() > -0.003
    assert d.max() < 0.016
