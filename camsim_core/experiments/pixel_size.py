"""Pixel size for a fixed sensor: signal-to-noise against resolution (the chapter's section 6 question).

"How, for fixed sensor array size, the improvement in signal-to-noise ratio
obtained by increasing pixel size trades off against the loss of resolution
caused by the same change." A 4.8 x 3.6 mm sensor (1/3 inch) behind a
4 mm f/2.8 diffraction-limited lens sees a scene with fine coloured detail
at several light levels; its pixel pitch runs from 1 to 5.6 um (4800 x 3600
down to 857 x 642 pixels). Each camera image is demosaiced, colour-corrected
to CIE XYZ and compared with the ideal image (the scene's own XYZ, no lens,
no sensor) by the mean S-CIELAB dE*ab. Beside it, the two measures the
error trades: the SNR of an 18 % grey field's green pixels (dB) and the
MTF50 of the noiseless camera on an ISO 12233 slanted edge (cycles/mm at
the sensor, :mod:`camsim_core.metrics.sharpness`).

The camera (everything else fixed)
----------------------------------
* **Lens**: 4 mm, f/2.8, focused at the scene (2 m); diffraction per
  wavelength (:mod:`camsim_core.optics`). The same for every pitch.
* **Pixel scaling with pitch p** (one BSI process, the OV5647's figures,
  ``assets/sensors/phone-1.4um.json``):

  - full well = 2200 e-/um^2 x p^2 (4300 e- at 1.4 um): charge per area is
    a property of the process;
  - fill factor = ((p - 0.2 um) / p)^2: a 0.2 um isolation trench around
    each pixel (0.64 at 1 um, 0.73 at 1.4 um, 0.93 at 5.6 um);
  - QE: the phone preset's R, G, B curves at every pitch;
  - read noise 1.7 e- (the read-out circuit's, not the pixel's),
    dark current 5 e-/s/um^2 x p^2, DSNU 1 e-, PRNU 1 %;
  - 10-bit ADC, the full well at full scale, RGGB Bayer tile;
  - a black level (pedestal) of 16 DN, raised at a high analogue gain to
    4 x the dark noise in DN (read noise, DSNU and the dark current's shot
    noise, times the system gain), as a camera's black-level calibration
    does at each gain and as EMVA 1288 asks of a measurement: the ADC
    never clips the noise around black (at 5 lux and 64 x gain a 1 um
    pixel's read noise alone is 51 DN; under a 16 DN pedestal 21 % of the
    grey field's green pixels were clipped at 0 and its SNR read -0.45 dB
    for the -5 dB of the EMVA 1288 model). Processing subtracts the
    pedestal and keeps the signed values.

* **Exposure**: the time that puts the scene's white at 80 % of the full
  well, at most 1/30 s (a hand-held video frame). Because both the well and
  the light collected grow as p^2, this time does not depend on the pitch:
  in bright light every pitch fills its well and the small pixels lose only
  their smaller wells' shot-noise SNR; in dim light the exposure is capped,
  the small pixels collect few electrons and read noise and shot noise
  dominate. There the camera raises its analogue gain (ISO) so that the
  white still reaches 80 % of the ADC's range above the pedestal (at most
  64 x), as a camera's auto-exposure does, so that the 10-bit quantization
  does not add to the noise (:func:`operating_point`).
* **Light levels**: the illuminance on the scene, lux (D65); a perfect
  white reflector then has a luminance of lux / pi cd/m^2.

The scene and the comparison
----------------------------
A patch at the centre of the field, 192 x 192 um on the sensor (about
1/25 of the sensor's width, so cos^4 is 1 within 0.01 %), sampled every
0.5 um at the sensor: the 24 Macbeth colours (BabelColor average), each
patch a sinusoidal grating between its colour and half of it, at
frequencies from 10 to 400 cycles/mm at the sensor (the 1 um pixel's
Nyquist frequency is 500, the 5.6 um pixel's 89). The ideal image is the
scene's XYZ averaged onto a 1 um grid; each camera image (demosaiced
bilinearly, black level subtracted, the camera's 3 x 3 colour matrix fitted
by least squares to the 24 Macbeth colours under the same light) is
interpolated bilinearly onto that grid. S-CIELAB sees the grid as if the
whole sensor's image spanned 40 degrees (a screen at arm's length): 120
samples per degree; the white point is the perfect white reflector's XYZ.

Programmatic use::

    from camsim_core.experiments import pixel_size
    records = pixel_size.run(pitches=[1.4, 5.6], lux=[10, 1000], seeds=1, workers=None)
    print(pixel_size.table(pixel_size.summarize(records)))
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..errors import ParameterError
from .grid import check_seeds, task_seed
from .results import format_mean_std, summarize as _summarize, write_csv
from .runner import run_tasks

__all__ = [
    "PixelSizeConfig",
    "PITCHES_UM",
    "LUX",
    "SENSOR_MM",
    "camera",
    "operating_point",
    "configurations",
    "evaluate",
    "run",
    "summarize",
    "table",
    "optimum",
    "write_outputs",
    "figure",
]

#: Pixel pitches of the sweep, um.
PITCHES_UM = (1.0, 1.2, 1.4, 1.75, 2.0, 2.4, 2.8, 3.45, 4.0, 4.8, 5.6)
#: Illuminance on the scene, lux: dim room, living room, office, overcast day.
LUX = (5.0, 20.0, 100.0, 1000.0, 10000.0)
#: Sensor size (height, width), mm.
SENSOR_MM = (3.6, 4.8)
FOCAL_MM, F_NUMBER, DISTANCE_M = 4.0, 2.8, 2.0
#: Patch of the sensor simulated (um) and the scene's sampling at the sensor (um).
PATCH_UM, SCENE_STEP_UM, COMPARE_STEP_UM = 192.0, 0.5, 1.0
#: The whole sensor width seen across this many degrees when the images are compared.
VIEW_DEG = 40.0
WELL_PER_UM2, READ_NOISE, DARK_PER_UM2, DSNU, PRNU, TRENCH_UM, BITS = 2200.0, 1.7, 5.0, 1.0, 0.01, 0.2, 10
MAX_EXPOSURE_S, WHITE_FILL, MAX_GAIN = 1 / 30, 0.8, 64.0
#: The pedestal (DN): at least BLACK_LEVEL, and at least PEDESTAL_SIGMAS x the dark noise in DN at the gain used.
BLACK_LEVEL, PEDESTAL_SIGMAS = 16.0, 4.0

_RECORD_COLUMNS = ("pitch_um", "lux", "seed", "noise_seed", "pixels", "exposure_s", "analog_gain", "black_level_dn",
                   "white_electrons", "full_well",
                   "fill_factor", "saturated", "error", "snr_db", "mtf50_cyc_per_mm", "seconds")


@dataclass(frozen=True)
class PixelSizeConfig:
    """One task: a pitch, a light level, a seed index."""

    pitch_um: float
    lux: float
    seed: int
    demosaic: str = "bilinear"

    @property
    def noise_seed(self):
        return task_seed("pixel-size", float(self.pitch_um), float(self.lux), int(self.seed))


def _image_distance():
    from ..optics import image_distance

    return image_distance(FOCAL_MM, DISTANCE_M)


def _ppd(step_um):
    """Pixels per degree of a sampling step at the sensor (um), through the lens focused at the scene."""
    return 1.0 / np.degrees(np.arctan(step_um * 1e-6 / _image_distance()))


def camera(pitch_um, lux=1000.0, seed=0):
    """The sweep's camera at ``pitch_um`` (um): the scaling of the module docstring, a patch of the sensor."""
    from ..camera import Camera
    from ..camera.physical import qe_sensors, read_sensor_sheet, SENSOR_SHEETS
    from ..optics import optics
    from ..simulation import DEFAULT_ARCHITECTURE, bayer

    p = float(pitch_um)
    sheet = read_sensor_sheet(str(SENSOR_SHEETS / "phone-1.4um.json"))
    n = int(PATCH_UM // p)
    well = WELL_PER_UM2 * p * p
    return Camera(
        sensors=qe_sensors(sheet["qe_peak"], sheet["qe_center_nm"], sheet["qe_sigma_nm"], "phone QE"),
        name=f"pitch {p:g} um",
        mosaic=bayer("RGGB"),
        height=n,
        width=n,
        angular_resolution=(_ppd(p),) * 2,
        focal_length=FOCAL_MM,
        pixel_size=(p * 1e-6, p * 1e-6),
        f_stop=F_NUMBER,
        distance=DISTANCE_M,
        exposure=MAX_EXPOSURE_S,
        noise_model="photon",
        read_noise=READ_NOISE,
        electrons_per_dn=well / (2**BITS - 1),
        bits=BITS,
        optics="diffraction",
        fill_factor=((p - TRENCH_UM) / p) ** 2,
        full_well=well,
        dark_current=DARK_PER_UM2 * p * p,
        dsnu=DSNU,
        prnu=PRNU,
        black_level=BLACK_LEVEL,
        seed=seed,
        # the optics stage by itself: its spectral planes at the sensor are blurred once and kept for every
        # light level and seed (the stages after it are run on them)
        architecture=(optics,) + DEFAULT_ARCHITECTURE,
    )


def check_pitches(values, name="pitches"):
    out = [float(v) for v in values]
    bad = [v for v in out if not (np.isfinite(v) and TRENCH_UM < v <= PATCH_UM / 8)]
    if not out or bad:
        raise ParameterError(name, f"pixel pitches must be um in ({TRENCH_UM:g}, {PATCH_UM / 8:g}], got {bad or 'none'}")
    if len(set(out)) != len(out):
        raise ParameterError(name, f"pitches are repeated: {out}")
    return out


def check_lux(values, name="lux"):
    out = [float(v) for v in values]
    bad = [v for v in out if not (np.isfinite(v) and 0 < v <= 1e6)]
    if not out or bad:
        raise ParameterError(name, f"light levels must be positive lux (at most 1e6), got {bad or 'none'}")
    if len(set(out)) != len(out):
        raise ParameterError(name, f"light levels are repeated: {out}")
    return out


def configurations(pitches=PITCHES_UM, lux=LUX, seeds=1, *, demosaic="bilinear"):
    """Validate a grid and list its tasks (pitch x lux x seed index)."""
    pitches, lux, seeds = check_pitches(pitches), check_lux(lux), check_seeds(seeds)
    if demosaic not in ("bilinear", "malvar2004", "menon2007", "bayesian", "freeman"):
        raise ParameterError("demosaic", f"must be a demosaicing method for a Bayer tile, got {demosaic!r}")
    return [PixelSizeConfig(p, v, s, demosaic) for v in lux for p in pitches for s in range(seeds)]


# --- the scene and the ideal image ------------------------------------------------------------


@lru_cache(maxsize=1)
def _reflectance_patch():
    """(H, W, 31) reflectances at 0.5 um sampling and their wavelengths: 24 Macbeth gratings."""
    from ..datasets.surfaces import macbeth
    from ..scene.synthetic import DEFAULT_WAVELENGTHS
    from ..spectra import resample

    w = DEFAULT_WAVELENGTHS
    mw, refl, _ = macbeth()
    r = resample(mw, refl, w)
    r[:, w > mw[-1]] = refl[:, -1:]
    n = int(round(PATCH_UM / SCENE_STEP_UM))
    rows, cols = 4, 6
    ph, pw = n // rows, n // cols
    x = (np.arange(n) + 0.5) * SCENE_STEP_UM * 1e-3  # mm at the sensor
    freqs = np.geomspace(10.0, 400.0, 24)  # cycles/mm at the sensor, one per patch
    out = np.empty((n, n, w.size))
    order = np.argsort(np.random.default_rng(1).random(24))  # spread the frequencies over the colours
    for i in range(24):
        rr, cc = divmod(i, cols)
        ys = slice(rr * ph, (rr + 1) * ph if rr < rows - 1 else n)
        xs = slice(cc * pw, (cc + 1) * pw if cc < cols - 1 else n)
        f = freqs[order[i]]
        # a grating at 45 degrees between the colour and half of it
        g = 0.75 + 0.25 * np.cos(2 * np.pi * f * (x[ys, None] + x[None, xs]) / np.sqrt(2))
        out[ys, xs, :] = g[:, :, None] * r[i][None, None, :]
    return out, w, r


def _illuminant(lux):
    """D65 per 10 nm band scaled so that a perfect white reflector has luminance lux / pi cd/m^2."""
    from ..datasets.illuminants import illuminant
    from ..scene.synthetic import DEFAULT_WAVELENGTHS, scale_to_luminance

    e = illuminant("D65").on(DEFAULT_WAVELENGTHS)
    return e * scale_to_luminance(DEFAULT_WAVELENGTHS, e, lux / np.pi)


def scene(lux):
    """The fine-detail scene at ``lux`` as a :class:`~camsim_core.scene.Scene` (2 m away, 0.5 um per sample at the sensor)."""
    from ..scene import Scene
    from ..spectra import Spectrum

    refl, w, _ = _reflectance_patch()
    e = _illuminant(lux)
    return Scene(refl * e, w, distance=DISTANCE_M, angular_resolution=(_ppd(SCENE_STEP_UM),) * 2,
                 illuminant=Spectrum(w, e, "D65"), name=f"macbeth gratings {lux:g} lux")


def _xyz_weights(w):
    from ..datasets.sensors import cie1931_xyz

    return 683.0 * cie1931_xyz().on(w).T  # (N, 3): radiance per band -> XYZ (cd/m^2)


@lru_cache(maxsize=2)
def _blurred_reflectance_image():
    """The optics stage's output for the scene at 1 lux-equivalent scale (linear in the light level), cached."""
    from ..image import image_from_scene
    from ..optics import optics

    s = scene(1.0)
    return optics(camera(PATCH_UM / 8), image_from_scene(s))


@lru_cache(maxsize=8)
def _ideal(lux):
    """The ideal image (XYZ on the 1 um grid) and the white point at ``lux``."""
    refl, w, _ = _reflectance_patch()
    xyz = (refl * _illuminant(lux)) @ _xyz_weights(w)
    k = int(round(COMPARE_STEP_UM / SCENE_STEP_UM))
    h = xyz.shape[0] // k
    xyz = xyz[: h * k, : h * k].reshape(h, k, h, k, 3).mean(axis=(1, 3))
    white = _illuminant(lux) @ _xyz_weights(w)
    return xyz, white


def colour_matrix(cam, lux):
    """3 x 3 least-squares map from the camera's mean DN (black subtracted) to XYZ over the 24 Macbeth colours."""
    from ..optics import magnification
    from ..simulation import sensor_weights

    _, w, r = _reflectance_patch()
    radiance = r * _illuminant(lux)
    weights, _ = sensor_weights(cam, w)
    dn = radiance @ weights / (1 + magnification(cam.focal_length, DISTANCE_M)) ** 2 * cam.analog_gain
    xyz = radiance @ _xyz_weights(w)
    m, *_ = np.linalg.lstsq(dn, xyz, rcond=None)
    return m  # xyz = dn @ m


def exposure_for(cam, lux):
    """Seconds that put the perfect white's brightest channel at 80 % of the full well (at most 1/30 s)."""
    from ..optics import magnification
    from ..simulation import sensor_weights

    _, w, _ = _reflectance_patch()
    weights, _ = sensor_weights(cam.replace(exposure=1.0), w)
    e_per_s = float(np.max(_illuminant(lux) @ weights)) * cam.electrons_per_dn / (1 + magnification(cam.focal_length, DISTANCE_M)) ** 2
    return min(MAX_EXPOSURE_S, WHITE_FILL * cam.full_well / e_per_s), e_per_s


def pedestal(cam, gain):
    """The black level (DN) at analogue ``gain``: 4 x the dark noise in DN, at least 16 DN, whole DN.

    The dark noise is the read noise, the DSNU and the dark current's shot
    noise (electrons rms) times the system gain: below the pedestal the ADC
    would clip it at 0 and bias a dim field's mean and noise.
    """
    from ..simulation.electrons import system_gain

    dark_e = np.sqrt(cam.read_noise**2 + cam.dsnu**2 + cam.dark_current * cam.exposure)
    return float(max(BLACK_LEVEL, np.ceil(PEDESTAL_SIGMAS * dark_e * system_gain(cam.replace(analog_gain=gain)))))


def operating_point(pitch_um, lux, seed=0):
    """The sweep's camera at ``pitch_um`` as it takes the picture at ``lux``: exposure, analogue gain, pedestal.

    The exposure puts the perfect white at 80 % of the full well (at most
    1/30 s, :func:`exposure_for`); in dim light the analogue gain lifts the
    white to 80 % of the ADC's range above the pedestal (1 to 64 x), and
    the pedestal holds 4 x the dark noise at that gain (:func:`pedestal`; the
    gain is found with the pedestal of the gain that ignores it, so that
    neither the white nor the noise around black clips). Returns ``(camera,
    white electrons)``.
    """
    cam = camera(pitch_um, lux, seed)
    exposure, e_per_s = exposure_for(cam, lux)
    cam = cam.replace(exposure=exposure)
    white_e = min(e_per_s * exposure, cam.full_well)
    full = 2**BITS - 1
    gain = float(np.clip(WHITE_FILL * cam.full_well / white_e, 1.0, MAX_GAIN))
    black = pedestal(cam, gain)
    gain = float(np.clip(WHITE_FILL * cam.full_well * (full - black) / full / white_e, 1.0, MAX_GAIN))
    return cam.replace(analog_gain=gain, black_level=black), white_e


def _to_grid(xyz, pitch_um, n_grid):
    """Bilinear interpolation of a camera image (pitch_um per pixel, centred) onto the comparison grid."""
    from scipy.ndimage import map_coordinates

    h = xyz.shape[0]
    centre_cam, centre_grid = h * pitch_um / 2, n_grid * COMPARE_STEP_UM / 2
    pos = ((np.arange(n_grid) + 0.5) * COMPARE_STEP_UM - centre_grid + centre_cam) / pitch_um - 0.5
    yy, xx = np.meshgrid(pos, pos, indexing="ij")
    return np.stack([map_coordinates(xyz[:, :, c], [yy, xx], order=1, mode="nearest") for c in range(3)], axis=2)


@lru_cache(maxsize=1)
def _edge_optics():
    """A slanted edge (ISO 12233, 5 degrees, 4:1) at the scene's sampling through the lens, at 1 lux (linear in the light)."""
    from ..image import image_from_scene
    from ..optics import optics
    from ..scene.charts import slanted_edge_scene

    n = int(round(PATCH_UM / SCENE_STEP_UM))
    edge = slanted_edge_scene(n, luminance=1.0 / np.pi, distance=DISTANCE_M, angular_resolution=(_ppd(SCENE_STEP_UM),) * 2)
    return optics(camera(PATCH_UM / 8), image_from_scene(edge))


@lru_cache(maxsize=32)
def sharpness(pitch_um, demosaic_method="bilinear"):
    """MTF50 (cycles/mm at the sensor) of the noiseless camera's demosaiced luminance on a slanted edge.

    Lens, pixel aperture, mosaic and demosaicing: what the pitch does to
    resolution, without noise (the edge's light level does not matter).
    """
    from .. import demosaic
    from ..metrics.sharpness import edge_mtf
    from ..simulation import run_stages

    cam = camera(pitch_um).replace(noise_model="gaussian", full_well=None, dark_current=0.0, dsnu=0.0, prnu=0.0,
                                   bits=None, black_level=0.0)
    raw = run_stages(cam, _edge_optics(), [s for s in cam.architecture if s.__name__ != "optics"])
    m = edge_mtf(demosaic(raw, method=demosaic_method))["luminance"]
    return float(m["mtf50"]) / (float(pitch_um) * 1e-3)


def grey_snr(cam, lux):
    """SNR (dB) of the green pixels of the raw of an 18 % grey field at ``lux``: the noise the pitch leaves."""
    from ..metrics.snr import region_snr
    from ..scene.charts import uniform_scene
    from ..simulation import simulate

    n = cam.height
    grey = uniform_scene(n, luminance=0.18 * lux / np.pi, distance=DISTANCE_M, angular_resolution=cam.angular_resolution)
    raw = simulate(grey, cam.replace(optics="none"))  # a uniform field: the blur changes nothing
    return float(region_snr(raw)["G"]["snr_db"])


def evaluate(config):
    """Mean S-CIELAB dE*ab of one camera image against the ideal image, with the sensor's operating point,
    the SNR of an 18 % grey and the MTF50 of a slanted edge."""
    from .. import demosaic
    from ..metrics import scielab
    from ..simulation import run_stages

    t0 = time.perf_counter()
    # ISO: in dim light an analogue gain lifts the white to 80 % of the ADC range, the pedestal the dark noise
    cam, white_e = operating_point(config.pitch_um, config.lux, config.noise_seed)
    exposure, gain = cam.exposure, cam.analog_gain
    blurred = _blurred_reflectance_image()
    light = blurred.replace(data=blurred.data * config.lux)  # the optics are linear in the light level
    raw = run_stages(cam, light, [s for s in cam.architecture if s.__name__ != "optics"])
    full = demosaic(raw, method=config.demosaic)
    xyz_cam = np.asarray(full.data, float) @ colour_matrix(cam, config.lux)
    ideal, white = _ideal(config.lux)
    n_grid = ideal.shape[0]
    # compare where the camera has pixels: the central square its array covers
    cover = int(np.floor(raw.data.shape[0] * config.pitch_um / COMPARE_STEP_UM))
    cover -= (n_grid - cover) % 2  # the same centre as the ideal grid, to the sample
    lo = (n_grid - cover) // 2
    ref = ideal[lo : lo + cover, lo : lo + cover]
    shown = _to_grid(xyz_cam, config.pitch_um, cover)
    spd = SENSOR_MM[1] * 1e3 / COMPARE_STEP_UM / VIEW_DEG
    error = float(np.mean(scielab(shown, ref, spd, white, method="CIE 1976"), dtype=np.float64))
    rec = asdict(config)
    rec.update(noise_seed=config.noise_seed, pixels=int(raw.data.shape[0]), exposure_s=exposure, analog_gain=gain,
               black_level_dn=cam.black_level, white_electrons=white_e, full_well=cam.full_well, fill_factor=cam.fill_factor,
               saturated=float(np.mean(raw.data >= 2**BITS - 1)), error=error, snr_db=grey_snr(cam, config.lux),
               mtf50_cyc_per_mm=sharpness(config.pitch_um, config.demosaic), seconds=time.perf_counter() - t0)
    return rec


def run(*, pitches=PITCHES_UM, lux=LUX, seeds=1, demosaic="bilinear", workers=None, scheduler=None, processes=True,
        progress=False, function=evaluate):
    """Run the sweep; one record per configuration, in grid order (light level, then pitch, then seed)."""
    configs = configurations(pitches, lux, seeds, demosaic=demosaic)
    return run_tasks(function, configs, workers=workers, scheduler=scheduler, processes=processes, progress=progress,
                     desc="pixel-size")


def summarize(records):
    """Mean and standard deviation over seeds of the error: one row per (lux, pitch), with the mean
    grey SNR (dB) and the MTF50 (cycles/mm) beside it when the records hold them."""
    rows = _summarize(records, ("lux", "pitch_um"), ("error",), value_name="measure")
    extra = {}
    for r in records:
        extra.setdefault((r["lux"], r["pitch_um"]), []).append(r)
    for r in rows:
        del r["measure"]
        group = extra[r["lux"], r["pitch_um"]]
        for key in ("snr_db", "mtf50_cyc_per_mm"):
            if all(key in g for g in group):
                r[key] = float(np.mean([g[key] for g in group]))
    return rows


def optimum(summary):
    """{lux: pitch (um) of the lowest mean error}."""
    best = {}
    for r in summary:
        if r["lux"] not in best or r["mean"] < best[r["lux"]][1]:
            best[r["lux"]] = (r["pitch_um"], r["mean"])
    return {k: v[0] for k, v in best.items()}


def table(summary):
    """Rows = pitch, columns = light level: mean S-CIELAB dE*ab (the best pitch of each column starred)."""
    lux = list(dict.fromkeys(r["lux"] for r in summary))
    pitches = sorted(dict.fromkeys(r["pitch_um"] for r in summary))
    index = {(r["lux"], r["pitch_um"]): r for r in summary}
    best = optimum(summary)
    n = max(r["n"] for r in summary)
    head = ["pitch (um) \\ lux"] + [f"{v:g}" for v in lux]
    body = []
    for p in pitches:
        cells = []
        for v in lux:
            r = index.get((v, p))
            cells.append("" if r is None else format_mean_std(r["mean"], r["std"]) + ("*" if best[v] == p else " "))
        body.append([f"{p:g}"] + cells)
    widths = [max(len(x) for x in col) for col in zip(head, *body)]
    lines = [f"Mean S-CIELAB dE*ab against the ideal image, {SENSOR_MM[1]:g} x {SENSOR_MM[0]:g} mm sensor, "
             f"{FOCAL_MM:g} mm f/{F_NUMBER:g}, " + (f"mean ± std over {n} seeds" if n > 1 else "1 seed")
             + "; * = best pitch at that light level"]
    for row in [head] + body:
        lines.append("  ".join([row[0].ljust(widths[0])] + [x.rjust(w) for x, w in zip(row[1:], widths[1:])]))
    return "\n".join(lines)


def figure(summary):
    """Mean S-CIELAB error against pitch, one curve per light level; beside it, when the summary holds them,
    the grey SNR and the MTF50 that the error trades (matplotlib Figure, Agg)."""
    import math

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.ticker import NullFormatter

    measures = all("snr_db" in r and "mtf50_cyc_per_mm" in r for r in summary)
    fig = Figure(figsize=(13.0 if measures else 6.4, 4.2), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 3 if measures else 1, squeeze=False)[0]
    ax = axes[0]
    best = optimum(summary)
    lux_levels = list(dict.fromkeys(r["lux"] for r in summary))
    colours = {}
    for v in lux_levels:
        rows = sorted((r for r in summary if r["lux"] == v), key=lambda r: r["pitch_um"])
        p = np.array([r["pitch_um"] for r in rows])
        m = np.array([r["mean"] for r in rows])
        s = np.array([r["std"] if math.isfinite(r["std"]) else 0.0 for r in rows])
        line = ax.errorbar(p, m, yerr=s if np.any(s > 0) else None, marker="o", ms=3, capsize=2, label=f"{v:g} lux")
        colours[v] = line[0].get_color()
        ax.plot([best[v]], [min(m)], marker="*", ms=12, color=colours[v])
        if measures:
            axes[1].plot(p, [r["snr_db"] for r in rows], marker="o", ms=3, color=colours[v], label=f"{v:g} lux")
    ax.set_ylabel("mean S-CIELAB ΔE*ab")
    ax.set_ylim(bottom=0)
    ax.legend(title="scene illuminance", fontsize="small")
    ax.set_title(f"Error against the ideal image (★ = best pitch)", fontsize="medium")
    if measures:
        rows = sorted((r for r in summary if r["lux"] == lux_levels[0]), key=lambda r: r["pitch_um"])
        axes[2].plot([r["pitch_um"] for r in rows], [r["mtf50_cyc_per_mm"] for r in rows], marker="o", ms=3, color="black")
        axes[1].set_ylabel("SNR of an 18 % grey, green pixels (dB)")
        axes[1].set_title("Noise: SNR grows with the pixel", fontsize="medium")
        axes[2].set_ylabel("MTF50 (cycles/mm at the sensor)")
        axes[2].set_ylim(bottom=0)
        axes[2].set_title("Sharpness: MTF50 of a slanted edge (noiseless)", fontsize="medium")
    for a in axes:
        a.set_xscale("log")
        a.xaxis.set_minor_formatter(NullFormatter())
        a.set_xticks([1, 1.4, 2, 2.8, 4, 5.6], labels=["1", "1.4", "2", "2.8", "4", "5.6"])
        a.set_xlabel("pixel pitch (µm), fixed 4.8 x 3.6 mm sensor")
        a.grid(True, alpha=0.3)
    fig.suptitle(f"Pixel size: noise against resolution ({FOCAL_MM:g} mm f/{F_NUMBER:g} lens, bilinear demosaic)",
                 fontsize="medium")
    return fig


def write_outputs(records, folder):
    """Write ``pixel-size-records.csv``, ``pixel-size-summary.csv`` and ``pixel-size.png``; return the paths."""
    from .plot import save_png

    folder = Path(folder)
    summary = summarize(records)
    best = optimum(summary)
    rows = [{**r, "best_pitch_um": best[r["lux"]]} for r in summary]
    return [
        write_csv(records, folder / "pixel-size-records.csv", _RECORD_COLUMNS + ("demosaic",)),
        write_csv(rows, folder / "pixel-size-summary.csv", ("lux", "pitch_um", "mean", "std", "n", "snr_db", "mtf50_cyc_per_mm",
                                                            "best_pitch_um")),
        save_png(figure(summary), folder / "pixel-size.png"),
    ]
