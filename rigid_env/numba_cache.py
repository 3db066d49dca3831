"""Where Numba caches the compiled kernels of :mod:`rigid_env.core` and :mod:`rigid_env.envs`."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba


def use_cache_for_this_source() -> None:
    """Keep compiled kernels under a folder named by a hash of the kernel sources
    (``rigid_env/core`` and ``rigid_env/envs``): Numba checks only the time stamp of the file
    that defines a cached function, not of the files whose functions it inlined, so an edit of
    ``core/kernels.py`` would otherwise leave stale code in the caches of the integrators. The
    folder is ``$XDG_CACHE_HOME/rigid_env/numba/<hash>`` (``~/.cache`` by default; safe to
    delete); ``NUMBA_CACHE_DIR``, where set, is used as it is. Call it before the first kernel
    is defined (``import rigid_env`` does)."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    package = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for path in sorted([*package.glob("core/*.py"), *package.glob("envs/*.py")]):
        digest.update(path.name.encode() + path.read_bytes())
    home = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    numba.config.CACHE_DIR = str(home / "rigid_env" / "numba" / digest.hexdigest()[:16])
