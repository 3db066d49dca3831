"""agents.baselines: the summary over seeds, the conditions, and its refusals."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import pytest

import agents.baselines as baselines
from agents.baselines import (
    CONDITIONS,
    METRICS,
    Run,
    condition_kwargs,
    evaluate_runs,
    find_run,
    main,
    summary_table,
)
from agents.env_kwargs import merge_env_kwargs
from agents.evaluate import EvaluationError

ENV = "RigidEnv/Detumble-v0"


def _rec(policy, seed, condition, success, fuel, t, steps=1_000_000):
    return {
        "env_id": "RigidEnv/Detumble-v0", "policy": policy, "seed": seed,
        "condition": condition, "timesteps": steps, "success_rate": success,
        "mean_final_angular_speed": 0.0, "mean_fuel": fuel, "mean_return": 0.0,
        "mean_time_to_success": t, "numerical_errors": 0,
    }  # fmt: skip


def test_summary_is_mean_worst_and_best_over_seeds_and_fuel_against_pd():
    records = [
        _rec("PPO", 0, "nominal", 1.00, 0.50, 1.0),
        _rec("PPO", 1, "nominal", 0.90, 0.70, 3.0),
        _rec("PPO", 2, "nominal", 0.95, 0.60, None),  # no success: no time to success
        *(_rec("PPO", s, "randomised", x, 1.0, 1.0) for s, x in enumerate((0.9, 0.8, 0.7))),
        *(
            _rec("PPO", s, c, 0.5, 1.0, 1.0)
            for s in range(3)
            for c in ("inertia +-90 %", "control step x2", "control step x4")
        ),
        *(_rec("pd", None, c, 1.0, 0.40, 2.0, None) for c in CONDITIONS),
    ]
    lines = summary_table(records).splitlines()
    ppo = [c.strip() for c in lines[2].strip("|").split("|")]
    pd = [c.strip() for c in lines[3].strip("|").split("|")]
    assert ppo == ["Detumble-v0", "PPO", "1.0M", "3", "0.95 (0.90-1.00)", "0.600", "1.50",
                   "2.00", "0.80", "0.50", "0.50", "0.50"]  # fmt: skip
    assert pd == ["Detumble-v0", "pd", "-", "-", "1.00", "0.400", "1.00", "2.00"] + ["1.00"] * 4


def test_nominal_condition_switches_off_a_training_randomisation():
    """A model trained under randomisation is evaluated without it in the nominal column: the
    condition's kwargs override every randomisation key of the recorded ones."""
    trained = {"randomization": {"inertia": 0.5, "thrust": 0.3, "sensor_noise": 0.01}}
    merged = merge_env_kwargs(trained, CONDITIONS["nominal"])
    assert all(v == 0.0 for v in merged["randomization"].values())
    assert merge_env_kwargs(trained, condition_kwargs("control step x4", ENV))["dt"] == 0.2


@pytest.mark.parametrize(("env_id", "dt"), [(ENV, 0.05), ("RigidEnv/BdotDetumble-v0", 5.0)])
def test_the_control_step_conditions_scale_each_tasks_own_step(env_id, dt):
    """``control step x2`` and ``x4`` hold each action two and four of the task's steps: 0.1 and
    0.2 s on a thruster task, 10 and 20 s on BdotDetumble (exact: powers of two)."""
    for factor in (2, 4):
        kwargs = condition_kwargs(f"control step x{factor}", env_id)
        assert kwargs["dt"] == factor * dt
        assert gym.make(env_id, **kwargs).unwrapped.task.dt == factor * dt


def test_unfinished_run_and_existing_results_are_refused(tmp_path, capsys):
    with pytest.raises(EvaluationError, match="no finished run"):
        find_run(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.md").write_text("earlier\n")
    assert main([str(tmp_path), "--out", str(out)]) == 2
    assert "pass --force" in capsys.readouterr().err
    assert (out / "results.md").read_text() == "earlier\n"


def test_conditions_keep_a_variants_registered_randomisation(monkeypatch):
    """DetumbleFaults-v0 registers its misalignment and faults under ``randomization``; a
    condition's ``randomization`` adds to it key by key (:func:`rigid_env.envs.variant_kwargs`):
    the env of every condition keeps them, and its episodes still draw faults."""
    seen = []

    def record(model, env_id, episodes, seed, only, kwargs):
        seen.append(kwargs)
        return {name: dict.fromkeys(METRICS, 0.0) for name in only}

    monkeypatch.setattr(baselines, "evaluate", record)
    env_id = "RigidEnv/DetumbleFaults-v0"
    run = Run(Path("run"), env_id, "ppo", 0, 1, {})
    evaluate_runs([run], episodes=1, seed=0)
    assert len(seen) == 2 * len(CONDITIONS)  # the model and the controllers, per condition
    registered = gym.spec(env_id).kwargs["randomization"]
    for kwargs in seen:
        env = gym.make(env_id, **kwargs)
        drawn = env.unwrapped.task.randomization
        assert drawn.thruster_misalignment == registered["thruster_misalignment"]
        assert drawn.thruster_faults.probability == registered["thruster_faults"]["probability"]
        env.close()
    # 64 episodes at a fault probability of 0.5 all draw none with probability 2^-64.
    env = gym.make_vec(env_id, num_envs=64, vectorization_mode="vector_entry_point", **seen[0])
    _, info = env.reset(seed=0)
    assert (info["fault_kind"] >= 0).any() and (info["fault_kind"] < 0).any()
    env.close()
