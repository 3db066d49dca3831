"""Where Numba caches the compiled kernels of :mod:`rigid_env.core` and :mod:`rigid_env.envs`."""

from __future__ import annotations

import ast
import hashlib
import importlib.util
import os
import shutil
import time
from pathlib import Path

import numba

STALE_AFTER_S = 24 * 3600.0
"""A cache folder of another key that no process has used for this long is removed (other
checkouts of other sources may share the cache's parent folder, so one in use is kept)."""
_STAMP = "last_used"


def code_key(source: str) -> bytes:
    """The code of a module's source without what cannot change a compiled kernel: its
    docstrings, comments, formatting and line numbers (a dump of the syntax tree with the
    docstrings taken out)."""
    tree = ast.parse(source)
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if not isinstance(body, list):
            continue
        node.body = [  # type: ignore[attr-defined]
            stmt
            for stmt in body
            if not (isinstance(stmt, ast.Expr) and isinstance(stmt.value, ast.Constant))
        ] or [ast.Pass()]
    return ast.dump(tree, include_attributes=False).encode()


def _effect_modules() -> list[Path]:
    """The source files of the modules named in ``RIGID_ENV_EFFECTS``
    (:mod:`rigid_env.core.effect`), found without importing them (their parents are)."""
    paths = []
    for name in os.environ.get("RIGID_ENV_EFFECTS", "").split(","):
        spec = importlib.util.find_spec(name.strip()) if name.strip() else None
        if spec is not None and spec.origin and spec.origin.endswith(".py"):
            paths.append(Path(spec.origin))
    return paths


def _remove_stale(parent: Path, keep: Path) -> None:
    """Remove the sibling cache folders of ``keep`` unused for :data:`STALE_AFTER_S`."""
    now = time.time()
    for folder in parent.iterdir() if parent.is_dir() else ():
        if folder == keep or not folder.is_dir():
            continue
        stamp = folder / _STAMP
        used = (stamp if stamp.exists() else folder).stat().st_mtime
        if now - used > STALE_AFTER_S:
            shutil.rmtree(folder, ignore_errors=True)


def use_cache_for_this_source() -> None:
    """Keep compiled kernels under a folder named by a hash of the kernel sources' code
    (``rigid_env/core`` and ``rigid_env/envs``, and the modules of effects registered from
    outside, ``RIGID_ENV_EFFECTS``, :func:`code_key`: an edit of a docstring or a
    comment keeps the key). Numba checks only the time stamp of the file that defines a cached
    function, not of the files whose functions it inlined, so a code edit of ``core/maths.py``
    would otherwise leave stale code in the caches of the integrators; a docstring edit
    recompiles only the functions of the file edited. The folder is
    ``$XDG_CACHE_HOME/rigid_env/numba/<hash>`` (``~/.cache`` by default; safe to delete), and
    folders of other keys unused for a day are removed; ``NUMBA_CACHE_DIR``, where set, is
    used as it is. Call it before the first kernel is defined (``import rigid_env`` does)."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    package = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for path in sorted([*package.glob("core/*.py"), *package.glob("envs/*.py")]):
        digest.update(path.name.encode() + code_key(path.read_text()))
    for path in _effect_modules():  # the registry's other effects compile into the same step
        digest.update(str(path).encode() + code_key(path.read_text()))
    home = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    folder = home / "rigid_env" / "numba" / digest.hexdigest()[:16]
    numba.config.CACHE_DIR = str(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        (folder / _STAMP).touch()
        _remove_stale(folder.parent, folder)
    except OSError:  # a read-only home: Numba then compiles without caching, as it would
        pass
