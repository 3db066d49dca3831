"""agents.env_kwargs: a keyword given to a registered variant adds to the mapping it registers."""

from __future__ import annotations

import json

import gymnasium as gym
import yaml

from agents.config import load_config
from agents.controllers import CONTROLLERS
from agents.env_kwargs import over_registered
from agents.evaluate import main as evaluate_main
from agents.evaluate import run_episodes

FAULTS = "RigidEnv/DetumbleFaults-v0"


def test_a_variants_registered_mapping_is_merged_not_replaced():
    """DetumbleFaults-v0 registers ``randomization`` (misalignment, faults): a given
    ``randomization`` adds its keys to it; other values are as given; None switches it off; a
    task's own id (which registers no mapping) gets its kwargs back unchanged."""
    registered = gym.spec(FAULTS).kwargs["randomization"]
    before = json.dumps(gym.spec(FAULTS).kwargs, sort_keys=True)
    out = over_registered(FAULTS, {"randomization": {"inertia": 0.3}, "dt": 0.1})
    assert out == {"randomization": {**registered, "inertia": 0.3}, "dt": 0.1}
    assert json.dumps(gym.spec(FAULTS).kwargs, sort_keys=True) == before  # the spec untouched
    assert over_registered(FAULTS, {"randomization": None}) == {"randomization": None}
    plain = {"randomization": {"inertia": 0.3}}
    assert over_registered("RigidEnv/Detumble-v0", plain) == plain


def test_a_variants_faults_survive_a_training_config_and_an_evaluation(tmp_path, capsys):
    """A config for DetumbleFaults-v0 with its own randomisation trains with the faults too
    (its resolved env_kwargs hold them), and so does ``agents.evaluate --env-kwargs``: the env
    built from what it reports draws faults (64 episodes at probability 0.5 all draw none with
    probability 2^-64)."""
    cfg = tmp_path / "faults.yaml"
    cfg.write_text(
        yaml.safe_dump(
            {
                "env_id": FAULTS,
                "algo": "ppo",
                "total_timesteps": 1000,
                "env_kwargs": {"randomization": {"inertia": 0.3}},
            }
        )
    )
    registered = gym.spec(FAULTS).kwargs["randomization"]
    resolved = load_config(cfg).env_kwargs["randomization"]
    assert resolved == {**registered, "inertia": 0.3}

    args = ["none", "--env", FAULTS, "--episodes", "2", "--only", "pd", "--json"]
    assert evaluate_main([*args, "--env-kwargs", "randomization.inertia=0.3"]) == 0
    used = json.loads(capsys.readouterr().out)["env_kwargs"]
    assert used["randomization"]["inertia"] == 0.3
    probe = gym.make_vec(FAULTS, num_envs=1, vectorization_mode="vector_entry_point", **used)
    pd = CONTROLLERS["pd"](probe)
    ep = run_episodes(FAULTS, pd, 64, 0, used)
    assert (ep["fault_kind"] >= 0).any() and (ep["fault_kind"] < 0).any()
