"""The README's "Your own task" example runs from a file of its own, prints what its comment
says, and its vector env equals its single env (a new task gets the library's guarantees)."""

from __future__ import annotations

import contextlib
import importlib.util
import io
import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parents[1] / "README.md"


def test_custom_task_example_runs_and_its_vector_env_equals_the_single_env(tmp_path) -> None:
    text = README.read_text()
    section = text[text.index("## Your own task") :]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    expected = re.search(r"print\(.*\)\s+#\s*(.+)", code).group(1)
    path = tmp_path / "stop_z.py"  # as a user would keep it: Numba caches kernels of files
    path.write_text(code)
    spec = importlib.util.spec_from_file_location("stop_z", path)
    module = importlib.util.module_from_spec(spec)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        spec.loader.exec_module(module)
    assert out.getvalue().strip() == expected.strip()
    single, vec = module.StopZEnv(), module.StopZVectorEnv(num_envs=3)
    vec_obs, _ = vec.reset(seed=7)
    obs, _ = single.reset(seed=8)  # sub-env 1 replays seed 7 + 1
    assert np.array_equal(vec_obs[1], obs)
    actions = np.random.default_rng(0).uniform(-1, 1, (5, 3, 6)).astype(np.float32)
    for a in actions:
        vec_obs, vec_rew, *_ = vec.step(a)
        obs, rew, *_ = single.step(a[1])
        assert np.array_equal(vec_obs[1], obs) and vec_rew[1] == rew


def test_custom_task_threaded_pass_equals_the_single_env(tmp_path, monkeypatch) -> None:
    """The README's optional threaded twin of the pass (its second code block), used from
    ``THREAD_MIN_BODIES`` envs on: the last env of a threaded vector env equals its single env,
    bit for bit."""
    from rigid_env.core import threads as world_module

    section = README.read_text()[README.read_text().index("## Your own task") :]
    first, second = re.findall(r"```python\n(.*?)```", section, re.S)[:2]
    path = tmp_path / "stop_z_threads.py"
    path.write_text(first + "\n" + second)
    spec = importlib.util.spec_from_file_location("stop_z_threads", path)
    module = importlib.util.module_from_spec(spec)
    with contextlib.redirect_stdout(io.StringIO()):
        spec.loader.exec_module(module)
    monkeypatch.setattr(world_module, "THREADS", 2)
    n = world_module.THREAD_MIN_BODIES + 5
    single, vec = module.StopZEnv(), module.StopZVectorEnv(num_envs=n)
    vec_obs, _ = vec.reset(seed=7)
    obs, _ = single.reset(seed=7 + n - 1)
    assert np.array_equal(vec_obs[-1], obs)
    actions = np.random.default_rng(1).uniform(-1, 1, (3, n, 6)).astype(np.float32)
    for a in actions:
        vec_obs, vec_rew, *_ = vec.step(a)
        obs, rew, *_ = single.step(a[-1])
        assert np.array_equal(vec_obs[-1], obs) and vec_rew[-1] == rew
