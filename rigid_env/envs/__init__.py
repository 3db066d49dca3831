"""Gymnasium environments, registered under the ``RigidEnv`` namespace on import."""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

#: (task, max_episode_steps) of every registered environment.
TASKS: dict[str, tuple[str, int]] = {
    "Detumble": ("detumble", 400),
    "SpinStabilize": ("spin_stabilize", 200),
    "Reorient": ("reorient", 300),
    "TumblingFall": ("tumbling_fall", 200),
}

ENV_IDS = [f"RigidEnv/{name}-v0" for name in TASKS]


def _register_all() -> None:
    for name, (module, steps) in TASKS.items():
        env_id = f"RigidEnv/{name}-v0"
        if env_id in registry:
            continue
        register(
            id=env_id,
            entry_point=f"rigid_env.envs.{module}:{name}Env",
            vector_entry_point=f"rigid_env.envs.{module}:{name}VectorEnv",
            max_episode_steps=steps,
        )


_register_all()
