"""Reading an upload in a worker process of its own: a crash, a hang or a bomb costs only that read.

The readers check every field, but they stand on compiled libraries
(scipy's MATLAB reader, HDF5, Pillow's decoders, zlib) that a crafted file
has crashed before, and on decompressors whose cost grows with what a file
claims. A server that parses an upload in its own process stakes every
session on them. :func:`load_upload_isolated` runs
:func:`~camsim_core.io.upload.load_upload` in a child process started from
a fork server (safe in a threaded server: the child is forked from a clean
single-threaded process, with the readers already imported), under limits
the child sets on itself before it reads a byte:

* address space: its size at start plus ``worker_memory_bytes``
  (``RLIMIT_AS``): an allocation past it fails in the child;
* CPU time: ``worker_cpu_seconds`` (``RLIMIT_CPU``, then ``SIGXCPU``);
* files it may write: no larger than a zip member may be (``RLIMIT_FSIZE``),
  and no core dumps;
* priority: ``nice`` 10, below the sessions' own work;
* wall time: the parent waits ``worker_wall_seconds`` at most, then kills it.

At most :data:`MAX_WORKERS` reads run at once in the whole server; more wait
their turn (in the caller's thread, never the event loop). The child sends
back the scene's fields; the parent builds the :class:`Scene` itself, so
every check of ``Scene`` runs again in the trusted process. Every failure
becomes a :class:`~camsim_core.errors.FileFormatError` naming the user's
file.

Hand-written: the standard library has the pieces (``multiprocessing``
fork server, ``resource.setrlimit``) but no bounded call with them.

Examples
--------
>>> import io, numpy as np
>>> from camsim_core.scene import macbeth_scene, save_npz_scene
>>> buf = io.BytesIO()
>>> np.savez(buf, data=np.ones((2, 3, 31)), wavelengths=np.arange(400.0, 701.0, 10.0))
>>> load_upload_isolated("cube.npz", buf.getvalue()).shape
(2, 3, 31)
"""

from __future__ import annotations

import dataclasses
import os
import signal
import threading

from ..errors import CamsimError, FileFormatError
from .upload import DEFAULT_LIMITS, load_upload, upload_name

__all__ = ["load_upload_isolated", "warm_up", "MAX_WORKERS"]

#: Most upload reads running at once in one server (each is a process with its own memory bound).
MAX_WORKERS = 2
_slots = threading.BoundedSemaphore(MAX_WORKERS)
_context = None
_context_lock = threading.Lock()
#: Modules the fork server imports once, so that each read's child starts with them loaded.
_PRELOAD = ["camsim_core.io.upload", "camsim_core.scene.matlab", "camsim_core.scene.photo", "camsim_core.scene.envi",
            "camsim_core.scene.cave", "scipy.io", "h5py", "PIL.Image"]


def _get_context():
    global _context
    with _context_lock:
        if _context is None:
            import multiprocessing

            ctx = multiprocessing.get_context("forkserver")
            ctx.set_forkserver_preload(_PRELOAD)
            _context = ctx
        return _context


def _nothing():
    """The worker :func:`warm_up` starts: it reads nothing."""


def warm_up():
    """Start the fork server now and one worker through it (a server calls it at start), so that the first
    upload waits for neither.

    The first worker a process starts also imports the parent's side of the fork server's protocol: 0.25 s
    for a first upload against 0.035 s for the next (measured on a quiet machine), held by the thread that
    started it, and so partly by the event loop (the first upload of the hostile load test of issue 36 made
    that round the slowest)."""
    from multiprocessing import forkserver

    ctx = _get_context()
    try:
        forkserver.ensure_running()
    except OSError as exc:
        if "path too long" not in str(exc):
            raise
        import tempfile

        from ..errors import ParameterError

        raise ParameterError("TMPDIR", f"the temporary directory {tempfile.gettempdir()!r} has too long a path for the "
                             "upload readers' socket (a socket's path is at most 107 bytes); set TMPDIR to a "
                             "shorter one, or serve with --no-upload") from None
    proc = ctx.Process(target=_nothing, name="camsim-upload-warm-up", daemon=True)
    proc.start()
    proc.join(30)


