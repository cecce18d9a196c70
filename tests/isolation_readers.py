"""Readers that misbehave on purpose, for the worker-process tests (imported by name in the worker)."""

import ctypes
import time

import numpy as np


def crash(filename, content, limits):
    ctypes.string_at(0)  # a read of address 0: SIGSEGV, as scipy's compiled reader did


def spin(filename, content, limits):
    while True:
        pass


def sleep(filename, content, limits):
    time.sleep(3600)


def hog(filename, content, limits):
    blocks = []
    while True:
        blocks.append(np.ones(2**27))  # 1 GiB at a time


def exits(filename, content, limits):
    import os

    os._exit(0)


def raises(filename, content, limits):
    return 1 / 0  # a reader's bug (not a CamsimError)
