"""Ray Tune sweeps (agents.sweep): sweep files, trials, a local sweep, resume, bad addresses.

The sweep-file and trial tests need no Ray; the others are skipped when ``ray[tune]`` is not
installed. All Ray tests share one local Ray instance (2 CPUs, no dashboard, quiet).
"""

from __future__ import annotations

import importlib.util
import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from agents.config import ConfigError, load_config
from agents.sweep import (
    SweepError,
    grid_points,
    load_sweep,
    main,
    run_sweep,
    run_trial,
    setting_label,
)

ROOT = Path(__file__).resolve().parents[2]
BASE = ROOT / "configs/agents/ppo_detumble.yaml"

HAS_RAY = importlib.util.find_spec("ray") is not None
needs_ray = pytest.mark.skipif(
    not HAS_RAY,
    reason="ray[tune] is not installed (pip install -e '.[sweep]'); "
    "sweep runs on Ray are not tested",
)

#: A trial of a few hundred steps: 2 envs x 64-step rollouts, 50-step episodes.
TINY = {
    "name": "tiny",
    "base": str(BASE),
    "total_timesteps": 256,
    "overrides": {
        "n_envs": 2,
        "env_kwargs": {"max_episode_steps": 50},
        "hyperparams": {"n_steps": 64, "batch_size": 64, "n_epochs": 1},
        "eval": {"freq": 128, "episodes": 2},
        "checkpoint_freq": 128,
    },
    "grid": {"seed": [0, 1]},
    "cpus_per_trial": 1,
    "max_concurrent": 2,
    "evaluation": {"episodes": 4, "seed": 12345},
}


def _sweep_file(tmp_path: Path, **changes) -> Path:
    data = {**TINY, "storage": str(tmp_path / "sweeps"), **changes}
    p = tmp_path / "sweep.yaml"
    p.write_text(yaml.safe_dump(data, sort_keys=False))
    return p


# --------------------------------------------------------------------------- sweep files


def test_shipped_sweep_files_load():
    for p in sorted((ROOT / "configs/sweeps").glob("*.yaml")):
        sweep = load_sweep(p)
        assert sweep.directory == Path("runs/sweeps") / sweep.name
        assert len(grid_points(sweep)) >= 2


def test_grid_is_the_cartesian_product_with_seeds_innermost(tmp_path):
    p = _sweep_file(
        tmp_path,
        grid={
            "seed": [0, 1, 2],
            "hyperparams.learning_rate": [3.0e-4, 1.0e-3],
            "env_kwargs.integrator": ["splitting", "rk4"],
        },
    )
    sweep = load_sweep(p)
    points = grid_points(sweep)
    assert len(points) == 12 and [pt["seed"] for pt in points[:3]] == [0, 1, 2]
    labels = [setting_label(sweep.varying, pt) for pt in points]
    assert labels[0] == "learning_rate=0.0003, integrator=splitting"
    assert len(set(labels)) == 4  # seeds share a setting


