"""PPO beside PD on RigidEnv/DetumbleFaults-v0, by fault (README, Baselines):

    .venv/bin/python docs/faults_table.py [MODEL.zip]

The pretrained policy (default ``agents/pretrained/ppo_detumble_faults.zip``) and the PD
controller play the same 100 held-out episodes, episode ``k`` reset with seed 12345 + k (the
baselines table's), so each faces the same initial spin, thruster tilts, fault and noise. A row
per policy and group of episodes by the fault drawn at reset (the same groups for both
policies): every episode, none drawn, a thruster stuck off, stuck on or degraded from a step in
the first second; *acted* counts the episodes that had not ended in success before it started.
"""

import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
from rigid_env.agents.controllers import CONTROLLERS
from rigid_env.agents.evaluate import load_policy, run_episodes

from rigid_env.envs.hardware import FAULT_KINDS

ENV_ID = "RigidEnv/DetumbleFaults-v0"
EPISODES, SEED = 100, 12345
MODEL = Path(__file__).resolve().parents[1] / "agents/pretrained/ppo_detumble_faults.zip"


def rows(name: str, ep: dict[str, np.ndarray]) -> list[str]:
    """Markdown rows of one policy: success and mean fuel [N s] per group of episodes."""
    kind = ep["fault_kind"]
    groups = {"all": np.ones_like(kind, dtype=bool), "no fault": kind < 0}
    groups |= {k: kind == i for i, k in enumerate(FAULT_KINDS)}
    out = []
    for label, m in groups.items():
        n, acted, ok = int(m.sum()), int(ep["fault_active"][m].sum()), int(ep["success"][m].sum())
        fuel = float(ep["fuel"][m].mean()) if n else float("nan")
        out.append(f"| {name} | {label} | {n} | {acted} | {ok}/{n} | {fuel:.3f} |")
    return out


if __name__ == "__main__":
    model = Path(sys.argv[1]) if len(sys.argv) > 1 else MODEL
    probe = gym.make_vec(ENV_ID, num_envs=1, vectorization_mode="vector_entry_point")
    policies = {"PPO": load_policy(model, ENV_ID), "PD": CONTROLLERS["pd"](probe)}
    print("| policy | fault drawn | episodes | acted | success | mean fuel [N s] |")
    print("|---|---|---:|---:|---:|---:|")
    for name, policy in policies.items():
        print("\n".join(rows(name, run_episodes(ENV_ID, policy, EPISODES, SEED))), flush=True)
