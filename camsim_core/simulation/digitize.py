"""Stage 5: digitization, with an optional static non-linearity (chapter 3.1 "Digitization")."""

from __future__ import annotations

import numpy as np

from ._stage import stage

__all__ = ["digitize", "apply_nonlinearity"]


def apply_nonlinearity(values, full_scale, nonlinearity):
    """The static non-linearity on values in [0, full_scale].

    A number g maps v to full * (v / full) ** g; an array is a lookup table of
    normalized outputs at evenly spaced normalized inputs over [0, 1].
    """
    x = np.clip(values / full_scale, 0.0, 1.0)
    if np.isscalar(nonlinearity):
        y = x ** float(nonlinearity)
    else:
        lut = np.asarray(nonlinearity, float)
        y = np.interp(x, np.linspace(0.0, 1.0, lut.size), lut)
    return y * full_scale


@stage("bits", "nonlinearity")
def digitize(camera, image):
    """Round and clip to [0, 2**bits - 1], after the static non-linearity if any.

    ``bits=None``: no quantization, the image passes unchanged.
    """
    if camera.bits is None:
        return image
    full = float(2 ** camera.bits - 1)
    data = np.asarray(image.data, float)
    if camera.nonlinearity is not None:
        data = apply_nonlinearity(data, full, camera.nonlinearity)
    out = np.clip(np.rint(data), 0.0, full)
    return image.then("digitize", data=out, bits=camera.bits, quantized=True)