@pytest.mark.parametrize(
    ("change", "named"),
    [
        ({"learning_rate": 1.0e-3}, "learning_rate"),  # unknown top-level key
        ({"grid": {"seed": [0], "lr": [1]}}, "grid.lr"),  # unknown axis
        ({"grid": {"seed": [0], "hyperparams.learnin_rate": [1.0e-3]}}, "hyperparams.learnin_rate"),
        ({"grid": {"seed": [0], "env_kwargs.integrator": ["rk5"]}}, "rk5"),
        ({"grid": {"seed": [0, 0]}}, "grid.seed"),  # duplicate value
        ({"grid": {"seed": "0"}}, "grid.seed"),  # not a list
        ({"grid": {"env_id": ["RigidEnv/Nope-v0"]}}, "env_id"),
        ({"metric": "accuracy"}, "metric"),
        ({"cpus_per_trial": 0}, "cpus_per_trial"),
        ({"total_timesteps": "many"}, "total_timesteps"),
        ({"overrides": {"eval": {"frq": 10}}}, "eval.frq"),
        ({"overrides": {"seed": 3}}, "overrides.seed"),
        ({"evaluation": {"episode": 3}}, "evaluation.episode"),
        ({"base": "nope.yaml"}, "base"),
        ({"name": "a/b"}, "name"),
    ],
)
def test_bad_sweep_file_is_one_line_naming_the_key(tmp_path, capsys, change, named):
    p = _sweep_file(tmp_path, **change)
    with pytest.raises(ConfigError) as exc:
        load_sweep(p)
    msg = str(exc.value)
    assert named in msg and str(p) in msg and "\n" not in msg, msg
    assert main([str(p)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("agents.sweep: error: ") and err.count("\n") == 1, err


def test_exponent_integers_are_the_numbers_meant(tmp_path):
    """Read as the training config is: 1e5 is 100000 (YAML 1.1 would read a string)."""
    p = _sweep_file(tmp_path)
    p.write_text(p.read_text().replace("total_timesteps: 256", "total_timesteps: 1e5"))
    assert load_sweep(p).total_timesteps == 100_000


def test_missing_sweep_file(tmp_path, capsys):
    assert main([str(tmp_path / "missing.yaml")]) == 2
    assert "file not found" in capsys.readouterr().err


# --------------------------------------------------------------------------- trials


def _spec(sweep_dir: Path) -> dict:
    from agents.sweep import _spec as spec

    return spec(load_sweep(_sweep_file(sweep_dir)), sweep_dir)


@pytest.mark.slow
def test_trial_trains_with_agents_train_reports_and_skips_when_done(tmp_path):
    """A trial (without Ray) reports after each evaluation and at the end, writes the same
    run folder as agents.train, and called again evaluates without training again."""
    import torch

    from agents.train import train

    reports: list[dict] = []
    spec = _spec(tmp_path)
    threads = torch.get_num_threads()  # a trial sets its own thread count
    try:
        final = run_trial({"seed": 0}, spec, report=reports.append)
    finally:
        torch.set_num_threads(threads)
    run_dir = Path(final["run_dir"])
    assert run_dir == tmp_path / "runs" / "base" / "Detumble__ppo__0"
    assert [r["timesteps"] for r in reports] == [128, 256, 256]
    assert [r["final"] for r in reports] == [False, False, True]
    assert reports[-1]["episodes"] == 4 and 0.0 <= final["success_rate"] <= 1.0
    for name in (
        "config.yaml",
        "model.zip",
        "vecnormalize.pkl",
        "model.json",
        "eval/evaluations.npz",
        "checkpoints/model_256_steps.zip",
        "final_eval.json",
    ):
        assert (run_dir / name).exists(), name

    stamp = (run_dir / "model.zip").stat().st_mtime_ns
    again: list[dict] = []
    assert (
        run_trial({"seed": 0}, spec, report=again.append)["success_rate"] == final["success_rate"]
    )
    assert len(again) == 1 and (run_dir / "model.zip").stat().st_mtime_ns == stamp

    # Deterministic per seed, and the same training job: agents.train with the trial's
    # resolved config gives the same weights, bit for bit.
    threads = torch.get_num_threads()
    torch.set_num_threads(spec["threads"])
    try:
        direct = train(load_config(run_dir / "config.yaml"), tmp_path / "direct", progress=False)
    finally:
        torch.set_num_threads(threads)
    from stable_baselines3 import PPO

    a = PPO.load(run_dir / "model.zip").policy.state_dict()
    b = PPO.load(direct / "model.zip").policy.state_dict()
    assert all(np.array_equal(a[k].numpy(), b[k].numpy()) for k in a)


# --------------------------------------------------------------------------- Ray


@pytest.fixture(scope="module")
def local_ray():
    """One quiet local Ray instance for the module (sweeps reuse a running instance)."""
    if not HAS_RAY:
        pytest.skip("ray[tune] is not installed")
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    os.environ.setdefault("RAY_AIR_NEW_OUTPUT", "0")
    import logging

    import ray

    ray.init(
        address="local",
        num_cpus=2,
        include_dashboard=False,
        log_to_driver=False,
        logging_level=logging.ERROR,
    )
    yield ray
    ray.shutdown()


def _assert_run_folder(run_dir: Path) -> None:
    for name in (
        "config.yaml",
        "model.zip",
        "model.json",
        "eval/evaluations.npz",
        "final_eval.json",
    ):
        assert (run_dir / name).exists(), run_dir / name


@needs_ray
@pytest.mark.slow
def test_local_sweep_writes_run_folders_and_summary(tmp_path, local_ray, capsys):
    p = _sweep_file(tmp_path)
    assert main([str(p)]) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    sweep_dir = tmp_path / "sweeps" / "tiny"
    for seed in (0, 1):
        _assert_run_folder(sweep_dir / "runs" / "base" / f"Detumble__ppo__{seed}")
    table = (sweep_dir / "summary.md").read_text()
    assert "| base | 2 |" in table and table in out
    assert len((sweep_dir / "summary.csv").read_text().strip().splitlines()) == 3
    assert (sweep_dir / "summary.png").stat().st_size > 0
    best = load_config(sweep_dir / "best_config.yaml")
    assert best.total_timesteps == 256 and best.n_envs == 2

    # Running it again without --resume would mix two sweeps: refused in one line.
    assert main([str(p)]) == 2
    assert "--resume" in capsys.readouterr().err


class _InterruptAfterFirstTrial:
    """Press Ctrl+C (SIGINT to this process) once the first trial has finished."""

    def __new__(cls, flag: Path):
        from ray import tune

        class Interrupt(tune.Callback):
            def on_trial_complete(self, iteration, trials, trial, **info):
                if not flag.exists():  # once: this callback is stored with the experiment
                    flag.write_text(trial.trial_id)
                    os.kill(os.getpid(), signal.SIGINT)

        return Interrupt()


@needs_ray
@pytest.mark.slow
def test_interrupted_sweep_resumes_only_unfinished_trials(tmp_path, local_ray, capsys):
    p = _sweep_file(tmp_path, max_concurrent=1)
    sweep = load_sweep(p)
    with pytest.raises(SweepError, match="no sweep to resume"):
        run_sweep(sweep, resume=True)
    rows = run_sweep(
        sweep, tune_callbacks=[_InterruptAfterFirstTrial(tmp_path / "flag")], log=lambda line: None
    )
    assert len(rows) == 1
    done = Path(rows[0].run_dir)
    other = done.parent / f"Detumble__ppo__{1 - rows[0].seed}"
    assert not (other / "final_eval.json").exists()
    stamps = {f: (done / f).stat().st_mtime_ns for f in ("model.zip", "final_eval.json")}
    tune_dir = tmp_path / "sweeps" / "tiny" / "tune"
    first_trial = tune_dir / f"trial_{(tmp_path / 'flag').read_text()}" / "result.json"
    reports = first_trial.read_text().count("\n")

    assert main([str(p), "--resume"]) == 0, capsys.readouterr().err
    _assert_run_folder(other)
    assert {f: (done / f).stat().st_mtime_ns for f in stamps} == stamps
    assert first_trial.read_text().count("\n") == reports  # the finished trial never ran again
    assert "| base | 2 |" in (tmp_path / "sweeps" / "tiny" / "summary.md").read_text()


@needs_ray
@pytest.mark.parametrize("how", ["flag", "env"])
def test_unreachable_address_fails_fast_in_one_line(tmp_path, capsys, monkeypatch, how):
    p = _sweep_file(tmp_path)
    address = "ray://127.0.0.1:9"  # discard port: nothing listens there
    args = [str(p), "--connect-timeout", "2"]
    if how == "flag":
        args += ["--address", address]
    else:
        monkeypatch.setenv("RAY_ADDRESS", address)
    start = time.monotonic()
    assert main(args) == 2
    assert time.monotonic() - start < 15.0
    err = capsys.readouterr().err
    assert err.startswith("agents.sweep: error: --address ray://127.0.0.1:9: cannot reach")
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not (tmp_path / "sweeps" / "tiny" / "tune").exists()


def test_bad_address_format_is_one_line(tmp_path, capsys):
    if not HAS_RAY:
        pytest.skip("ray[tune] is not installed")
    assert main([str(_sweep_file(tmp_path)), "--address", "localhost"]) == 2
    assert "expected ray://HOST:PORT" in capsys.readouterr().err
