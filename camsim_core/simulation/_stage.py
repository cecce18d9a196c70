"""The stage decorator: what camera fields a stage reads, for caching downstream work."""

__all__ = ["stage"]


def stage(*uses, prepare=None):
    """Mark a function ``f(camera, image) -> image`` as a pipeline stage.

    ``uses`` names the camera fields the stage reads; a cache (the explorer's)
    re-runs a stage only when one of them, or its input image, changed.

    ``prepare``, optional, is ``(first, first_uses, finish)``: the stage in
    two parts, ``f(camera, image) == finish(camera, first(camera, image),
    reuse=True)``, where ``first`` reads only the fields ``first_uses``. A
    cache keeps ``first``'s value while those fields and the input stay the
    same and re-runs ``finish`` alone (``reuse=False``: it must not modify
    the kept value), with the numbers of the whole stage. The sensor stage
    is so split: its sums over the spectral planes do not depend on exposure.
    """
    if prepare is not None:
        first, first_uses, finish = prepare
        if not (callable(first) and callable(finish)) or not set(first_uses) <= set(uses):
            raise ValueError("prepare must be (first, first_uses, finish): two functions, and fields among the stage's uses")

    def mark(func):
        func.uses = tuple(uses)
        func.is_stage = True
        if prepare is not None:
            func.prepare = (prepare[0], tuple(prepare[1]), prepare[2])
        return func

    return mark
