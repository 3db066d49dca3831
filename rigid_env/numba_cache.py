"""Where Numba caches compiled kernels: a folder per module, keyed by the code it can compile in.

Numba checks only the source of the file that defines a cached function, not of the files whose
functions it inlined, so an edit of ``core/maths.py`` would leave stale code in the caches of the
integrators. Each module's kernels therefore live in a folder named by a hash of the code of the
module and of every ``rigid_env`` module it imports, directly or through others
(:func:`module_key`): core's kernels are keyed by the core files they reach, a task module's by
those, the shared task files (``envs/kernels.py``, ``envs/maths.py``, ...) and itself. Adding or
editing one task module recompiles that task's kernels only; an edit of ``core/maths.py``
recompiles everything that reaches it. The registry ``rigid_env/envs/__init__.py`` holds nothing
compiled and is left out of every key, so adding a task's row there recompiles nothing.

The registries of effects (:mod:`rigid_env.core.effect`) and of actuators
(:mod:`rigid_env.core.actuator`) are composed into every kernel that reaches them, so the code of
the modules of effects and actuators registered from outside (``RIGID_ENV_EFFECTS``,
``RIGID_ENV_ACTUATORS``) is part of those kernels' keys: a world of other parts compiles under
another key, never from stale code.

A module outside the package whose kernels use ours (a task of your own, in a file of its own) is
keyed the same way: its code and the ``rigid_env`` modules it reaches. Such a module must be
importable by its name (``sys.modules``) when Numba loads its kernels, as any imported module is.

The folders are ``$XDG_CACHE_HOME/rigid_env/numba/<key>/`` (``~/.cache`` by default, or under
``NUMBA_CACHE_DIR`` where set; safe to delete), and key folders that no process has used for a day
are removed. The mechanism is Numba's own: a cache locator class (:class:`ModuleKeyedLocator`)
put first in the list Numba asks (``CacheImpl._locator_classes``); ``NUMBA_CACHE_LOCATOR_CLASSES``,
where set, still decides.
"""

from __future__ import annotations

import ast
import functools
import hashlib
import importlib.util
import os
import re
import shutil
import time
from collections.abc import Iterator
from pathlib import Path

from numba.core import caching
from numba.core.caching import _CacheLocator, _SourceFileBackedLocatorMixin

_CacheImpl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
"""Numba's base of a cache's implementation, whose ``_locator_classes`` it asks in turn
(``CacheImpl`` from Numba 0.61 on, ``_CacheImpl`` before)."""

PACKAGE = Path(__file__).resolve().parent
"""The ``rigid_env`` package folder."""
KEYED = ("core", "envs")
"""The package's folders whose code a key covers: the only ones that define kernels."""
UNKEYED = ("envs/__init__.py",)
REGISTRIES = ("core/effect.py", "core/actuator.py")
"""The modules whose registries (effects, actuators) are composed into every kernel that reaches
them."""
"""Files of those folders that are followed but left out of every key (the task registry)."""
STALE_AFTER_S = 24 * 3600.0
"""A key folder that no process has used for this long is removed (other checkouts of other
sources may share the cache's parent folder, so one in use is kept)."""
_STAMP = "last_used"
_KEY = re.compile(r"[0-9a-f]{16}")
_used: set[Path] = set()


def code_key(source: str) -> bytes:
    """The code of a module's source without what cannot change a compiled kernel: its
    docstrings, comments, formatting and line numbers (a dump of the syntax tree with the
    docstrings taken out)."""
    return _code_dump(ast.parse(source))


def _code_dump(tree: ast.AST) -> bytes:
    """:func:`code_key` of a parsed module (its tree loses its docstrings)."""
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


def _module_file(name: str, package: Path) -> Path | None:
    """The file of module ``name`` (``rigid_env.core.maths``) in ``package``, or None."""
    parts = name.split(".")
    if parts[0] != package.name:
        return None
    base = package.joinpath(*parts[1:])
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path.resolve()
    return None


