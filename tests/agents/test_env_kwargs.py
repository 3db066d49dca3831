"""A keyword given to a registered variant adds to the mapping it registers, in gym.make and in
the agents' configs and evaluations."""

from __future__ import annotations

import json

import gymnasium as gym
import pytest
import yaml

from agents.config import load_config
from agents.controllers import CONTROLLERS
from agents.evaluate import main as evaluate_main
from agents.evaluate import run_episodes

FAULTS = "RigidEnv/DetumbleFaults-v0"


@pytest.mark.parametrize("vector", [False, True])
def test_a_variants_registered_mapping_is_merged_not_replaced(vector: bool):
    """DetumbleFaults-v0 registers ``randomization`` (misalignment, faults): ``gym.make`` and
    ``gym.make_vec`` with a ``randomization`` of one's own add its keys to the variant's (where
    Gymnasium alone would replace the mapping and drop the faults); None switches it off; the
    spec is untouched; a task's own id takes its kwargs as given."""
    before = json.dumps(gym.spec(FAULTS).kwargs, sort_keys=True)

    def randomization(env_id: str, **kwargs):
        if vector:
            env = gym.make_vec(env_id, 2, vectorization_mode="vector_entry_point", **kwargs)
        else:
            env = gym.make(env_id, **kwargs)
        r = env.unwrapped.task.randomization if not vector else env.task.randomization
        env.close()
        return r

    mixed = randomization(FAULTS, randomization={"inertia": 0.3})
    assert mixed.inertia == 0.3
    assert mixed.thruster_misalignment == 2.0
    assert mixed.thruster_faults is not None and mixed.thruster_faults.probability == 0.5
    off = randomization(FAULTS, randomization=None)
    assert off.thruster_faults is None and off.thruster_misalignment == 0.0
    assert json.dumps(gym.spec(FAULTS).kwargs, sort_keys=True) == before
    plain = randomization("RigidEnv/Detumble-v0", randomization={"inertia": 0.3})
    assert plain.inertia == 0.3 and plain.thruster_faults is None
    with pytest.raises(ValueError, match="variant: 'nope' is not one of"):
        gym.make("RigidEnv/Detumble-v0", variant="nope")


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
    resolved = load_config(cfg).env_kwargs["randomization"]
    assert resolved == {"inertia": 0.3}  # the env adds the variant's own (above)

    args = ["none", "--env", FAULTS, "--episodes", "2", "--only", "pd", "--json"]
    assert evaluate_main([*args, "--env-kwargs", "randomization.inertia=0.3"]) == 0
    used = json.loads(capsys.readouterr().out)["env_kwargs"]
    assert used["randomization"]["inertia"] == 0.3
    probe = gym.make_vec(FAULTS, num_envs=1, vectorization_mode="vector_entry_point", **used)
    pd = CONTROLLERS["pd"](probe)
    ep = run_episodes(FAULTS, pd, 64, 0, used)
    assert (ep["fault_kind"] >= 0).any() and (ep["fault_kind"] < 0).any()
