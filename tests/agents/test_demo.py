"""`rigid-env demo`: the main job in one command (inference only, a few episodes)."""

from __future__ import annotations

import csv
import functools
import os
import re
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import pytest

from agents import demo
from agents.evaluate import evaluate
from agents.shipped import TASKS
from agents.side_by_side import PANEL, record_side_by_side
from rigid_env.cli import main

ROOT = Path(__file__).resolve().parents[2]
EPISODES = 2
# Same episodes through another path (a vector env of all episodes at once against one
# rollout per episode): equal up to the float32 rounding of a batch, far below the printed digits.
SAME_EPISODES = 1e-9


def run_demo(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "rigid_env.cli", "demo", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
        env={**os.environ, "SDL_VIDEODRIVER": "dummy", "MPLBACKEND": "Agg"},
    )


def assert_one_line_error(proc: subprocess.CompletedProcess[str], *words: str) -> None:
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rigid-env: error: "), proc.stderr
    assert "Traceback" not in proc.stderr
    for word in words:
        assert word in lines[0], (word, lines[0])


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """One `rigid-env demo --episodes 2` of all four tasks (about 25 s on two cores)."""
    out = tmp_path_factory.mktemp("demo")
    proc = run_demo("--episodes", str(EPISODES), "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    return out, proc.stdout


@pytest.mark.slow
def test_demo_writes_table_and_animations(demo_run):
    out, stdout = demo_run
    with open(out / "results.csv") as fh:
        rows = list(csv.DictReader(fh))
    analytic = {task: "B-dot" if task == "BdotDetumble" else "PD" for task in TASKS}
    assert [(r["task"], r["policy"]) for r in rows] == [
        (task, policy) for task in TASKS for policy in ("PPO", analytic[task])
    ]
    assert all(int(r["episodes"]) == EPISODES for r in rows)
    assert all(int(r["first_seed"]) == demo.DEMO_SEED for r in rows)
    md = (out / "results.md").read_text()
    assert "| task | policy | episodes | success rate | final \\|w\\| [rad/s]" in md
    assert md.count("| PPO |") == len(TASKS) and md.count("| PD |") == len(TASKS) - 1
    # Fuel in each task's unit: the coils' dipole-time on magnetorquers, thrust's impulse else.
    units = {r["task"]: r["fuel_unit"] for r in rows}
    assert units["BdotDetumble"] == units["WheelPointing"] == "A m^2 s"
    assert units["Detumble"] == "N s"
    assert re.search(r"\| BdotDetumble \| PPO \|[^\n]*\| [\d.]+ A m\^2 s \|", md)
    assert "[N s]" not in md.splitlines()[4]  # the header names no one unit for all
    # The terminal gets the table and every path written.
    assert "time to success [s]" in stdout and "TumblingFall" in stdout
    from PIL import Image

    for task in TASKS:
        gif = demo.animation_path(out, task)
        assert f"wrote {gif}" in stdout
        assert gif.stat().st_size < 500_000  # small enough to commit or mail
        with Image.open(gif) as im:
            assert im.size[0] == 2 * PANEL and im.n_frames > 5


@pytest.mark.slow
def test_demo_pd_row_equals_a_direct_evaluation(demo_run):
    """The table's PD row on Detumble is what `agents.evaluate` gives for the PD controller on
    the same seeds, computed independently (all episodes at once in one vector env)."""
    out, _ = demo_run
    with open(out / "results.csv") as fh:
        row = next(r for r in csv.DictReader(fh) if r["task"] == "Detumble" and r["policy"] == "PD")
    ref = evaluate(None, "RigidEnv/Detumble-v0", EPISODES, demo.DEMO_SEED, only=["pd"])["pd"]
    assert float(row["success_rate"]) == ref["success_rate"]
    for col, key in (
        ("final_angular_speed_rad_s", "mean_final_angular_speed"),
        ("fuel", "mean_fuel"),
        ("return", "mean_return"),
    ):
        assert float(row[col]) == pytest.approx(ref[key], rel=SAME_EPISODES), col
    # Detumble ends at success, so "first success" and "successful episodes" coincide here.
    assert float(row["time_to_success_s"]) == pytest.approx(ref["mean_time_to_success"])


@pytest.mark.slow
def test_second_run_without_force_refuses(demo_run):
    out, _ = demo_run
    before = (out / "results.md").read_text()
    proc = run_demo("--episodes", "1", "--out", str(out))
    assert_one_line_error(proc, "earlier demo results", "--force")
    assert (out / "results.md").read_text() == before


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("--task", "Nope"), ("Nope", "Detumble", "SpinStabilize", "Reorient", "TumblingFall")),
        (("--episodes", "0"), ("--episodes", ">= 1")),
        (("--episodes", "two"), ("--episodes", "integer")),
    ],
)
@pytest.mark.slow
def test_bad_flags_are_one_line_errors(args, words, tmp_path):
    proc = run_demo(*args, "--out", str(tmp_path / "d"))
    assert_one_line_error(proc, *words)
    assert not (tmp_path / "d").exists()


