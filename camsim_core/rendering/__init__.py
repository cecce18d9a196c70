"""Colour balancing and rendering, and the ideal image (chapter sections 4.2, 4.3). [stub: issue 3]"""


def render(image, monitor, method="baseline", illuminant=None, dimensions=None, **options):
    raise NotImplementedError("render is being written (issue 3)")


def to_xyz(rendered, monitor):
    raise NotImplementedError("to_xyz is being written (issue 3)")


def ideal_image(scene, camera, monitor, **simulate_kwargs):
    raise NotImplementedError("ideal_image is being written (issue 3)")
