"""Make ``edges.npz`` and ``reference.json``: slanted edges, and Burns' sfrmat's e-SFR of each, run in GNU Octave.

Not run by the test suite (``tests/engine/test_sharpness_sfrmat.py`` reads the two files; it needs no
Octave). The repository holds only the reference code's *outputs*, never its code.

Two reference implementations, each called on every edge image, one channel (no luminance weighting):

``iso12233``
    ISETCam's ``ISO12233.m`` (ISET/isetcam, ``metrics/ISO/ISO12233.m``; Burns' sfrmat4 as Wandell
    rewrote it), called as ``ISO12233(img, 1, [], 'none')``: deltaX 1 (cycles per pixel), no plots.
    4x binning, linear edge fit, Hamming windows, 3-point derivative, *no* derivative correction,
    frequency axis along the pixel row (not divided by cos(angle)).
``sfrmat5``
    Burns' own sfrmat5 v1 (28 Feb. 2023, ISO 12233:2023), from the public copy t-kuha/sfrmat5
    (``matlab/sfrmat5``), called as ``sfrmat5(1, 1, img, 1, 1)``: io 1 (no GUI), del 1 (cycles per
    pixel), npol 1 (linear edge fit, as ISO 12233:2017 and camsim), wflag 1 (Hamming window, as camsim;
    sfrmat5's default is a Tukey window). 4x binning, 3-point derivative corrected by ``fir2fix``,
    frequency axis perpendicular to the edge (bin width cos(angle) / 4).

Re-running
----------
1. ``apt-get install octave`` (Debian 12: GNU Octave 7.3.0).
2. ISETCam: ``git clone https://github.com/ISET/isetcam`` and check out the commit in
   ``reference.json`` (``references.iso12233.commit``); ``--iso12233-dir`` is its ``metrics/ISO``
   folder. The one ISETCam helper ``ISO12233.m`` calls on this path, ``ieNotDefined``, is replaced
   by a stub this script writes (true when the caller has no such variable or it is empty), so
   ISETCam need not be on Octave's path. (The reference of record was made from a transcription of
   that file holding its code lines verbatim, less comments, the ip-struct input branch and the
   plotting branches, which ``plotOptions = 'none'`` never runs.)
3. sfrmat5: ``git clone https://github.com/t-kuha/sfrmat5`` at the commit in ``reference.json``;
   ``--sfrmat5-dir`` is its ``matlab/sfrmat5`` folder (used unchanged).
4. ``cd /work/main && .venv/bin/python tests/engine/data/sfrmat/make_reference.py
   --iso12233-dir ISETCAM/metrics/ISO --sfrmat5-dir SFRMAT5/matlab/sfrmat5``
   (``--images-only`` rewrites edges.npz alone).
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.io import loadmat, savemat
from scipy.special import ndtr

HERE = Path(__file__).resolve().parent
SHAPE = (128, 128)
LO, HI = 0.2, 0.8

PROVENANCE = {
    "iso12233": {
        "repository": "https://github.com/ISET/isetcam",
        "commit": "030f251c390259b7bf8e05675f8ce3d58567f31f",
        "path": "metrics/ISO/ISO12233.m",
        "call": "results = ISO12233(img, 1, [], 'none')",
        "notes": ("code lines transcribed verbatim (comments, the ip-struct input branch and the plotting "
                  "branches left out: plotOptions 'none' runs none of them); local subfunctions (ahamming, "
                  "cent, pbCentroid, clipping, deriv1, findedge2, polyfit_convert, project2, rotatev2, "
                  "rotate90, r90) are the file's own; ieNotDefined stubbed"),
        "options": {"oversampling": 4, "edge_fit": "linear (npol 1)", "window": "Hamming (ahamming), centred on "
                    "the LSF centroid after shifting", "derivative": "3-point [0.5 0 -0.5] on the 4x ESF",
                    "derivative_correction": "none", "frequency_axis": "cycles per pixel along the row "
                    "(4 (n-1) / nn), not divided by cos(angle)", "weights": "none (one channel)"},
    },
    "sfrmat5": {
        "repository": "https://github.com/t-kuha/sfrmat5",
        "commit": "e422be17323cdb4335460feb8d429f8129d86813",
        "path": "matlab/sfrmat5/sfrmat5.m (and the folder's helper functions)",
        "call": "[status, dat, e, sfr50, fitme, esf, nbin, del2] = sfrmat5(1, 1, img, 1, 1)",
        "notes": "Peter D. Burns' sfrmat5 v1 (28 Feb. 2023), a public copy; used unchanged, no stubs",
        "options": {"oversampling": 4, "edge_fit": "linear (npol 1)", "window": "Hamming (wflag 1), centred on "
                    "the LSF peak after shifting", "derivative": "3-point [0.5 0 -0.5] on the 4x ESF",
                    "derivative_correction": "fir2fix(nn2, 3)", "frequency_axis": "cycles per pixel "
                    "perpendicular to the edge ((n-1) / (del2 nn), del2 = cos(angle) / 4)",
                    "weights": "none (one channel)"},
    },
}

IEN_STUB = """function r = ieNotDefined(name)
% Stub for ISETCam's ieNotDefined: true when the caller has no variable NAME or it is empty.
r = ~evalin('caller', ['exist(''' name ''', ''var'') && ~isempty(' name ')']);
end
"""

OCTAVE_DRIVER = r"""
addpath('{stubs}'); addpath('{iso}'); addpath('{s5}');
names = {names};
out = struct();
for k = 1:numel(names)
  nm = names{{k}};
  s = load(fullfile('{work}', [nm '.mat']));
  img = double(s.img);
  [r, fitme] = ISO12233(img, 1, [], 'none');
  out.([nm '_iso_freq']) = r.freq(:);
  out.([nm '_iso_mtf']) = r.mtf(:, 1);
  out.([nm '_iso_fitme']) = fitme(1, :);
  out.([nm '_iso_mtf50own']) = r.mtf50;
  [status, dat, e, sfr50, fitme5, esf, nbin, del2] = sfrmat5(1, 1, img, 1, 1);
  out.([nm '_s5_freq']) = dat(:, 1);
  out.([nm '_s5_mtf']) = dat(:, 2);
  out.([nm '_s5_fitme']) = fitme5(1, :);
  out.([nm '_s5_sfr50']) = sfr50;
  out.([nm '_s5_del2']) = del2;
  out.([nm '_s5_nbin']) = nbin;
end
save('-v7', fullfile('{work}', 'out.mat'), '-struct', 'out');
"""


def _distance(shape, angle):
    """Perpendicular distance of each pixel centre from a line through the image centre (as test_sharpness.py)."""
    h, w = shape
    y, x = np.mgrid[0:h, 0:w]
    return (x - (w / 2 + (y - h / 2) * np.tan(np.radians(angle)))) * np.cos(np.radians(angle))


def diffraction_mtf(nu, cutoff):
    """Diffraction-limited MTF of a circular pupil, incoherent light (Goodman, Fourier Optics, Eq. 6-32)."""
    v = np.clip(np.asarray(nu, float) / cutoff, 0, 1)
    return 2 / np.pi * (np.arccos(v) - v * np.sqrt(1 - v**2))


def _esf_from_mtf(d, mtf, nu_max, n=8000):
    """ESF(d) = 1/2 + integral_0^nu_max MTF(nu) sin(2 pi nu d) / (pi nu) dnu, midpoint rule on n frequencies."""
    dnu = nu_max / n
    nu = (np.arange(n) + 0.5) * dnu
    w = mtf(nu) / (np.pi * nu) * dnu
    flat = d.ravel()
    out = np.empty(flat.size)
    for i in range(0, flat.size, 2048):
        out[i:i + 2048] = 0.5 + np.sin(2 * np.pi * np.outer(flat[i:i + 2048], nu)) @ w
    return out.reshape(d.shape)


def build_edges():
    """name -> (float32 image, metadata with what the analytic MTF is, if any)."""
    from camsim_core.scene.charts import edge_coverage

    edges = {}
    for angle in (5.0, 12.0):
        img = LO + (HI - LO) * (1.0 - edge_coverage(SHAPE, angle))
        edges[f"step_area_{angle:g}deg"] = (img, {"kind": "area_step", "angle": angle,
                                                  "description": f"step area-sampled by 1 px pixels "
                                                  f"(edge_coverage, 32 samples per pixel along y), {angle:g} deg"})
    for sigma in (0.5, 1.0, 2.0):
        for angle in (5.0, 12.0):
            img = LO + (HI - LO) * ndtr(_distance(SHAPE, angle) / sigma)
            edges[f"gauss_s{sigma:g}_{angle:g}deg"] = (img, {"kind": "gaussian", "sigma": sigma, "angle": angle,
                                                              "description": f"step blurred by a Gaussian of "
                                                              f"sigma {sigma:g} px, point-sampled, {angle:g} deg"})
    rng = np.random.default_rng(12233)
    img = LO + (HI - LO) * ndtr(_distance(SHAPE, 5.0) / 1.0) + rng.normal(0.0, 0.01, SHAPE)
    edges["gauss_s1_5deg_noise"] = (img, {"kind": "gaussian", "sigma": 1.0, "angle": 5.0, "noise_sigma": 0.01,
                                          "seed": 12233, "description": "the sigma 1 px, 5 deg edge plus white "
                                          "Gaussian noise of sigma 0.01 (step 0.6; numpy default_rng(12233))"})
    # imx174's 5.86 um pixel behind a diffraction-limited f/11 lens at 550 nm, the pixel area-sampling
    pitch_mm, wl_mm, n_f, angle = 5.86e-3, 550e-6, 11.0, 5.0
    cutoff = pitch_mm / (wl_mm * n_f)  # cycles per pixel
    c, s = np.cos(np.radians(angle)), np.sin(np.radians(angle))

    def system(nu):
        return diffraction_mtf(nu, cutoff) * np.sinc(nu * c) * np.sinc(nu * s)

    img = LO + (HI - LO) * _esf_from_mtf(_distance(SHAPE, angle), system, cutoff)
    edges["diffraction_f11_imx174_5deg"] = (img, {"kind": "diffraction", "cutoff": cutoff, "angle": angle,
                                                  "description": "imx174 pixel (5.86 um), f/11, 550 nm: "
                                                  "diffraction (Goodman 6-32) times the 1 px square pixel's "
                                                  "MTF across a 5 deg edge, sinc(f cos) sinc(f sin); ESF by "
                                                  "numerical integration (8000 frequencies)"})
    edges["dcs200_green"] = (_dcs200_green(), {"kind": "camera", "description":
                             "Kodak DCS-200 (kodak-dcs200: Bayer, 8 bit, seed 0) on the 'slanted-edge' chart at "
                             "auto exposure, bilinear demosaic, G plane, 4 px border cropped (120 x 120)"})
    return {k: (np.asarray(v, np.float32), meta) for k, (v, meta) in edges.items()}


def _dcs200_green():
    import camsim_core as cs

    cam = cs.load_camera("kodak-dcs200")
    scene = cs.load_scene("slanted-edge")
    raw = cs.simulate(scene, cam, exposure=cs.auto_exposure(scene, cam))
    full = cs.demosaic(raw, "bilinear")
    g = np.asarray(full.data, float)[:, :, list(full.sensor_names).index("G")]
    return g[4:-4, 4:-4]


def first_crossing(f, m, level=0.5):
    """Frequency where m first falls below ``level``, linearly interpolated (camsim's mtf50 rule)."""
    below = np.nonzero(m < level)[0]
    if below.size == 0:
        return None
    i = below[0]
    if i == 0:
        return float(f[0])
    return float(f[i - 1] + (m[i - 1] - level) * (f[i] - f[i - 1]) / (m[i - 1] - m[i]))


def _octave_version():
    out = subprocess.run(["octave", "--no-gui", "--version"], capture_output=True, text=True).stdout
    return out.splitlines()[0].strip() if out else "unknown"


def run_octave(edges, iso_dir, s5_dir):
    names = list(edges)
    with tempfile.TemporaryDirectory(prefix="sfrmat_") as work:
        work = Path(work)
        stubs = work / "stubs"
        stubs.mkdir()
        (stubs / "ieNotDefined.m").write_text(IEN_STUB)
        for nm, (img, _) in edges.items():
            savemat(work / f"{nm}.mat", {"img": img.astype(np.float64)})
        cell = "{" + ", ".join(f"'{n}'" for n in names) + "}"
        script = OCTAVE_DRIVER.format(stubs=stubs, iso=iso_dir, s5=s5_dir, names=cell, work=work)
        (work / "driver.m").write_text(script)
        proc = subprocess.run(["octave", "--no-gui", "--norc", "--quiet", str(work / "driver.m")],
                              capture_output=True, text=True, cwd=work)
        if not (work / "out.mat").exists():
            sys.stderr.write(proc.stdout + proc.stderr)
            raise SystemExit("octave failed")
        return loadmat(work / "out.mat", squeeze_me=True), proc.stdout


def _curve(f, m, fmax=1.0):
    f, m = np.asarray(f, float).ravel(), np.asarray(m, float).ravel()
    keep = f <= fmax + 1e-9
    return f[keep], m[keep]


def _r(a):
    """A curve as a list, 9 significant digits (far below either implementation's own precision)."""
    return [float(f"{v:.9g}") for v in np.asarray(a, float)]


def _sha(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--iso12233-dir", help="folder holding ISETCam's ISO12233.m")
    ap.add_argument("--sfrmat5-dir", help="folder holding Burns' sfrmat5.m and its helpers")
    ap.add_argument("--images-only", action="store_true")
    args = ap.parse_args(argv)

    edges = build_edges()
    np.savez_compressed(HERE / "edges.npz", **{k: v[0] for k, v in edges.items()})
    print(f"edges.npz: {(HERE / 'edges.npz').stat().st_size} bytes, {len(edges)} images")
    if args.images_only:
        return
    out, log = run_octave(edges, Path(args.iso12233_dir).resolve(), Path(args.sfrmat5_dir).resolve())

    prov = json.loads(json.dumps(PROVENANCE))
    prov["iso12233"]["sha256_of_file_run"] = _sha(Path(args.iso12233_dir) / "ISO12233.m")
    prov["sfrmat5"]["sha256_of_file_run"] = _sha(Path(args.sfrmat5_dir) / "sfrmat5.m")
    images = {}
    for nm, (img, meta) in edges.items():
        entry = dict(meta, shape=list(img.shape), dtype=str(img.dtype))
        # ISO12233: x = fitme(1) y + fitme(2) on the (unrotated: all edges here are near vertical) image
        f, m = _curve(out[f"{nm}_iso_freq"], out[f"{nm}_iso_mtf"])
        slope = float(np.ravel(out[f"{nm}_iso_fitme"])[0])
        iso = {"frequency": _r(f), "mtf": _r(m), "mtf50": first_crossing(f, m),
               "mtf_nyquist": float(np.interp(0.5, f, m)), "fit_slope_dx_dy": slope,
               "angle_deg": float(np.degrees(np.arctan(slope))), "oversampling": 4,
               "frequency_units": "cycles per pixel along the row",
               "own_mtf50_on_0.2_grid": float(out[f"{nm}_iso_mtf50own"])}
        f, m = _curve(out[f"{nm}_s5_freq"], out[f"{nm}_s5_mtf"])
        fit5 = np.ravel(out[f"{nm}_s5_fitme"])
        s5 = {"frequency": _r(f), "mtf": _r(m), "mtf50": first_crossing(f, m),
              "mtf_nyquist": float(np.interp(0.5, f, m)), "fit_slope_dx_dy": float(fit5[0]),
              "angle_deg": float(np.degrees(np.arctan(fit5[0]))), "oversampling": int(out[f"{nm}_s5_nbin"]),
              "bin_width_px": float(out[f"{nm}_s5_del2"]), "frequency_units": "cycles per pixel perpendicular to "
              "the edge", "own_sfr50_clipped_at_0.495": float(out[f"{nm}_s5_sfr50"])}
        images[nm] = dict(entry, iso12233=iso, sfrmat5=s5)
    doc = {
        "description": "Burns' sfrmat e-SFR of each image in edges.npz: ISETCam's ISO12233.m and Burns' sfrmat5. "
                       "mtf50 and mtf_nyquist are computed here from each stored curve by linear interpolation "
                       "(mtf50: first fall below 0.5), the rule camsim's mtf50 / mtf_at use. angle_deg is "
                       "atan(dx/dy) of the fitted line x = p0 + (dx/dy) y, the sign camsim's edge_angle uses "
                       "(sfrmat5 itself prints the opposite sign). Curves are kept up to 1 cycle/px.",
        "made_by": "tests/engine/data/sfrmat/make_reference.py",
        "date": datetime.date.today().isoformat(),
        "octave": _octave_version(),
        "references": prov,
        "images": images,
    }
    text = json.dumps(doc, indent=1)
    # one line per numeric list (the curves), the rest indented
    text = re.sub(r"\[\s*(-?[0-9][^\]\[{}\"]*?)\s*\]", lambda mt: "[" + re.sub(r"\s+", " ", mt.group(1)) + "]", text)
    (HERE / "reference.json").write_text(text + "\n")
    print(f"reference.json: {(HERE / 'reference.json').stat().st_size} bytes")


if __name__ == "__main__":
    main()
