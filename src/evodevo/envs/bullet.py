"""PyBullet, imported once without its ``pybullet build time`` banner (SPEC §3).

The banner is printed by the C extension to the process' standard error when the module is
first imported, so every worker process printed it; here the import runs with file descriptors
1 and 2 pointed at ``/dev/null``, and C's output buffers are flushed there before they are
restored. Every evodevo module takes PyBullet from here.

>>> from evodevo.envs.bullet import pybullet
>>> pybullet.DIRECT
2
"""

from __future__ import annotations

import contextlib
import ctypes
import importlib
import os
import sys
from types import ModuleType

__all__ = ["pybullet"]


def _import_quietly(name: str) -> ModuleType:
    if name in sys.modules:
        return sys.modules[name]
    sys.stdout.flush()
    sys.stderr.flush()
    saved = {fd: os.dup(fd) for fd in (1, 2)}
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        for fd in saved:
            os.dup2(devnull, fd)
        return importlib.import_module(name)
    finally:
        _flush_c_stdio()  # what C buffered goes to /dev/null too
        for fd, copy in saved.items():
            os.dup2(copy, fd)
            os.close(copy)
        os.close(devnull)


def _flush_c_stdio() -> None:
    with contextlib.suppress(OSError, AttributeError):  # no C library (not POSIX)
        ctypes.CDLL(None).fflush(None)


pybullet = _import_quietly("pybullet")
