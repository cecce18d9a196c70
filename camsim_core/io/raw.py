"""Wrapping real raw mosaics as camera images. [stub: issue 3]"""


def raw_from_array(array, tile, **metadata):
    raise NotImplementedError("raw_from_array is being written (issue 3)")