def _imported_names(tree: ast.AST, own: tuple[str, ...]) -> Iterator[str]:
    """The modules a syntax tree imports by name (``import a.b``; ``from a import b``: ``a``
    and ``a.b``; relative imports from the package ``own``), without the parent packages
    Python imports implicitly (a kernel reaches only the names a module binds)."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                if not own:
                    continue
                parents = own[: len(own) - node.level + 1]
                base = ".".join([*parents, *([base] if base else [])])
            yield base
            yield from (f"{base}.{alias.name}" for alias in node.names)


@functools.cache
def _facts(path: Path, mtime_ns: int, size: int, package: Path) -> tuple[str, tuple[Path, ...]]:
    """A file's code digest (of :func:`code_key`; empty for a package file that no key
    covers) and the package's module files it imports (memoised on the file's time and size:
    one parse per file and process)."""
    tree = ast.parse(path.read_text())
    own = path.parent.relative_to(package.parent).parts if path.is_relative_to(package) else ()
    names = list(_imported_names(tree, own))
    files = {f for name in names if (f := _module_file(name, package)) is not None}
    keyed = _keyed(path, package) is not None or not path.is_relative_to(package)
    code = hashlib.sha256(_code_dump(tree)).hexdigest() if keyed else ""  # no key reads it
    return code, tuple(sorted(files))


def _file_facts(path: Path, package: Path) -> tuple[str, tuple[Path, ...]]:
    st = path.stat()
    return _facts(path, st.st_mtime_ns, st.st_size, package)


def _reach(path: Path, package: Path) -> set[Path]:
    """``path`` and every module file of ``package`` it imports, directly or through others."""
    seen: set[Path] = set()
    todo = [path]
    while todo:
        current = todo.pop()
        if current not in seen:
            seen.add(current)
            todo.extend(_file_facts(current, package)[1])
    return seen


def _keyed(path: Path, package: Path) -> str | None:
    """The name a key records for ``path`` (``core/maths.py``), or None if it is left out."""
    if not path.is_relative_to(package):
        return None
    relative = path.relative_to(package).as_posix()
    if relative.split("/")[0] not in KEYED or relative in UNKEYED:
        return None
    return relative


def module_key(path: str | Path, package: Path = PACKAGE) -> str | None:
    """The key (16 hex digits) of the kernels of the module file ``path``: a hash of the code
    (:func:`code_key`) of every module of ``package``'s :data:`KEYED` folders that ``path``
    reaches by imports, itself included (:data:`UNKEYED` aside), and of ``path`` itself where
    it lies outside them. None for a file that reaches none of them (not ours: Numba's own
    locators cache it)."""
    path, package = Path(path).resolve(), package.resolve()
    keyed = sorted(
        (name, p) for p in _reach(path, package) if (name := _keyed(p, package)) is not None
    )
    if not keyed:
        return None
    digest = hashlib.sha256()
    for name, p in keyed:
        digest.update(f"{name}\0{_file_facts(p, package)[0]}\n".encode())
    if _keyed(path, package) is None:  # a module of its own: its code too
        digest.update(f"own\0{_file_facts(path, package)[0]}\n".encode())
    if any(name in REGISTRIES for name, _ in keyed):  # the parts composed into its kernels
        for var, kind in (("RIGID_ENV_EFFECTS", "effects"), ("RIGID_ENV_ACTUATORS", "actuators")):
            for path in _plugin_modules(var):
                digest.update(f"{kind}\0{path}\0{_file_facts(path, package)[0]}\n".encode())
    return digest.hexdigest()[:16]


def _plugin_modules(variable: str) -> list[Path]:
    """The source files of the modules named in the environment ``variable``
    (``RIGID_ENV_EFFECTS``, :mod:`rigid_env.core.effect`; ``RIGID_ENV_ACTUATORS``,
    :mod:`rigid_env.core.actuator`), found without importing them (their parents are)."""
    paths = []
    for name in os.environ.get(variable, "").split(","):
        spec = importlib.util.find_spec(name.strip()) if name.strip() else None
        if spec is not None and spec.origin and spec.origin.endswith(".py"):
            paths.append(Path(spec.origin).resolve())
    return paths


def cache_root() -> Path:
    """The folder of the key folders: ``NUMBA_CACHE_DIR`` where set, else
    ``$XDG_CACHE_HOME/rigid_env/numba`` (``~/.cache`` by default)."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"])
    home = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return home / "rigid_env" / "numba"


