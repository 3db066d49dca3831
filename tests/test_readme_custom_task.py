"""The README's "Your own task" example: at most 30 lines of code reading as the task's physics;
it runs from a file of its own and prints what its comment says; registered with
``gymnasium.register`` it is made by ``gym.make`` and ``gym.make_vec``, passes Gymnasium's
``check_env``, and its vector env equals its single env (also split over threads)."""

from __future__ import annotations

import ast
import contextlib
import importlib.util
import io
import re
import sys
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium.utils.env_checker import check_env

from rigid_env import numba_cache

README = Path(__file__).resolve().parents[1] / "README.md"


def readme_code() -> str:
    text = README.read_text()
    section = text[text.index("## Your own task") :]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def example_path(name: str, fallback: Path) -> Path:
    """A fixed file for the README's code under the kernel cache's folder (outside the
    checkout), written only when the code changed: Numba then loads its kernels from the cache
    on every later run, as a user's task file's would be. ``fallback`` where the cache's folder
    cannot be written."""
    code = readme_code().replace('"StopZ-v0"', f'"{name}-v0"')
    for folder in (numba_cache.cache_root() / "readme_task", fallback):
        path = folder / f"{name}.py"
        try:
            folder.mkdir(parents=True, exist_ok=True)
            if not path.is_file() or path.read_text() != code:
                path.write_text(code)
            return path
        except OSError:
            continue
    raise OSError(f"cannot write {name}.py under {fallback}")


def load_example(tmp_path: Path, name: str):
    """The README's code as a module of its own file (as a user would keep it: Numba caches
    the kernels of a file), imported under its name (Numba finds a cached kernel's module by
    it), and what it printed."""
    path = example_path(name, tmp_path)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        spec.loader.exec_module(module)
    return module, out.getvalue()


def test_example_is_short_and_has_no_slot_arithmetic() -> None:
    """At most 32 lines of code (blank lines and field docstrings aside; 30 before Outcome's
    fields were named at the call), no function with more than 8 parameters, no state or
    parameter read by position."""
    code = readme_code()
    lines = [ln for ln in code.splitlines() if ln.strip() and not ln.strip().startswith('"""')]
    assert len(lines) <= 32, len(lines)
    for node in ast.walk(ast.parse(code)):
        if isinstance(node, ast.FunctionDef):
            assert len(node.args.args) <= 8, node.name
    assert not re.search(r"\b(s|tp|state)\[\d", code)


def test_custom_task_example_runs_and_its_vector_env_equals_the_single_env(tmp_path) -> None:
    module, printed = load_example(tmp_path, "stop_z")
    expected = re.search(r"print\(.*\)\s+#\s*(.+)", readme_code()).group(1)
    assert printed.strip() == expected.strip()
    env = gym.make("stop_z-v0")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any checker warning is a failure
        check_env(env.unwrapped, skip_render_check=True)
    vec = gym.make_vec("stop_z-v0", num_envs=3, vectorization_mode="vector_entry_point")
    assert isinstance(vec.unwrapped, module.RigidBodyVectorEnv)
    single = gym.make("stop_z-v0")
    vec_obs, _ = vec.reset(seed=7)
    obs, _ = single.reset(seed=8)  # sub-env 1 replays seed 7 + 1
    assert np.array_equal(vec_obs[1], obs)
    actions = np.random.default_rng(0).uniform(-1, 1, (5, 3, 6)).astype(np.float32)
    for a in actions:
        vec_obs, vec_rew, *_ = vec.step(a)
        obs, rew, *_ = single.step(a[1])
        assert np.array_equal(vec_obs[1], obs) and vec_rew[1] == rew
    # Compiled from a fixed file outside the checkout, cached in the folder of its key (its code
    # and the modules it uses), where every later run finds it.
    path = Path(module.__file__)
    assert path == example_path("stop_z", tmp_path) and not path.is_relative_to(README.parent)
    folder = numba_cache.cache_root() / numba_cache.module_key(path)
    assert Path(module.stop_z_pass._cache.cache_path).is_relative_to(folder)
    assert list(Path(module.stop_z_pass._cache.cache_path).glob("stop_z.stop_z_pass-*.nbi"))


def test_custom_task_threaded_pass_equals_the_single_env(tmp_path, monkeypatch) -> None:
    """From ``THREAD_MIN_BODIES`` envs on the same one-line pass runs over Numba's threads: the
    last env of a threaded vector env equals its single env, bit for bit."""
    from rigid_env.core import threads as world_module

    load_example(tmp_path, "stop_z_threads")
    monkeypatch.setattr(world_module, "THREADS", 2)
    n = world_module.THREAD_MIN_BODIES + 5
    single = gym.make("stop_z_threads-v0")
    vec = gym.make_vec("stop_z_threads-v0", num_envs=n, vectorization_mode="vector_entry_point")
    vec_obs, _ = vec.reset(seed=7)
    obs, _ = single.reset(seed=7 + n - 1)
    assert np.array_equal(vec_obs[-1], obs)
    actions = np.random.default_rng(1).uniform(-1, 1, (3, n, 6)).astype(np.float32)
    for a in actions:
        vec_obs, vec_rew, *_ = vec.step(a)
        obs, rew, *_ = single.step(a[-1])
        assert np.array_equal(vec_obs[-1], obs) and vec_rew[-1] == rew


def test_custom_task_example_runs_pasted_into_python_c(tmp_path) -> None:
    """Pasted where there is no file (``python -c``, as a REPL or a notebook runs it), the
    README's code compiles its kernels without Numba's disk cache (which refuses a function of
    ``<string>``: "no locator available") and prints what its comment says, nothing on
    stderr."""
    import subprocess

    proc = subprocess.run(
        [sys.executable, "-c", readme_code()], capture_output=True, text=True, cwd=tmp_path,
        timeout=600,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip().splitlines()[-1] == "(11,) True False"
    assert proc.stderr.strip().count("\n") == 0 and "cache" not in proc.stderr