def test_task_names():
    assert demo.resolve_tasks(None) == list(TASKS)
    for name in ("Detumble", "detumble", "RigidEnv/Detumble-v0"):
        assert demo.resolve_tasks(name) == ["Detumble"]
    assert demo.resolve_tasks("RigidEnv/TumblingFall-v1") == ["TumblingFall"]
    with pytest.raises(demo.DemoError, match="choose one of Detumble, SpinStabilize"):
        demo.resolve_tasks("Detumble-v0")


def test_help_states_the_default_episodes(capsys):
    assert main(["demo", "--help"]) == 0
    assert f"(default: {demo.DEFAULT_EPISODES})" in capsys.readouterr().out


@pytest.mark.slow
def test_animated_episode_is_episode_zero_of_the_table(tmp_path):
    """The GIF's episode (a single env, rendered) is the table's episode 0 (a rollout)."""
    pd = demo.pd_policy("Detumble")
    (row0,) = demo.run_episodes("Detumble", pd, 1, demo.DEMO_SEED)
    outcomes = record_side_by_side(
        "RigidEnv/Detumble-v0", [("PD", pd)], demo.DEMO_SEED, tmp_path / "pd.gif"
    )
    shown = outcomes["PD"]
    assert shown.success == row0.success
    assert shown.final_angular_speed == pytest.approx(row0.final_angular_speed, rel=SAME_EPISODES)
    assert shown.fuel == pytest.approx(row0.fuel, rel=SAME_EPISODES)
    assert shown.time_to_success == pytest.approx(row0.time_to_success)


def test_the_render_hint_names_the_package_not_a_checkout(monkeypatch):
    """A wheel installed without [render]: the hint must work outside a checkout too."""
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "pygame" else real(name, *a)
    )
    with pytest.raises(demo.DemoError, match=r"pip install 'rigid_env\[render\]'"):
        demo._check_render_extras()


# A fresh run against the committed results (docs/results/demo/episodes.csv, which the README's
# and the manual's tables are read from). On one machine the run is deterministic and equal bit
# for bit. Across CPUs the env is too (no fused multiply-add, our own sin/cos and tanh in the
# kernels), but the policy's float32 matrix products may sum in another order (AVX2 against
# AVX-512, another BLAS): actions then differ by ~1e-7 relative, which the closed loop carries
# to the episode's end without growing past ~1e-4 (each task's controller contracts the motion
# it acts on). So: success exactly; final |w|, fuel and return within 1 % (100x that); time to
# success within one control step (0.05 s; BdotDetumble's 5 s): a crossing of the success
# threshold moved by 1e-6 can land one step earlier or later.
COMMITTED = ROOT / "docs" / "results" / "demo" / "episodes.csv"
ACROSS_CPUS = 1e-2


@functools.cache
def one_step_s(task: str) -> float:
    """A control step of ``task`` [s] (and its rounding): made when a test asks, not when the
    file is collected, where each worker would compile every task's step."""
    env = gym.make(TASKS[task].env_id)
    try:
        return env.unwrapped.dt + 1e-9
    finally:
        env.close()


@pytest.mark.slow
def test_a_fresh_run_equals_the_committed_results(demo_run):
    out, _ = demo_run
    with open(COMMITTED) as fh:
        committed = {(r["task"], r["policy"], r["seed"]): r for r in csv.DictReader(fh)}
    with open(out / "episodes.csv") as fh:
        fresh = list(csv.DictReader(fh))
    assert len(fresh) == 2 * len(TASKS) * EPISODES
    for row in fresh:
        ref = committed[(row["task"], row["policy"], row["seed"])]
        assert row["success"] == ref["success"], row
        for col in ("final_angular_speed_rad_s", "fuel", "return"):
            assert float(row[col]) == pytest.approx(float(ref[col]), rel=ACROSS_CPUS, abs=1e-6)
        if ref["time_to_success_s"]:
            got, want = float(row["time_to_success_s"]), float(ref["time_to_success_s"])
            assert abs(got - want) <= one_step_s(row["task"]), row


def test_help_offers_exactly_the_tasks_the_demo_plays(capsys, monkeypatch):
    """A registered task without a pretrained policy (a new one, say) is neither offered by
    ``demo --help`` nor counted in its default; asking for it is a one-line error that says
    why. Every task the help offers, the demo resolves."""
    import rigid_env.envs
    from agents.shipped import shipped_id
    from rigid_env.envs import Task

    new = Task("StopZ", module="stop_z", scene="detumble", max_episode_steps=10)
    monkeypatch.setitem(rigid_env.envs.TASKS, "StopZ", new)
    assert main(["demo", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "StopZ" not in text and f"(default: all {len(TASKS)})" in text
    for name in TASKS:
        played = shipped_id(name)  # the id its policy was trained on (agents.shipped)
        assert name in text and played in text
        assert demo.resolve_tasks(name) == demo.resolve_tasks(played) == [name]
    with pytest.raises(demo.DemoError, match=r"^--task: StopZ ships no pretrained policy"):
        demo.resolve_tasks("stopz")
