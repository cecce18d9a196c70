"""Stage 3: the sensor mosaic, any periodic tile (chapter 3.1 "Mosaicing")."""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ..image import check_tile
from .._parallel import CORES, run_blocks, split
from ._stage import stage

__all__ = ["mosaic", "tile_index_map", "BAYER", "bayer", "FOUR_SENSOR_GRID"]

#: The Bayer tile in its four phases (0-based R=0, G=1, B=2), by the colours of its top row.
BAYER = {
    "GRBG": np.array([[1, 0], [2, 1]]),
    "RGGB": np.array([[0, 1], [1, 2]]),
    "BGGR": np.array([[2, 1], [1, 0]]),
    "GBRG": np.array([[1, 2], [0, 1]]),
}

#: Figure 1.15's regular square grid of four sensor classes 1-4 (0-based 0-3).
FOUR_SENSOR_GRID = np.array([[0, 1], [2, 3]])


def bayer(phase="GRBG", order=(0, 1, 2)):
    """A Bayer tile; ``order`` gives the sensor indices used for R, G and B."""
    if phase not in BAYER:
        raise ParameterError("phase", f"unknown Bayer phase {phase!r}; one of {', '.join(BAYER)}")
    return np.asarray(order)[BAYER[phase]]


def tile_index_map(tile, shape):
    """The tile repeated over an image of ``shape`` (H, W): (H, W) or (H, W, tiers) sensor indices."""
    t = np.asarray(tile)
    H, W = shape
    n, m = t.shape[:2]
    reps = (-(-H // n), -(-W // m)) + ((1,) if t.ndim == 3 else ())
    return np.tile(t, reps)[:H, :W]


def _one_plane(planes, tile):
    """planes (H, W, K) -> (H, W): at each tile position, a strided copy of the plane it samples.

    The same values as ``take_along_axis`` with the repeated index map,
    without building that map (n x m strided copies instead of a full-frame
    gather).
    """
    H, W = planes.shape[:2]
    out = np.empty((H, W), planes.dtype)
    n, m = tile.shape

    def copy(a, b):  # rows a..b, a a whole number of tiles down: the tile's phase is the image's
        for py in range(min(n, b - a)):
            for px in range(min(m, W)):
                out[a + py : b : n, px::m] = planes[a + py : b : n, px::m, tile[py, px]]

    # blocks of whole tile rows on the machine's cores (numpy's copies release the GIL)
    run_blocks(copy, split(-(-H // n), CORES) * n, values=out.size)
    return out


@stage("mosaic")
def mosaic(camera, image):
    """Keep at each pixel only the response of the sensor its tile position names.

    The result is one plane (H, W) plus the tile, as a raw file holds it, or
    (H, W, tiers) for a tiered (field-sequential) tile. No tile: unchanged.
    """
    if camera.mosaic is None:
        return image
    if image.space != "sensor" or image.mosaiced:
        raise ParameterError("mosaic", f"needs full sensor planes, got a {'mosaiced ' if image.mosaiced else ''}{image.space} image")
    tile = check_tile(camera.mosaic, image.data.shape[2], "mosaic")
    if tile.ndim == 2:
        data = _one_plane(image.data, tile)
    else:
        idx = tile_index_map(tile, image.data.shape[:2])
        data = np.take_along_axis(image.data, idx, axis=2)
    return image.then("mosaic", data=data, tile=tile, mosaiced=True)
