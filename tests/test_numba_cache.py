"""The Numba cache is keyed per module: a module's kernels by the code of the modules it
reaches (core's by core, a task's by core, the shared task files and itself), not by docstrings
or comments; adding or editing a task module leaves every other module's key as it was; folders
of old keys are removed."""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path

import pytest

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


NEW_TASK = """from rigid_env.envs.kernels import Outcome, env_pass, kernel, task_kernel


@kernel
def evaluate(body, effort, goal, memory, task, stepped):
    return Outcome(-effort, False, False, memory, (body.w[2],))


@task_kernel
def new_pass(job, threads): return env_pass(evaluate, job, threads)
"""


@pytest.fixture
def package(tmp_path: Path) -> Path:
    """A copy of the package's sources to edit."""
    copy = tmp_path / "rigid_env"
    shutil.copytree(numba_cache.PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    return copy


def keys(package: Path) -> dict[str, str | None]:
    """The key of every kernel module (core/ and envs/) of ``package``, by its path there."""
    numba_cache._facts.cache_clear()  # edits within one clock tick keep a file's time stamp
    files = [*package.glob("core/*.py"), *package.glob("envs/*.py")]
    return {f.relative_to(package).as_posix(): numba_cache.module_key(f, package) for f in files}


def edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, (path, old)
    path.write_text(text.replace(old, new, 1))


def test_a_new_task_module_and_its_registry_row_change_no_other_key(package: Path) -> None:
    before = keys(package)
    (package / "envs" / "new_task.py").write_text(NEW_TASK)
    edit(package / "envs" / "__init__.py", "    )\n)\n", "        Task('New', module='new_task', "
         "scene='detumble', max_episode_steps=10),\n    )\n)\n")  # fmt: skip
    after = keys(package)
    assert after.pop("envs/new_task.py") not in (None, *before.values())
    assert after == before


def test_editing_a_task_module_changes_its_key_only(package: Path) -> None:
    before = keys(package)
    edit(package / "envs" / "detumble.py", "speed < task.success_threshold",
         "speed <= task.success_threshold")  # fmt: skip
    after = keys(package)
    changed = {name for name in before if after[name] != before[name]}
    assert changed == {"envs/detumble.py"}


def test_a_core_edit_changes_the_keys_of_the_modules_that_reach_it(package: Path) -> None:
    """A docstring or comment changes no key; a code edit of ``core/maths.py`` changes the keys
    of every module that imports it (directly or through others: the integrators, the task
    pass, every task), not of those that do not (``core/rotation.py``, ``core/jit.py``)."""
    before = keys(package)
    maths = package / "core" / "maths.py"
    edit(maths, "def cross(a, b):\n", "def cross(a, b):  # a comment\n")
    edit(maths, '"""', '"""An edited docstring. ')
    assert keys(package) == before
    edit(maths, "def cross(a, b):", "def _unused(a):\n    return a\n\n\n@kernel\ndef cross(a, b):")
    after = keys(package)
    changed = {name for name in before if after[name] != before[name]}
    tasks = {"envs/detumble.py", "envs/spin_stabilize.py", "envs/reorient.py"}
    assert {"core/maths.py", "core/integrators.py", "envs/kernels.py", *tasks} <= changed
    assert not {"core/rotation.py", "core/jit.py", "envs/__init__.py"} & changed
    assert before["envs/__init__.py"] is None  # the registry compiles nothing


def test_kernels_are_cached_in_the_folder_of_their_module_key() -> None:
    """Numba asks our locator first; a core kernel and a task's pass lie in the folders of
    their own modules' keys."""
    from numba.core.caching import _CacheLocator

    from rigid_env.core.maths import cross
    from rigid_env.envs.detumble import detumble_pass

    assert numba_cache._CacheImpl._locator_classes[0] is numba_cache.ModuleKeyedLocator
    assert issubclass(numba_cache.ModuleKeyedLocator, _CacheLocator)
    for function in (cross, detumble_pass):
        path = Path(function.py_func.__code__.co_filename)
        folder = numba_cache.cache_root() / numba_cache.module_key(path)
        assert Path(function._cache.cache_path).is_relative_to(folder)
    assert numba_cache.module_key(Path(shutil.__file__)) is None  # not ours: Numba's own


def test_folders_of_old_keys_are_removed(tmp_path: Path) -> None:
    """Key folders unused for a day are removed; recent ones (another checkout's, maybe in use)
    and folders not named as keys (a shared NUMBA_CACHE_DIR's) are kept."""
    old, recent, other = (
        tmp_path / "0123456789abcdef",
        tmp_path / "fedcba9876543210",
        tmp_path / "x",
    )
    for folder in (old, recent, other):
        folder.mkdir()
        (folder / "x.nbi").write_bytes(b"")
    day_ago = time.time() - numba_cache.STALE_AFTER_S - 60.0
    for folder in (old, other):
        os.utime(folder, (day_ago, day_ago))
    keep = tmp_path / "00000000000000ff"
    keep.mkdir()
    numba_cache._remove_stale(tmp_path, keep)
    assert not old.exists()
    assert recent.exists() and other.exists() and keep.exists()


def test_the_pass_parts_that_take_a_tasks_evaluate_stay_off_the_disk() -> None:
    """The parts of the task pass typed by a task's ``evaluate`` are compiled into each task's
    cached pass only: on disk they would add an entry per compile that no process finds again."""
    from numba.core.caching import NullCache

    from rigid_env.envs import kernels

    assert isinstance(kernels._env._cache, NullCache)
    assert isinstance(kernels._envs._cache, NullCache)
    assert not isinstance(kernels.fine_spin._cache, NullCache)  # the task-free parts are cached


def test_a_copy_of_the_package_shares_the_kernels_of_the_same_code(tmp_path: Path) -> None:
    """A copy of the package elsewhere (a wheel installed beside the checkout) names the same
    cache folder for the same code, so it loads the kernels the checkout compiled (Numba then
    checks the bytes of the file, equal in a copy)."""
    import subprocess
    import sys
    import sysconfig

    from rigid_env.core.maths import cross

    shutil.copytree(Path(numba_cache.PACKAGE), tmp_path / "rigid_env",
                    ignore=shutil.ignore_patterns("__pycache__"))  # fmt: skip
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = os.pathsep.join([str(tmp_path), sysconfig.get_paths()["purelib"]])
    code = "import rigid_env.core.maths as m; print(m.__file__); print(m.cross._cache.cache_path)"
    run = subprocess.run([sys.executable, "-S", "-c", code], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=120, check=True)  # fmt: skip
    where, folder = run.stdout.split()
    assert Path(where).is_relative_to(tmp_path)  # the copy, not the checkout
    assert folder == cross._cache.cache_path
