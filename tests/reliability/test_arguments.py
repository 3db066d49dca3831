"""Arguments are taken as given or refused in one line, never bent (issue 28, sections 4-6):
the SB3 adapter's time limit and attributes, the demo's tasks and episode count, and hints that
name where this install keeps its files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from agents import demo
from agents.evaluate import EvaluationError, evaluate, load_policy
from agents.vec_adapter import RigidBodySB3VecEnv
from rigid_env.resources import SCENE_DIR
from rigid_env.scene import SceneError, load_scene

ENV = "RigidEnv/Detumble-v0"


@pytest.mark.parametrize("bad", [0, -1, 2.5, 3.0, True, "400", 1e300, np.int64(0)])
def test_adapter_refuses_a_time_limit_that_is_not_a_whole_number_of_steps(bad):
    """0 used to become the registry's 400, -1 one-step episodes and 2.5 three steps."""
    with pytest.raises(ValueError, match=r"^max_episode_steps: expected an integer >= 1"):
        RigidBodySB3VecEnv(ENV, num_envs=2, max_episode_steps=bad)


def test_adapter_time_limit_ends_episodes_at_that_step():
    """max_episode_steps=3 (also as np.int64): every episode is cut after exactly 3 steps,
    flagged as a time limit, and the next one starts; None keeps the registry's 400."""
    assert RigidBodySB3VecEnv(ENV, num_envs=1).max_episode_steps == 400
    venv = RigidBodySB3VecEnv(ENV, num_envs=2, max_episode_steps=np.int64(3))
    venv.seed(5)
    venv.reset()
    zero = np.zeros((2, venv.action_space.shape[0]), dtype=np.float32)
    dones = []
    for _ in range(6):
        venv.step_async(zero)
        _, _, done, infos = venv.step_wait()
        dones.append(done.tolist())
        for i in np.flatnonzero(done):
            assert infos[i]["TimeLimit.truncated"] is True  # no thrust: never detumbled
    assert dones == [[False, False], [False, False], [True, True]] * 2


def test_adapter_set_attr_refuses_the_tasks_attributes():
    """set_attr("dt", -1) was accepted (and changed nothing the world steps with)."""
    venv = RigidBodySB3VecEnv(ENV, num_envs=2)
    dt = venv.get_attr("dt")[0]
    with pytest.raises(ValueError, match=r"^set_attr: 'dt' cannot be changed.*dt=\.\.\."):
        venv.set_attr("dt", -1)
    with pytest.raises(ValueError, match=r"^set_attr: 'no_such' cannot be changed"):
        venv.set_attr("no_such", 1)
    assert venv.get_attr("dt") == [dt, dt]
    with pytest.raises(ValueError, match=r"^max_episode_steps: expected an integer >= 1"):
        venv.set_attr("max_episode_steps", 0)
    venv.set_attr("max_episode_steps", 7)
    assert venv.get_attr("max_episode_steps") == [7, 7]


def test_demo_takes_the_ids_its_help_names_and_refuses_older_versions():
    assert demo.resolve_tasks("RigidEnv/Reorient-v1") == ["Reorient"]
    assert demo.resolve_tasks(" reorient ") == ["Reorient"]
    assert demo.resolve_tasks("RigidEnv/Detumble-v0") == ["Detumble"]
    with pytest.raises(demo.DemoError, match=r"Reorient-v0 is not the version.*Reorient-v1"):
        demo.resolve_tasks("RigidEnv/Reorient-v0")
    with pytest.raises(demo.DemoError, match=r"unknown task 'Reorient-v1'"):
        demo.resolve_tasks("Reorient-v1")


@pytest.mark.parametrize("episodes", [0, -3, demo.MAX_EPISODES + 1, 10**9, 10**20])
def test_demo_refuses_episode_counts_out_of_range(tmp_path, episodes):
    with pytest.raises(demo.DemoError, match=rf"--episodes: .* got {episodes};"):
        demo.run("Detumble", episodes, tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_demo_progress_reports_each_episode_done(monkeypatch):
    """run_episodes calls progress after every episode but the last (whose end the task line
    reports); _Progress turns that into lines with the episodes done and the time left."""
    done: list[int] = []
    pd = demo.pd_policy("Detumble")
    episodes = demo.run_episodes("Detumble", pd, 3, demo.DEMO_SEED, done.append)
    assert done == [1, 2] and len(episodes) == 3
    lines: list[str] = []
    monkeypatch.setattr(demo, "PROGRESS_EVERY_S", 0.0)
    ticker = demo._Progress("Detumble PD", 3, lines.append)
    ticker(1)
    assert lines and lines[0].startswith("Detumble PD: 1/3 episodes, about ")


def test_evaluate_refuses_render_mode_in_env_kwargs():
    """Checked with gym.make (which takes render_mode), run with make_vec (which does not):
    was an 18-line traceback."""
    with pytest.raises(EvaluationError, match=r"render_mode=human: an evaluation .* --video"):
        evaluate(None, ENV, 2, 0, only=["pd"], env_kwargs={"render_mode": "human"})


def test_hints_name_this_installs_folders(monkeypatch, tmp_path):
    """A missing model points at the shipped policies where this install keeps them (inside
    the package in a wheel), and a missing scene at the shipped scenes' folder."""
    import agents.evaluate as ev

    installed = tmp_path / "site-packages" / "rigid_env" / "agents" / "pretrained"
    monkeypatch.setattr(ev, "find_data", lambda relative: installed)
    with pytest.raises(EvaluationError) as info:
        load_policy(tmp_path / "missing.zip", ENV)
    assert f"use a shipped policy, {installed}/*.zip" in str(info.value)
    monkeypatch.setattr(ev, "find_data", lambda relative: None)
    with pytest.raises(EvaluationError) as info:
        load_policy(tmp_path / "missing.zip", ENV)
    assert "pretrained" not in str(info.value)

    with pytest.raises(SceneError) as info:
        load_scene(tmp_path / "nope.yaml")
    assert f"example scenes are in {SCENE_DIR})" in str(info.value)
    assert Path(SCENE_DIR).is_dir()
