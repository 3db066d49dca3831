"""The rsl-rl learner (agents.parallel): its policy as the SB3 zip our tools read, its configs."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

pytest.importorskip("rsl_rl")

from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecNormalize

from agents.callbacks import save_snapshot
from agents.config import ConfigError, load_config
from agents.parallel.learner import make_runner, to_sb3
from agents.train import _new_model, make_vec_env

ROOT = Path(__file__).resolve().parents[2]
# SB3's MlpPolicy and rsl-rl's MLP run the same float32 layers on the same weights and inputs:
# the actions agree to float32 rounding (~1e-7 on actions in [-1, 1]); the issue asks 1e-6.
SAME_ACTIONS = 1e-6

TINY = {
    "env_id": "RigidEnv/Detumble-v0",
    "algo": "ppo",
    "learner": "rsl_rl",
    "seed": 3,
    "total_timesteps": 2048,
    "n_envs": 64,
    "env_kwargs": {"randomization": {"inertia": 0.5, "sensor_noise": 0.01}},
    "policy_kwargs": {"net_arch": [32, 32], "activation_fn": "tanh", "log_std_init": -1.0},
    "hyperparams": {"n_steps": 8, "batch_size": 256, "n_epochs": 2, "learning_rate": 3e-3},
    "eval": {"freq": 1024, "episodes": 4, "seed": 1000},
    "checkpoint_freq": 1024,
}


def trained_runner(cfg):
    venv = make_vec_env(cfg, cfg.n_envs, cfg.seed)
    runner = make_runner(cfg, venv, 400)
    runner.learn(3)
    return runner, venv


def test_sb3_zip_acts_as_the_learner(tmp_path: Path) -> None:
    cfg = load_config(TINY)
    runner, venv = trained_runner(cfg)
    model = _new_model(cfg, venv, tmp_path, 0)
    to_sb3(runner, model)
    model.num_timesteps = 3 * 64 * 8
    save_snapshot(model, tmp_path / "model.zip", tmp_path / "vecnormalize.pkl", None,
                  {"env_id": cfg.env_id, "algo": "ppo", "env_kwargs": {}})  # fmt: skip
    # raw observations from the task: the env's own, un-normalised
    rng = np.random.default_rng(0)
    raw = np.concatenate([venv.get_original_obs()] + [
        venv.unnormalize_obs(venv.step(rng.uniform(-1, 1, (64, 6)))[0]) for _ in range(30)
    ])  # fmt: skip
    loaded = PPO.load(str(tmp_path / "model.zip"), device="cpu")
    norm = VecNormalize.load(str(tmp_path / "vecnormalize.pkl"), venv)
    norm.training = False
    ours = norm.normalize_obs(raw).astype(np.float32)
    with torch.no_grad():
        actor = runner.alg.get_policy()
        mean = actor.mlp(torch.from_numpy(ours))
        learner = torch.clamp(mean, -1.0, 1.0).numpy()
    sb3 = loaded.predict(ours, deterministic=True)[0]
    assert np.abs(sb3 - learner).max() <= SAME_ACTIONS
    assert np.abs(learner).max() > 0.05  # a policy that acts, not zeros on both sides
    # the evaluation tools read it: agents.evaluate with its sidecar and statistics
    from agents.evaluate import load_policy

    policy = load_policy(tmp_path / "model.zip", cfg.env_id)
    assert np.abs(policy(raw) - learner).max() <= SAME_ACTIONS


def test_same_seed_same_policy() -> None:
    cfg = load_config(TINY)
    first, _ = trained_runner(cfg)
    second, _ = trained_runner(cfg)
    a, b = first.alg.get_policy().state_dict(), second.alg.get_policy().state_dict()
    assert all(torch.equal(a[k], b[k]) for k in a)
    other, _ = trained_runner(load_config({**TINY, "seed": 4}))
    c = other.alg.get_policy().state_dict()
    assert not all(torch.equal(a[k], c[k]) for k in a)


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ({"hyperparams": {"n_steps": 8, "batch_size": 300}}, "does not divide"),
        ({"hyperparams": {"n_steps": 8, "target_kl": 0.02}}, "not taken by learner rsl_rl"),
        ({"policy_kwargs": {"ortho_init": True}}, "not taken by learner rsl_rl"),
        ({"learner": "sb3", "rsl_rl": {"schedule": "adaptive"}}, "learner rsl_rl only"),
        ({"algo": "sac", "hyperparams": {}, "policy_kwargs": {}}, "ppo only"),
    ],
)
def test_config_refusals_name_the_field(change: dict, words: str) -> None:
    from agents.parallel.learner import runner_config

    with pytest.raises(ConfigError, match=words):
        runner_config(load_config({**TINY, **change}))


@pytest.mark.slow
def test_train_command_runs_resumes_and_evaluates(tmp_path: Path) -> None:
    config = tmp_path / "tiny.yaml"
    config.write_text(json.dumps(TINY))  # JSON is YAML
    runs = tmp_path / "runs"

    def train(*extra: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, "-m", "agents.train", str(config), "--runs-dir", str(runs),
             "--no-progress", *extra],
            cwd=ROOT, capture_output=True, text=True, timeout=300, check=False,
        )  # fmt: skip

    first = train()
    assert first.returncode == 0, first.stderr
    run = runs / "Detumble__ppo_rsl__3"
    side = json.loads((run / "model.json").read_text())
    assert side["num_timesteps"] == 2048 and side["vecnormalize"] == "vecnormalize.pkl"
    assert (run / "model.optim.pt").exists() and (run / "eval" / "evaluations.npz").exists()
    from agents.meaning import recorded_meaning

    assert recorded_meaning(run / "model.zip") is not None  # what its actions mean, inside it
    again = train("--resume", "--total-timesteps", "3072")
    assert again.returncode == 0, again.stderr
    assert json.loads((run / "model.json").read_text())["num_timesteps"] == 3072
    with np.load(run / "eval" / "evaluations.npz") as h:
        assert list(h["timesteps"]) == [1024, 2048, 3072]
    from agents.evaluate import evaluate

    res = evaluate(run / "model.zip", TINY["env_id"], 2, 5, only=["model"])
    assert res["model"]["episodes"] == 2


@pytest.mark.slow
def test_rates_benchmark_measures_every_learner() -> None:
    """`rigid-env bench learn --rates-only`'s measurement runs each learner's three loops (the
    rates themselves are the benchmark's to report, not a test's to bound)."""
    pytest.importorskip("skrl")
    from rigid_env.bench.learn_rates import RATES, markdown, measure

    rows = measure(
        "detumble", ("sb3", "rsl_rl", "skrl"), 1, 1, n_envs=64, stretch_s=0.0, whole_episodes=False
    )
    assert [r.learner for r in rows] == ["sb3", "rsl_rl", "skrl"]
    assert all(getattr(r, rate) > 0 for r in rows for rate in RATES)
    assert rows[1].n_envs == rows[2].n_envs == 64
    assert len(markdown(rows)) == 2 + len(rows)


def test_rates_run_each_learner_on_its_own_threads_and_restore_the_counts() -> None:
    """The guide's allotment (`--sb3-threads 1 --threads 2`): the SB3 path's rows on one
    thread, rsl_rl's on two, both measured, the table saying so, and the process's torch and
    Numba thread counts as they were before."""
    import numba

    from rigid_env.bench.learn_rates import RATES, markdown, measure

    before = torch.get_num_threads(), numba.get_num_threads()
    rows = measure("detumble", ("sb3", "rsl_rl"), 1, 2, n_envs=64, stretch_s=0.0,
                   whole_episodes=False, sb3_threads=1)  # fmt: skip
    assert [(r.learner, r.threads) for r in rows] == [("sb3", 1), ("rsl_rl", 2)]
    assert all(getattr(r, rate) > 0 for r in rows for rate in RATES)
    assert [line.split(" | ")[5] for line in markdown(rows)[2:]] == ["1", "2"]
    assert (torch.get_num_threads(), numba.get_num_threads()) == before


def test_bench_learn_plans_rsl_runs_only_where_a_task_has_its_config() -> None:
    """`rigid-env bench learn --tasks tumbling_fall detumble` (TumblingFall has no rsl-rl
    config): the shipped and previous runs of both, rsl-rl's of Detumble alone, rather than a
    FileNotFoundError before anything runs; the rates refuse rsl_rl on it in one line."""
    import argparse

    from rigid_env.bench import learn
    from rigid_env.bench.learn_rates import config_of

    parser = argparse.ArgumentParser()
    learn.add_arguments(parser)
    args = parser.parse_args(["--tasks", "tumbling_fall", "detumble", "--seeds", "0", "1"])
    runs = {(task, seed, kind) for task, seed, kind, _ in learn.plan(args)}
    sb3 = {(t, s, k) for t in ("tumbling_fall", "detumble") for s in (0, 1)
           for k in ("shipped", "previous")}  # fmt: skip
    want = sb3 | {("detumble", 0, "rsl_rl"), ("detumble", 1, "rsl_rl")}
    assert runs == want
    with pytest.raises(ValueError, match=r"^--learners: rsl_rl has no config for tumbling_fall"):
        config_of("tumbling_fall", "rsl_rl")