def _address_space():
    """This process's virtual size, bytes (Linux ``/proc/self/status``), or None elsewhere."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def _limit_self(limits):
    import resource

    base = _address_space()
    if base is not None:
        resource.setrlimit(resource.RLIMIT_AS, (base + limits.worker_memory_bytes,) * 2)
    resource.setrlimit(resource.RLIMIT_CPU, (limits.worker_cpu_seconds, limits.worker_cpu_seconds + 1))
    resource.setrlimit(resource.RLIMIT_FSIZE, (limits.max_member_bytes + 2**20,) * 2)
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    os.nice(10)


def _child(conn, filename, content, limits, reader):
    """The worker: limits first, then the read; sends ("scene", fields) or ("error", message)."""
    try:
        _limit_self(limits)
        scene = reader(filename, content, limits)
        fields = {f.name: getattr(scene, f.name) for f in dataclasses.fields(scene)}
        conn.send(("scene", fields))
    except CamsimError as exc:
        conn.send(("error", str(exc)))
    except MemoryError:
        conn.send(("error", f"{upload_name(filename)}: needs more than the "
                            f"{limits.worker_memory_bytes / 2**20:.0f} MiB a read may use"))
    except Exception as exc:  # a reader's bug: the uploader gets a message, the log the traceback
        import traceback

        traceback.print_exc()
        conn.send(("error", f"{upload_name(filename)}: could not be read (the reader failed: {type(exc).__name__})"))
    finally:
        conn.close()


def _refusal(name, code, limits):
    if code in (-signal.SIGXCPU, -signal.SIGKILL):  # the soft CPU limit, or the hard one a second later
        return FileFormatError(name, f"was stopped: reading it took more than {limits.worker_cpu_seconds} s of CPU "
                                     "or more memory than a read may use; refused")
    if code is not None and code < 0:
        return FileFormatError(name, f"could not be read: the reader stopped ({signal.Signals(-code).name})")
    return FileFormatError(name, "could not be read: the reader stopped without an answer")


def load_upload_isolated(filename, content, limits=DEFAULT_LIMITS, reader=load_upload):
    """:func:`~camsim_core.io.upload.load_upload` in a bounded worker process (see the module docstring).

    Parameters
    ----------
    filename : str
        The upload's name (only its last component is used).
    content : bytes
        The upload's bytes.
    limits : UploadLimits
        Size bounds for the read and the worker's memory, CPU and wall time.
    reader : callable, optional
        ``reader(filename, content, limits) -> Scene``, run in the worker
        (default :func:`~camsim_core.io.upload.load_upload`); a module-level
        function, as the worker imports it by name.

    Returns
    -------
    Scene
        Built in this process from the fields the worker read.

    Raises
    ------
    FileFormatError
        Naming the user's file: the reader's own refusal, or the worker's
        crash, time-out, CPU or memory limit.
    """
    name = upload_name(filename)  # its own checks (NUL, length) before any process starts
    if len(content) > limits.max_upload_bytes:
        return load_upload(filename, content, limits)  # refused by size, no worker needed
    ctx = _get_context()
    with _slots:
        receive, send = ctx.Pipe(duplex=False)
        proc = ctx.Process(target=_child, args=(send, filename, content, limits, reader), name="camsim-upload-read", daemon=True)
        proc.start()
        send.close()
        try:
            if not receive.poll(limits.worker_wall_seconds):
                if proc.is_alive():
                    proc.kill()
                    proc.join()
                    raise FileFormatError(name, f"took longer than {limits.worker_wall_seconds:g} s to read; refused")
                proc.join()
                raise _refusal(name, proc.exitcode, limits)
            try:
                kind, payload = receive.recv()
            except (EOFError, OSError):
                proc.join(5)
                raise _refusal(name, proc.exitcode, limits) from None
        finally:
            receive.close()
            if proc.is_alive():
                proc.join(5)
            if proc.is_alive():
                proc.kill()
                proc.join()
    if kind == "error":
        raise FileFormatError(*payload.split(": ", 1)) if ": " in payload else FileFormatError(name, payload)
    from ..scene.scene import Scene

    try:
        return Scene(**payload)
    except CamsimError as exc:
        raise FileFormatError(name, str(exc)) from None
