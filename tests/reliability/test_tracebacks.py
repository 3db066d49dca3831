"""Issue 35, tracebacks: bad fault values at reset, an action_repeat past int64, torch tensors
as actions and a pretrained policy on an env that observes more are each one line (or, for
the tensors, simply work)."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
import torch
from reliability_helpers import ROOT, assert_one_line_error

import rigid_env.envs  # noqa: F401  (registers the ids)
from agents.evaluate import main as evaluate_main

D = "RigidEnv/Detumble-v0"


@pytest.mark.parametrize(
    ("fault", "field"),
    [
        ({"within_steps": 10**30}, "within_steps"),
        ({"within_steps": 2**63}, "within_steps"),
        ({"within_steps": True}, "within_steps"),
        ({"within_steps": "5"}, "within_steps"),
        ({"stuck_level": [1.0, 0.2]}, "stuck_level"),
        ({"stuck_level": [float("nan"), 1.0]}, "stuck_level"),
        ({"stuck_level": [0.0, float("inf")]}, "stuck_level"),
        ({"degraded_fraction": [float("nan"), 0.5]}, "degraded_fraction"),
        ({"degraded_fraction": [0.8, 0.2]}, "degraded_fraction"),
        ({"probability": "0.5"}, "probability"),
        ({"probability": True}, "probability"),
    ],
)
def test_bad_fault_values_are_one_line_before_any_reset(fault, field):
    """Values that used to raise deep in reset (an int64 overflow, a reversed range, a NaN
    draw) or pass as numbers (text, booleans): one ValueError line naming the field, at
    gym.make, before any episode."""
    kwargs = {"randomization": {"thruster_faults": {"probability": 1.0, **fault}}}
    with pytest.raises(ValueError) as info:
        gym.make(D, **kwargs)
    assert "\n" not in str(info.value)
    assert f"thruster_faults.{field}" in str(info.value)


@pytest.mark.parametrize("repeat", [2**63, 2**64, np.int64(2**62)])
def test_action_repeat_past_int64_is_one_line(repeat):
    with pytest.raises(ValueError, match=r"^randomization\.action_repeat: holds .* above 100000"):
        gym.make(D, randomization={"action_repeat": [repeat]})


@pytest.mark.parametrize(
    "make",
    [
        lambda a: torch.tensor(a, requires_grad=True),
        lambda a: torch.tensor(a, dtype=torch.bfloat16),
        lambda a: torch.tensor(a, dtype=torch.float64),
    ],
    ids=["grad", "bfloat16", "float64"],
)
def test_torch_tensors_as_actions_are_the_numbers_they_hold(make):
    """A tensor that requires grad, or in bfloat16 (NumPy takes neither): converted, the step
    equal to the one with the same numbers as a NumPy array."""
    action = np.array([0.5, -0.25, 1.0, 0.0, -1.0, 0.125])  # exact in bfloat16
    steps = []
    for a in (make(action), action):
        env = gym.make(D)
        env.reset(seed=5)
        obs, reward, *_ = env.step(a)
        steps.append((obs, reward))
    assert np.array_equal(steps[0][0], steps[1][0]) and steps[0][1] == steps[1][1]


def test_pretrained_policy_with_observe_control_period_names_the_option(capsys):
    """The shipped Detumble policy observes 13 numbers; the env with observe_control_period
    gives 14: one line naming the option, exit 2 (not a shape error deep in evaluate)."""
    model = ROOT / "agents" / "pretrained" / "ppo_detumble.zip"
    kwargs = json.dumps({"observe_control_period": True})
    argv = [str(model), "--env", D, "--episodes", "1", "--only", "model", "--env-kwargs", kwargs]
    assert evaluate_main(argv) == 2
    assert_one_line_error(
        capsys.readouterr().err, "agents.evaluate: error:", "observe_control_period=True"
    )


@pytest.mark.parametrize(
    ("changes", "words"),
    [
        ({"normalize": {"obs": 1}}, ["normalize.obs", "expected true or false, got 1"]),
        ({"policy_kwargs": {"ortho_init": "yes"}}, ["ortho_init", "true or false"]),
        ({"seed": "3"}, ["seed", "write the number without quotes: 3"]),
        ({"env_kwargs": {"observe_control_period": 1}}, ["observe_control_period", "got 1"]),
    ],
)
def test_integers_and_text_are_not_booleans_nor_numbers_in_a_training_config(
    tmp_path, capsys, changes, words
):
    """`obs: 1` passed as true; bools are not integers and integers not bools anywhere."""
    from reliability_helpers import write_config

    from agents.train import main as train_main

    config = write_config(tmp_path, **changes)
    assert train_main([str(config), "--runs-dir", str(tmp_path / "runs")]) == 2
    assert_one_line_error(capsys.readouterr().err, "agents.train: error:", *words)


def test_a_flag_given_double_dash_is_one_line(tmp_path, capsys):
    """`--out=--` reached simulate as an empty list (a TypeError traceback); `--seed=--` the
    training config as one: each refused in one line naming the flag."""
    from agents.train import main as train_main
    from rigid_env.cli import main as cli_main

    scene = ROOT / "configs" / "scenes" / "detumble.yaml"
    assert cli_main(["simulate", str(scene), "--steps", "2", "--out=--"]) == 2
    assert_one_line_error(capsys.readouterr().err, "rigid-env: error: --out:", "'--'")
    with pytest.raises(SystemExit) as info:
        train_main([str(ROOT / "configs" / "agents" / "ppo_detumble.yaml"), "--seed=--"])
    assert info.value.code == 2
    assert_one_line_error(capsys.readouterr().err, "agents.train: error:", "--seed", "'--'")
