"""How the rendered image is viewed: the samples per degree of S-CIELAB (chapter section 4.3).

S-CIELAB filters each opponent channel with Gaussians whose widths are fixed
in degrees of visual angle, so its result depends on how many image samples
fall in one degree at the observer's eye. That is a property of the viewing,
not of the image: the same rendered picture seen from twice as far has
twice as many samples per degree, and the eye's blur then hides more of its
noise and mosaic artifacts.

A viewing is given by a short text (:func:`parse_viewing`; the command
line's ``--viewing``) or built as :class:`Viewing`:

``camera`` (the default, the chapter's choice)
    The chapter neglects image size (section 4.3: "any differences in image
    size between the original scene and the rendered image may be
    neglected"): the rendered image subtends at the eye the angle the scene
    subtended at the camera, so the samples per degree are the camera's
    angular resolution (102.6 for the Kodak DCS-200 with its 50 mm lens: a
    372-pixel-wide image spans 3.6 degrees).
``camera/N``
    The camera's angular resolution divided by ``N``: the image seen ``N``
    times larger. ``camera/10`` is the original simulator's only S-CIELAB
    example (10.26 samples per degree for the DCS-200: the same image spans
    36 degrees).
``spd:S`` or a bare number ``S``
    ``S`` samples per degree directly.
``display:PITCHmm@DISTANCEm`` or ``PITCH@DISTANCE``
    One image pixel per display pixel of pitch ``PITCH`` mm, seen from
    ``DISTANCE`` m: ``1 / (2 atan(pitch / (2 distance)))`` samples per
    degree (e.g. 0.25 mm at 0.6 m: 41.9).

Every result that uses S-CIELAB says which viewing and which samples per
degree it used (:meth:`Viewing.describe`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ..errors import ParameterError
from .s_cielab import display_samples_per_degree, samples_per_degree as camera_samples_per_degree

__all__ = ["Viewing", "parse_viewing", "DEFAULT_VIEWING", "ORIGINAL_EXAMPLE_VIEWING", "viewing_samples_per_degree"]

#: The default viewing: the chapter's (samples per degree = the camera's angular resolution).
DEFAULT_VIEWING = "camera"
#: The original simulator's S-CIELAB example: the angular resolution divided by 10.
ORIGINAL_EXAMPLE_VIEWING = "camera/10"

_KINDS = ("camera", "samples", "display")


def _positive(value, name):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(name, f"must be a positive number, got {value!r}") from None
    if not (v > 0 and math.isfinite(v)):
        raise ParameterError(name, f"must be a positive, finite number, got {value!r}")
    return v


@dataclass(frozen=True)
class Viewing:
    """How the rendered image is viewed.

    Attributes
    ----------
    kind : {"camera", "samples", "display"}
    divisor : float
        For "camera": the angular resolution is divided by this (1 = the chapter, 10 = the original's example).
    samples_per_degree : float or None
        For "samples".
    pixel_pitch_mm, distance_m : float or None
        For "display": the display's pixel pitch (mm) and the viewing distance (m).
    """

    kind: str = "camera"
    divisor: float = 1.0
    samples_per_degree: float | None = None
    pixel_pitch_mm: float | None = None
    distance_m: float | None = None

    def __post_init__(self):
        if self.kind not in _KINDS:
            raise ParameterError("viewing", f"kind must be one of {', '.join(_KINDS)}, got {self.kind!r}")
        object.__setattr__(self, "divisor", _positive(self.divisor, "viewing divisor"))
        if self.kind == "samples":
            object.__setattr__(self, "samples_per_degree", _positive(self.samples_per_degree, "samples_per_degree"))
        if self.kind == "display":
            object.__setattr__(self, "pixel_pitch_mm", _positive(self.pixel_pitch_mm, "pixel_pitch"))
            object.__setattr__(self, "distance_m", _positive(self.distance_m, "viewing_distance"))

    @property
    def spec(self):
        """The canonical text of this viewing (parsed back by :func:`parse_viewing`)."""
        if self.kind == "camera":
            return "camera" if self.divisor == 1 else f"camera/{self.divisor:g}"
        if self.kind == "samples":
            return f"spd:{self.samples_per_degree:g}"
        return f"display:{self.pixel_pitch_mm:g}mm@{self.distance_m:g}m"

    def rate(self, image=None):
        """Samples per degree for ``image`` (anything with ``angular_resolution``; needed for "camera")."""
        if self.kind == "samples":
            return self.samples_per_degree
        if self.kind == "display":
            return display_samples_per_degree(self.pixel_pitch_mm * 1e-3, self.distance_m)
        if image is None:
            raise ParameterError("viewing", f"{self.spec!r} needs the camera image's angular resolution")
        return camera_samples_per_degree(image) / self.divisor

    def describe(self, image=None):
        """One line: the samples per degree and where they come from."""
        if self.kind == "samples":
            how = "given directly"
        elif self.kind == "display":
            how = f"one image pixel per {self.pixel_pitch_mm:g} mm display pixel seen from {self.distance_m:g} m"
        elif self.divisor == 1:
            how = "the camera's angular resolution: the image seen under the scene's visual angle (the chapter)"
        else:
            base = "" if image is None else f" {camera_samples_per_degree(image):g}"
            how = f"the camera's angular resolution{base} / {self.divisor:g}" + (
                " (the original's S-CIELAB example)" if self.divisor == 10 else "")
        rate = "" if (self.kind == "camera" and image is None) else f"{self.rate(image):.4g} samples/deg, "
        return f"S-CIELAB viewing {self.spec}: {rate}{how}"


_NUMBER = r"([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)"


def parse_viewing(value=None):
    """A :class:`Viewing` from ``None`` (the default), a Viewing, a number (samples per degree) or a text.

    Texts: ``camera``, ``camera/N``, ``spd:S`` (or ``S``), ``display:PITCHmm@DISTANCEm``
    (or ``PITCH@DISTANCE``, mm and m). Anything else is a :class:`ParameterError`.

    Examples
    --------
    >>> parse_viewing("camera/10").spec, parse_viewing(23).spec
    ('camera/10', 'spd:23')
    """
    if value is None:
        value = DEFAULT_VIEWING
    if isinstance(value, Viewing):
        return value
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return Viewing("samples", samples_per_degree=value)
    text = str(value).strip().lower().replace(" ", "")
    if text == "camera":
        return Viewing("camera")
    m = re.fullmatch(r"camera/" + _NUMBER, text)
    if m:
        return Viewing("camera", divisor=float(m.group(1)))
    m = re.fullmatch(r"(?:spd:)?" + _NUMBER, text)
    if m:
        return Viewing("samples", samples_per_degree=float(m.group(1)))
    m = re.fullmatch(r"(?:display:)?" + _NUMBER + r"(?:mm)?@" + _NUMBER + r"m?", text)
    if m:
        return Viewing("display", pixel_pitch_mm=float(m.group(1)), distance_m=float(m.group(2)))
    raise ParameterError(
        "viewing",
        f"{value!r} is not a viewing; expected camera, camera/N (e.g. camera/10), spd:S or a number of samples "
        "per degree, or display:PITCHmm@DISTANCEm (e.g. display:0.25mm@0.6m)",
    )


def viewing_samples_per_degree(viewing, image=None):
    """Samples per degree for ``image`` under ``viewing`` (anything :func:`parse_viewing` takes).

    Examples
    --------
    >>> viewing_samples_per_degree("spd:10.26")
    10.26
    """
    return parse_viewing(viewing).rate(image)
