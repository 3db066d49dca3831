"""PD on thrusters as hardware (README, Environments): success and fuel of the PD controller
with and without its pulse modulator, on ideal and realistic thrusters and on DetumbleFaults-v0.

    .venv/bin/python docs/thruster_pd.py

Each row: one vector env, episodes seeded from 1000 on, every env run to the end of its first
episode (at most 400 steps).
"""

import gymnasium as gym
import numpy as np
from rigid_env.agents.controllers import PDController

import rigid_env.envs  # noqa: F401  (registers the ids)


def run(env_id: str, n: int, modulate: bool, **kwargs: object) -> tuple[float, float, float]:
    """(success rate, mean fuel [N s], fraction of episodes that end with a fault acting)."""
    env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)
    pd = PDController(env)
    pd.modulate.active = modulate
    obs, _ = env.reset(seed=1000)
    done, success = np.zeros(n, bool), np.zeros(n, bool)
    fuel, faulted = np.zeros(n), np.zeros(n, bool)
    for _ in range(400):
        obs, _, term, trunc, info = env.step(pd(obs))
        new = (term | trunc) & ~done
        success[new], fuel[new] = info["success"][new], info["fuel"][new]
        if "fault_active" in info:
            faulted[new] = info["fault_active"][new]
        done |= term | trunc
        if done.all():
            break
    return success.mean(), fuel.mean(), faulted.mean()


if __name__ == "__main__":
    cases = [
        ("RigidEnv/Detumble-v0", 32, True, {}),
        ("RigidEnv/Detumble-v0", 32, True, {"thrusters": "realistic"}),
        ("RigidEnv/Detumble-v0", 32, False, {"thrusters": "realistic"}),
        ("RigidEnv/DetumbleFaults-v0", 64, True, {}),
        ("RigidEnv/DetumbleFaults-v0", 64, False, {}),
    ]
    for env_id, n, modulate, kwargs in cases:
        s, f, k = run(env_id, n, modulate, **kwargs)
        label = f"{env_id} {kwargs or ''} {'modulator' if modulate else 'no modulator'}"
        print(f"{label}: success {s:.3f}, fuel {f:.3f} N s, faulted {k:.2f}", flush=True)
