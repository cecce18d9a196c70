"""The lens: irradiance at the sensor and diffraction-limited blur (an optional stage before the sensor).

* :mod:`.diffraction` - the OTF of a circular aperture, with and without defocus;
* :mod:`.irradiance` - the camera equation, cos^4 relative illumination, magnification;
* :mod:`.stage` - the ``optics`` stage on the spectral planes;
* :mod:`.fused` - the lens and the sensor responses in one stage (a low-rank OTF over wavelength).
"""

from .diffraction import MIN_F_NUMBER, cutoff_frequency, defocus_otf, defocus_waves, diffraction_mtf
from .irradiance import cos4, field_angles, image_distance, image_irradiance, magnification, sample_pitch
from .fused import OTF_TOLERANCE, lens_sensor_responses, otf_factors
from .stage import OPTICS, blur_planes, optics, optics_active, plane_otfs, relative_illumination_map, sensor_irradiance, \
    working_f_number

__all__ = [
    "diffraction_mtf",
    "cutoff_frequency",
    "defocus_otf",
    "defocus_waves",
    "MIN_F_NUMBER",
    "magnification",
    "image_distance",
    "image_irradiance",
    "cos4",
    "field_angles",
    "sample_pitch",
    "optics",
    "lens_sensor_responses",
    "otf_factors",
    "OTF_TOLERANCE",
    "optics_active",
    "blur_planes",
    "plane_otfs",
    "relative_illumination_map",
    "sensor_irradiance",
    "OPTICS",
    "working_f_number",
]