def _use(folder: Path) -> None:
    """Stamp ``folder`` as used (once per process) and remove the stale key folders beside it."""
    if folder in _used:
        return
    _used.add(folder)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / _STAMP).touch()
    if len(_used) == 1:
        _remove_stale(folder.parent, keep=folder)


def _remove_stale(parent: Path, keep: Path) -> None:
    """Remove the key folders beside ``keep`` unused for :data:`STALE_AFTER_S` (only folders
    named as keys are: the parent may be a ``NUMBA_CACHE_DIR`` shared with others)."""
    now = time.time()
    for folder in parent.iterdir() if parent.is_dir() else ():
        if folder == keep or folder in _used or not folder.is_dir():
            continue
        if not _KEY.fullmatch(folder.name):
            continue
        stamp = folder / _STAMP
        used = (stamp if stamp.exists() else folder).stat().st_mtime
        if now - used > STALE_AFTER_S:
            shutil.rmtree(folder, ignore_errors=True)


@functools.cache
def _file_key(py_file: str) -> str | None:
    """:func:`module_key` of a file, once per process (Numba asks for every kernel of a file;
    the sources do not change under a running process), or None where it cannot be read."""
    try:
        return module_key(py_file)
    except (OSError, SyntaxError, ValueError):
        return None


class ModuleKeyedLocator(_SourceFileBackedLocatorMixin, _CacheLocator):
    """Numba's cache locator for the kernels of our modules and of modules that use them: the
    folder ``<cache root>/<module key>/<folder of the file>`` (:func:`module_key`). Within it
    Numba checks the file's own source as ever (a hash of its bytes).

    The folder of a file of the package is named by its place in the package (``core``,
    ``envs``), not by where the package lies, so every copy of the same code shares its kernels:
    a wheel installed beside a checkout, or a second checkout, loads what the first compiled (the
    key and the bytes of the file agree, so the kernels are the same). A file of its own keeps
    Numba's folder, named by the file's place on disk."""

    def __init__(self, py_func, py_file: str, folder: Path) -> None:
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = str(folder / self.get_suitable_cache_subpath(py_file))

    @classmethod
    def get_suitable_cache_subpath(cls, py_file: str) -> str:
        path = Path(py_file).resolve()
        if path.is_relative_to(PACKAGE):
            return "_".join(path.parent.relative_to(PACKAGE.parent).parts)  # rigid_env_core
        return super().get_suitable_cache_subpath(py_file)

    def get_cache_path(self) -> str:
        return self._cache_path

    @classmethod
    def from_function(cls, py_func, py_file: str):
        """A locator for a function of ``py_file``, or None where the file reaches none of our
        kernel modules (or the cache folder cannot be written: Numba then asks its own)."""
        if not os.path.isfile(py_file):
            return None
        key = _file_key(py_file)
        if key is None:
            return None
        folder = cache_root() / key
        self = cls(py_func, py_file, folder)
        try:
            _use(folder)
            self.ensure_cache_path()
        except OSError:  # a read-only home: Numba's own locators, as it would
            return None
        return self


def use_cache_for_this_source() -> None:
    """Put :class:`ModuleKeyedLocator` first among the locators Numba asks for a cached
    function's folder. Call it before the first kernel is defined (``import rigid_env``
    does)."""
    if ModuleKeyedLocator not in _CacheImpl._locator_classes:
        _CacheImpl._locator_classes.insert(0, ModuleKeyedLocator)
