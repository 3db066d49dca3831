"""A training config's mistakes end in one line before any training starts (item 8).

Each case goes through ``agents.train``'s command line in this process; one goes through a
fresh interpreter to show the exit status and stderr end to end.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from reliability_helpers import ROOT, TINY, assert_one_line_error, run_module

from agents.config import ConfigError, load_config
from agents.train import main as train_main

ERR = "agents.train: error: "
HYPER = TINY["hyperparams"]

CASES = {
    "integrator rk5": (
        {"env_kwargs": {"integrator": "rk5"}},
        ["env_kwargs.integrator", "rk5", "choose one of", "rk4"],
    ),
    "randomization out of range": (
        {"env_kwargs": {"randomization": {"inertia": 1.5}}},
        ["env_kwargs.randomization.inertia", "[0, 1)"],
    ),
    "unknown env keyword": ({"env_kwargs": {"wind": 3}}, ["env_kwargs.wind", "unknown keyword"]),
    "gamma nan": ({"hyperparams": {**HYPER, "gamma": float("nan")}}, ["hyperparams.gamma", "nan"]),
    "gamma 2": ({"hyperparams": {**HYPER, "gamma": 2}}, ["hyperparams.gamma", "(0, 1]"]),
    "clip_obs -1": ({"normalize": {"clip_obs": -1}}, ["normalize.clip_obs", "greater than 0"]),
    "learning_rate -1": (
        {"hyperparams": {**HYPER, "learning_rate": -1}},
        ["hyperparams.learning_rate", "greater than 0"],
    ),
    "learning_rate in quotes": (
        {"hyperparams": {**HYPER, "learning_rate": "fast"}},
        ["hyperparams.learning_rate", "without quotes"],
    ),
    "device gpu9": ({"device": "gpu9"}, ["device", "gpu9", "cpu, cuda"]),
    "policy MLPpolicy": ({"policy": "MLPpolicy"}, ["policy", "MLPpolicy", "MlpPolicy"]),
    "unknown policy_kwargs key": (
        {"policy_kwargs": {"net_arch": [16], "net_arc": [16]}},
        ["policy_kwargs.net_arc", "allowed keys", "net_arch"],
    ),
    "policy_kwargs for another policy": (
        {"policy_kwargs": {"n_critics": 2}},
        ["policy_kwargs.n_critics", "PPO"],
    ),
    "string net_arch": ({"policy_kwargs": {"net_arch": "64,64"}}, ["policy_kwargs.net_arch"]),
    "negative layer width": (
        {"policy_kwargs": {"net_arch": [64, -1]}},
        ["policy_kwargs.net_arch[1]", "greater than or equal to 1"],
    ),
    "n_envs 0": ({"n_envs": 0}, ["n_envs", "greater than or equal to 1"]),
    "eval seed -1": ({"eval": {"seed": -1}}, ["eval.seed"]),
    "unknown hyperparameter": (
        {"hyperparams": {**HYPER, "n_stepz": 3}},
        ["hyperparams.n_stepz", "PPO"],
    ),
    "algo dqn": ({"algo": "dqn"}, ["algo", "'ppo'"]),
    "env id": ({"env_id": "RigidEnv/Nope-v0"}, ["env_id", "RigidEnv/Detumble-v0"]),
}


@pytest.mark.parametrize("name", list(CASES))
def test_bad_config_is_one_line_before_any_training(tmp_path, capsys, name):
    change, words = CASES[name]
    path = tmp_path / "cfg.yaml"
    path.write_text(yaml.safe_dump({**TINY, **change}))
    assert train_main([str(path), "--runs-dir", str(tmp_path / "runs"), "--no-progress"]) == 2
    assert_one_line_error(capsys.readouterr().err, ERR, str(path), *words)
    assert not (tmp_path / "runs").exists()  # nothing started


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("- env_id: RigidEnv/Detumble-v0\n- algo: ppo\n", ["holds a list", "key: value"]),
        ("algo: ppo\nalgo: sac\n", ["line 2", "'algo' given twice", "keep one"]),
        ("env_id: [RigidEnv/Detumble-v0\n", ["line", "fix the YAML syntax"]),
        ("", ["holds nothing", "key: value"]),
    ],
)
def test_bad_yaml_is_one_line(tmp_path, capsys, text, words):
    path = tmp_path / "cfg.yaml"
    path.write_text(text)
    assert train_main([str(path), "--runs-dir", str(tmp_path / "runs")]) == 2
    assert_one_line_error(capsys.readouterr().err, ERR, str(path), *words)


def test_exponent_floats_read_as_the_numbers_meant(tmp_path):
    """YAML 1.1 reads 1e-4 as the string '1e-4' (SB3 then failed an assertion); it is the
    number, and so are 1e5, 2.5E+3 and 1e1."""
    path = tmp_path / "cfg.yaml"
    path.write_text(
        "env_id: RigidEnv/Detumble-v0\n"
        "algo: ppo\n"
        "total_timesteps: 1e5\n"
        "checkpoint_freq: 2.5E+3\n"
        "hyperparams: {learning_rate: 1e-4, n_steps: 64}\n"
        "normalize: {clip_obs: 1e1}\n"
    )
    cfg = load_config(path)
    assert cfg.hyperparams.learning_rate == 1e-4
    assert cfg.total_timesteps == 100_000 and cfg.checkpoint_freq == 2500
    assert cfg.normalize.clip_obs == 10.0


def test_every_shipped_config_loads():
    for path in sorted((ROOT / "configs" / "agents").glob("*.yaml")):
        cfg = load_config(path)
        assert cfg.run_name.endswith("__0"), path


@pytest.mark.slow
def test_a_learning_rate_of_1e_minus_4_trains(tmp_path):
    """The value the user meant reaches the model."""
    path = tmp_path / "cfg.yaml"
    text = yaml.safe_dump({**TINY, "total_timesteps": 128}).replace(
        "n_epochs: 1", "n_epochs: 1\n  learning_rate: 1e-4"
    )
    path.write_text(text)
    assert train_main([str(path), "--runs-dir", str(tmp_path), "--no-progress"]) == 0
    from stable_baselines3 import PPO

    model = PPO.load(tmp_path / "Detumble__ppo__0" / "model.zip")
    assert model.learning_rate == 1e-4


@pytest.mark.slow
def test_config_error_in_a_fresh_process_is_one_line(tmp_path):
    """The issue's SceneError traceback, end to end: exit 2, one stderr line."""
    path = tmp_path / "cfg.yaml"
    path.write_text(yaml.safe_dump({**TINY, "env_kwargs": {"integrator": "rk5"}}))
    proc = run_module("agents.train", str(path), "--runs-dir", str(tmp_path / "runs"))
    assert proc.returncode == 2
    assert_one_line_error(proc.stderr, ERR, str(path), "env_kwargs.integrator", "rk5")


def test_python_api_raises_config_error(tmp_path: Path):
    with pytest.raises(ConfigError) as exc:
        load_config({**TINY, "hyperparams": {**HYPER, "gamma": 0}})
    assert str(exc.value).startswith("<config>: hyperparams.gamma: ")


def test_flag_syntax_errors_are_one_line(tmp_path, capsys):
    config = ROOT / "configs" / "agents" / "ppo_detumble.yaml"
    with pytest.raises(SystemExit) as exc:
        train_main([str(config), "--total-timesteps", "lots", "--runs-dir", str(tmp_path)])
    assert exc.value.code == 2
    assert_one_line_error(capsys.readouterr().err, ERR, "--total-timesteps", "'lots'")
    assert not any(tmp_path.iterdir())
