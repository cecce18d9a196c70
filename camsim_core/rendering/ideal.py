"""The ideal comparison image (chapter section 4.3, "Generation of a comparison image").

A camera with the human cone sensitivities (``camera_preset("human-cones")``),
no mosaic and no noise, but the given camera's geometry (angular
resolution, distance, pixel array, lens, blur) and its quantization, is
simulated on the scene and rendered by the baseline method on the same
monitor, with the same display scale rule as every camera image.
"""

from __future__ import annotations

from ..camera import camera_preset, load_camera

__all__ = ["ideal_camera", "ideal_image", "render_ideal"]


def ideal_camera(camera):
    """The ideal (cone, non-mosaiced, noiseless, pedestal-free, linear) counterpart of ``camera``."""
    cam = load_camera(camera)
    cones = camera_preset("human-cones").sensors
    return cam.replace(
        name=f"ideal({cam.name})",
        sensors=cones,
        mosaic=None,
        noise_model="gaussian",
        noise_mean=0.0,
        noise_sigma=0.0,
        black_level=0.0,
        read_noise=0.0,
        full_well=None,
        dark_current=0.0,
        dsnu=0.0,
        prnu=0.0,
        analog_gain=1.0,
        nonlinearity=None,
        bits=cam.bits if cam.bits is not None else 8,
    )


def ideal_image(scene, camera, monitor, *, white=None, scale=None, **simulate_kwargs):
    """The rendered ideal image of ``scene`` for ``camera`` on ``monitor`` (a CameraImage, space "monitor").

    ``simulate_kwargs`` (distance, exposure, f_stop, seed) go to
    :func:`~camsim_core.simulation.simulate` as for the camera itself. The
    ideal camera uses the same exposure; pick one at which neither camera
    saturates (the cones are on the DCS-200's common scale, so the levels
    are similar). ``white`` / ``scale``: see :func:`camsim_core.render`.
    """
    from ..simulation import simulate

    raw = simulate(scene, ideal_camera(camera), **simulate_kwargs)
    return render_ideal(raw, monitor, name=f"ideal {scene.name}", white=white, scale=scale)


def render_ideal(raw, monitor, *, name, white=None, scale=None):
    """The ideal camera's simulated image ``raw`` rendered as the ideal image (baseline, on ``monitor``),
    named ``name``: the second half of :func:`ideal_image`, for a cache that simulated the ideal camera itself."""
    from ..monitor import load_monitor
    from . import render

    out = render(raw, load_monitor(monitor), method="baseline", white=white, scale=scale)
    return out.then("ideal", name=name)
