"""The Numba cache's key follows the kernels' code, not their docstrings or comments, and
folders of old keys are removed."""

from __future__ import annotations

import os
import time
from pathlib import Path

import numba

from rigid_env import numba_cache

SOURCE = '''"""Module docstring."""
import math

X = 2.0
"""Attribute docstring."""


def f(a):
    """Docstring."""
    return a * X  # a comment
'''


def test_key_ignores_docstrings_comments_and_layout() -> None:
    edited = (
        SOURCE.replace("Docstring.", "Another docstring, longer.")
        .replace("# a comment", "# a new comment")
        .replace('"""Module docstring."""', '"""Module\n\ndocstring, edited."""\n')
    )
    assert numba_cache.code_key(edited) == numba_cache.code_key(SOURCE)
    assert numba_cache.code_key(SOURCE.replace("a * X", "a * X + 1.0")) != numba_cache.code_key(
        SOURCE
    )
    assert numba_cache.code_key(SOURCE.replace("X = 2.0", "X = 3.0")) != numba_cache.code_key(
        SOURCE
    )


def test_folders_of_old_keys_are_removed(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setattr(numba.config, "CACHE_DIR", numba.config.CACHE_DIR)  # restored after
    parent = tmp_path / "rigid_env" / "numba"
    old, recent = parent / "0123456789abcdef", parent / "fedcba9876543210"
    for folder in (old, recent):
        folder.mkdir(parents=True)
        (folder / "x.nbi").write_bytes(b"")
    day_ago = time.time() - numba_cache.STALE_AFTER_S - 60.0
    os.utime(old, (day_ago, day_ago))
    numba_cache.use_cache_for_this_source()
    current = Path(numba.config.CACHE_DIR)
    assert current.parent == parent and current.is_dir()
    assert not old.exists()  # unused for a day: removed
    assert recent.exists()  # maybe another checkout's, in use: kept
