"""How a raw frame is exposed, and the warnings a score made from it must carry.

An error against the ideal image scores what the camera recorded. A black
frame (nothing above the pedestal: exposure 1e-4 s on the chapter's scene)
or a clipped one (values at the ADC's full scale, only a lower bound of the
light) recorded little or nothing of the scene, whatever its dE says: with
a reference quantized like the camera, a black frame scored a mean dE of
0.00 against a reference as black as itself. :func:`exposure_measures`
measures the frame; :meth:`ExposureMeasures.flags` says, in words, why its
score is not a good one; the explorer shows them beside the dE it headlines
(:attr:`camsim_core.cache.Result.exposure`).

The measures, per pixel of the raw (a mosaic's pixel is one sample; a
full-colour pixel is clipped when any of its sensors is, at the black level
when all are):

* ``clipped``: the share of pixels at the full scale (``2**bits - 1``, a
  half step below counting when quantized); 0 for a raw without a bit
  depth, which no ADC clipped. Given the camera, an electron-level sensor's
  pixels at its full well count too (:func:`saturation_level`): when the
  full well times the system gain is below the ADC's full scale, a pixel
  saturates in the sensor, at a value no ADC clipped (``limit`` then says
  "the full well");
* ``black``: the share at or below the black level (the pedestal, a half
  step above counting when quantized): no light recorded;
* ``signal``: the mean value above the pedestal as a fraction of the range
  above it (without a bit depth: up to the full well's level for an
  electron-level sensor given with its camera, else 255, the engine's
  display convention; with 255, imx174 unquantized at 0.05 s read 89.5 % of
  its range, where its full well puts it at 5.6 %).

Flags: a *black frame* when at least half the pixels are at the black
level; *under-exposed* when the mean signal is below 2 % of the range (a
frame with a range: unquantized in digital units, it has none);
*clipped* when at least 1 % of the pixels are at full scale or at the
full well (*fully clipped* from 99 %); an *empty frame* has no pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ExposureMeasures", "exposure_measures", "exposure_flags", "saturation_level", "CLIPPED_SHARE", "BLACK_SHARE",
           "DIM_SIGNAL", "SATURATION_SIGMAS"]

#: Share of pixels at full scale from which a frame is flagged clipped.
CLIPPED_SHARE = 0.01
#: Share of pixels at the black level from which a frame is flagged black.
BLACK_SHARE = 0.5
#: Mean signal (fraction of the range above the pedestal) below which a frame is flagged under-exposed.
DIM_SIGNAL = 0.02
#: A pixel within this many standard deviations of the read-out (read noise and DSNU, added after the charge is
#: clipped at the full well) below the full well's value counts as saturated: it cannot be told from one.
SATURATION_SIGMAS = 3.0


@dataclass(frozen=True)
class ExposureMeasures:
    """The exposure of one raw frame (see the module docstring). Shares are fractions 0..1."""

    pixels: int
    clipped: float
    black: float
    signal: float
    #: What a clipped pixel is at: "full scale" (the ADC's), or "the full well" (a sensor saturating below it).
    limit: str = "full scale"
    #: Whether the frame has a range to be a share of: an ADC's or a full well's. Unquantized in digital units (the
    #: chapter's cameras at 0 bits) it has none: ``signal`` is then a share of 255, the display's convention, and
    #: no frame is under-exposed by it (the DCS-200 at a thousandth of its light was, with the dE of a fair one).
    bounded: bool = True

    @property
    def flags(self):
        """Why a score of this frame is not a good one: a tuple of short sentences (empty for a fair frame)."""
        out = []
        if self.pixels == 0:
            return ("empty frame: no pixels",)
        if self.black >= BLACK_SHARE:
            out.append(f"black frame: {_percent(self.black)} of pixels at the black level")
        elif self.signal < DIM_SIGNAL and self.bounded:
            out.append(f"under-exposed: mean signal {_percent(self.signal)} of full scale")
        if self.clipped >= 0.99:
            out.append(f"fully clipped: {_percent(self.clipped)} of pixels at {self.limit}")
        elif self.clipped >= CLIPPED_SHARE:
            out.append(f"clipped: {_percent(self.clipped)} of pixels at {self.limit}")
        return tuple(out)

    def as_dict(self):
        return {"pixels": self.pixels, "clipped": self.clipped, "black": self.black, "signal": self.signal,
                "limit": self.limit, "bounded": self.bounded, "flags": list(self.flags)}


def _percent(share):
    """A share as a percentage to a tenth (as the explorer's exposure line gives it: "clipped: 70 %" stood beside
    "69.5 % of pixels are clipped"), never rounded to 0 % or 100 % unless it is.

    Examples
    --------
    >>> _percent(0.695), _percent(1.0), _percent(0.0), _percent(0.9995), _percent(0.0004)
    ('69.5 %', '100 %', '0 %', '> 99.9 %', '< 0.1 %')
    """
    p = 100.0 * share
    if 0 < p < 0.1:
        return "< 0.1 %"
    if 99.9 < p < 100:
        return "> 99.9 %"
    return f"{p:.0f} %" if p in (0.0, 100.0) else f"{p:.1f} %"


def _per_pixel(level, image, data):
    """The pedestal or full scale as an array that broadcasts against ``data`` (one per class, by pixel)."""
    level = np.asarray(level, float)
    if level.ndim == 0:
        return level
    if image.mosaiced and image.tile is not None:
        from ..simulation.mosaic import tile_index_map

        per = level[tile_index_map(image.tile, data.shape[:2])]
        return per if per.shape == data.shape else per.reshape(data.shape)
    return level  # one per sensor, along the last axis of a full-colour image


def saturation_level(camera):
    """The value (digital units above the black level, before the ADC rounds and clips) from which a pixel of
    ``camera``'s electron-level sensor is at its full well; None for a sensor without one.

    The sensor (:func:`camsim_core.simulation.electrons.electron_sensor`) clips the charge at ``full_well``
    electrons, then adds the DSNU and the read noise (e- rms) and multiplies by the system gain
    K = ``analog_gain / electrons_per_dn`` DN/e-, adding ``noise_mean``; the ADC applies the static
    non-linearity. A saturated pixel is therefore at K x full_well
    (:func:`~camsim_core.simulation.electrons.full_well_level`) + noise_mean, spread by the read-out's
    noise: the level returned is :data:`SATURATION_SIGMAS` standard deviations of it below (at most 5 % of the
    full well below), so that a saturated pixel is counted whatever its read-out noise.
    """
    from ..simulation.electrons import full_well_level, system_gain

    top = full_well_level(camera)  # K x full_well, the one definition auto exposure shares
    if top is None:
        return None
    well = float(camera.full_well)
    spread = float(np.hypot(camera.read_noise, camera.dsnu))
    level = top - min(SATURATION_SIGMAS * spread, 0.05 * well) * system_gain(camera) + float(camera.noise_mean)
    if camera.nonlinearity is not None and camera.bits is not None:
        from ..simulation.digitize import apply_nonlinearity

        level = float(apply_nonlinearity(np.array([level]), float(2 ** camera.bits - 1), camera.nonlinearity)[0])
    return level


def exposure_measures(raw, camera=None):
    """The :class:`ExposureMeasures` of a raw camera image (digital units, its pedestal still in its data).

    ``camera``: the camera that made it; an electron-level sensor's pixels at its full well then count as
    clipped (:func:`saturation_level`), not only those at the ADC's full scale.
    """
    data = np.asarray(raw.data)
    if data.dtype not in (np.float32, np.float64):
        data = data.astype(np.float64)
    full_colour = not raw.mosaiced and data.ndim == 3
    pixels = int(np.prod(data.shape[:2])) if data.ndim >= 2 else int(data.size)
    if pixels == 0 or data.size == 0:
        return ExposureMeasures(0, 0.0, 0.0, 0.0)
    black = _per_pixel(raw.black_level, raw, data)
    half = 0.5 if raw.quantized else 0.0
    at_black = data <= black + half
    full = raw.full_scale
    if full is not None:
        clipped = data >= full - half
    else:
        clipped = np.zeros(data.shape, bool)
    limit = "full scale"
    well = saturation_level(camera)
    if well is not None:
        at_well = data >= black + well - half
        if full is None or np.any(np.asarray(black + well, float) < full - half):  # saturates before the ADC clips
            limit = "the full well"
        clipped |= at_well
    if full_colour:
        at_black, clipped = at_black.all(axis=2), clipped.any(axis=2)
    elif data.ndim == 3:  # tiers of a mosaic: one pixel, several samples
        at_black, clipped = at_black.all(axis=2), clipped.any(axis=2)
    if full is None and well is not None:  # unquantized, an electron-level sensor: its range ends at the full well
        top = np.asarray(float(well))
    else:
        top = _per_pixel((full if full is not None else 255.0) - np.asarray(raw.black_level, float), raw, data)
    if np.ndim(black) == 0 and np.ndim(top) == 0:  # one pedestal: no full-size temporary
        signal = (float(np.mean(data, dtype=np.float64)) - float(black)) / max(float(top), 1e-12)
    else:
        signal = float(np.mean((data - black) / np.maximum(top, 1e-12)))
    return ExposureMeasures(pixels, float(np.mean(clipped)), float(np.mean(at_black)), signal, limit,
                            bounded=full is not None or well is not None)


def exposure_flags(raw, camera=None):
    """The flags of :func:`exposure_measures` of ``raw`` (a tuple of short sentences)."""
    return exposure_measures(raw, camera).flags
