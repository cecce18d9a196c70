"""The stage decorator: what camera fields a stage reads, for caching downstream work."""

__all__ = ["stage"]


def stage(*uses):
    """Mark a function ``f(camera, image) -> image`` as a pipeline stage.

    ``uses`` names the camera fields the stage reads; a cache (the explorer's)
    re-runs a stage only when one of them, or its input image, changed.
    """

    def mark(func):
        func.uses = tuple(uses)
        func.is_stage = True
        return func

    return mark
