"""sbx-rl's PPO on the batched task (agents.parallel.sbx_peer), the JIT-compiled peer that
`rigid-env bench learn` measures (issue 45)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("sbx", reason="sbx-rl is in the bench extra: pip install 'rigid_env[bench]'")

from agents.config import load_config
from agents.parallel.sbx_peer import _Bootstrap, make_sbx, sample
from agents.train import make_vec_env

TINY = {
    "env_id": "RigidEnv/Detumble-v0",
    "algo": "ppo",
    "learner": "rsl_rl",
    "seed": 3,
    "total_timesteps": 2048,
    "n_envs": 4,
    "env_kwargs": {"randomization": {"inertia": 0.5, "sensor_noise": 0.01}},
    "policy_kwargs": {"net_arch": [32, 32], "activation_fn": "tanh", "log_std_init": -1.0},
    "hyperparams": {"n_steps": 8, "batch_size": 16, "n_epochs": 2, "learning_rate": 3e-3},
    "rsl_rl": {"schedule": "adaptive", "desired_kl": 0.01},
    "eval": {"freq": 1024, "episodes": 4, "seed": 1000},
    "checkpoint_freq": 1024,
}
# The critic's value of one observation in a batch of 4 and alone: the same float32 layers, the
# sums possibly in another order (XLA vectorises the batch): a few ulps of values of order 1.
SAME_VALUE = 1e-5


def tiny(tmp_path):
    import yaml

    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(TINY))
    return load_config(path)


def test_time_limit_bootstrap_is_sbx_rls_own_per_env_value(tmp_path) -> None:
    """The batched bootstrap adds gamma V(terminal observation) to exactly the envs cut by the
    time limit, the value sbx-rl's per-env loop would add, and leaves a terminated env alone."""
    cfg = tiny(tmp_path)
    venv = make_vec_env(cfg, cfg.n_envs, cfg.seed)
    model = make_sbx(cfg, venv)
    assert model.target_kl == 0.01 and model.n_epochs == 2 and model.batch_size == 16
    rng = np.random.default_rng(0)
    obs_dim = venv.observation_space.shape[0]
    terminal = rng.normal(size=(4, obs_dim)).astype(np.float32)
    rewards = np.array([0.5, -1.0, 2.0, 0.25], np.float32)
    dones = np.array([False, True, True, True])
    infos = [{}, {"TimeLimit.truncated": True, "terminal_observation": terminal[1]},
             {"TimeLimit.truncated": False, "terminal_observation": terminal[2]},
             {"TimeLimit.truncated": True, "terminal_observation": terminal[3]}]  # fmt: skip
    obs = rng.normal(size=(4, obs_dim)).astype(np.float32)
    boot = _Bootstrap(venv, model)  # what BatchedPPO's rollout steps
    boot.venv.step_wait = lambda: (obs, rewards.copy(), dones, infos)
    _, got, _, got_infos = boot.step_wait()
    params = model.policy.vf_state.params
    alone = [float(np.asarray(model.vf.apply(params, terminal[i][None])).item()) for i in (1, 3)]
    want = rewards.copy()
    want[[1, 3]] += model.gamma * np.array(alone, np.float32)
    np.testing.assert_allclose(got, want, rtol=0, atol=SAME_VALUE)
    assert got[0] == rewards[0] and got[2] == rewards[2]
    assert "terminal_observation" not in got_infos[1] and "terminal_observation" in got_infos[2]


def test_learns_and_samples_in_the_action_space(tmp_path) -> None:
    """Two rollouts and updates through the wrapper run; sampled actions lie in [-1, 1]."""
    cfg = tiny(tmp_path)
    venv = make_vec_env(cfg, cfg.n_envs, cfg.seed)
    model = make_sbx(cfg, venv)
    model.learn(2 * cfg.n_envs * 8)
    assert model.num_timesteps == 64
    actions, _ = sample(model, venv.reset())
    assert actions.shape == (4, venv.action_space.shape[0]) and np.all(np.abs(actions) <= 1)


@pytest.mark.slow
def test_rates_benchmark_measures_sbx() -> None:
    """`rigid-env bench learn --rates-only --learners sb3 sbx --sbx-config ...` runs sbx-rl's
    three loops on the config it is given (here SB3's shipped one, narrowed to 64 envs)."""
    from rigid_env.bench.learn_rates import RATES, measure
    from rigid_env.resources import data_path

    shipped = data_path("configs/agents/ppo_detumble.yaml")
    rows = measure("detumble", ("sb3", "sbx"), 1, 1, n_envs=64, stretch_s=0.0,
                   whole_episodes=False, sbx_config=shipped)  # fmt: skip
    assert [r.learner for r in rows] == ["sb3", "sbx"] and rows[1].n_envs == 64
    assert rows[1].config == "ppo_detumble.yaml" and rows[1].batch_size == 512  # 1024 * 64/128
    assert all(getattr(r, rate) > 0 for r in rows for rate in RATES)
    assert all(0 < r.update_share < 1 for r in rows)  # the update is part of each full stretch


def test_update_cost_benchmark_prints_one_row_per_minibatch() -> None:
    """`python -m rigid_env.bench.learn_update 8 16`: a row per size, every cost positive (the
    costs are the benchmark's to report, not a test's to bound); a size < 2 is refused."""
    from rigid_env.bench.learn_update import main, measure

    rows = measure([8, 16], stretch_s=0.01, repeats=1)
    assert [r.split("|")[1].strip() for r in rows] == ["8", "16"]
    assert all(float(x) > 0 for r in rows for x in r.strip("| x\n").split("|")[1:5])
    assert main(["1"]) == 2


def test_cpu_split_reports_both_learners(tmp_path) -> None:
    """`python -m rigid_env.bench.learn_update --split CONFIG`: a line for SB3 and for sbx-rl."""
    from rigid_env.bench.learn_update import split

    tiny(tmp_path)
    lines = split(str(tmp_path / "tiny.yaml"), iterations=1)
    assert [line.split(":")[0] for line in lines] == ["sb3", "sbx"]
    assert all("env-steps per CPU-s" in line for line in lines)
