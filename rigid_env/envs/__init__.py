"""Gymnasium environments, registered under the ``RigidEnv`` namespace on import."""

from __future__ import annotations

import copy

from gymnasium.envs.registration import register, registry

#: (task module, max_episode_steps, newest version) of every registered task. Every version
#: from v0 to the newest stays registered; version k >= 1 is the same class made with
#: ``version=k`` (see each env's Version History).
TASKS: dict[str, tuple[str, int, int]] = {
    "Detumble": ("detumble", 400, 0),
    "SpinStabilize": ("spin_stabilize", 200, 1),
    "Reorient": ("reorient", 300, 1),
    "TumblingFall": ("tumbling_fall", 200, 1),
}

#: The newest version of each task: the ids the baselines are trained and reported on.
ENV_IDS = [f"RigidEnv/{name}-v{newest}" for name, (_, _, newest) in TASKS.items()]
#: Every registered id, older versions included.
ALL_ENV_IDS = [
    f"RigidEnv/{name}-v{k}" for name, (_, _, newest) in TASKS.items() for k in range(newest + 1)
]


#: Registered variants of a task with other defaults: id -> (task, max_episode_steps, kwargs).
VARIANTS: dict[str, tuple[str, int, dict]] = {
    # Detumble on realistic cold-gas thrusters where half the episodes lose a thruster (stuck
    # off, stuck on or degraded) from a random step in the first 20 (1 s) on; a 2 degree
    # misalignment per episode. The observation does not say which (info does).
    "DetumbleFaults-v0": (
        "Detumble",
        400,
        {
            "thrusters": "realistic",
            "randomization": {
                "thruster_misalignment": 2.0,
                "thruster_faults": {"probability": 0.5, "within_steps": 20},
            },
        },
    ),
}
ALL_ENV_IDS += [f"RigidEnv/{variant}" for variant in VARIANTS]


def variant_kwargs(kwargs: dict) -> dict:
    """The keyword arguments a task env is made with: for a registered variant (``variant``
    names it; the registration passes it) the variant's defaults with ``kwargs`` merged over
    them, mappings key by key, so that ``gym.make("RigidEnv/DetumbleFaults-v0",
    randomization={"inertia": 0.3})`` keeps the variant's misalignment and faults (Gymnasium
    would hand over the given mapping in place of the registered one); None switches a mapping
    off. Without ``variant``, ``kwargs`` as given."""
    kwargs = dict(kwargs)
    name = kwargs.pop("variant", None)
    if name is None:
        return kwargs
    if name not in VARIANTS:
        raise ValueError(f"variant: {name!r} is not one of {sorted(VARIANTS)}")
    return merge_kwargs(VARIANTS[name][2], kwargs)


def merge_kwargs(base: dict, over: dict) -> dict:
    """``over`` merged into a copy of ``base``, mappings key by key (so ``{"randomization":
    {"inertia": 0.2}}`` keeps ``base``'s ``randomization.mass``); any other value, None
    included, replaces ``base``'s. Neither argument is changed."""
    out = copy.deepcopy(base)
    for key, value in over.items():
        both = isinstance(value, dict) and isinstance(out.get(key), dict)
        out[key] = merge_kwargs(out[key], value) if both else copy.deepcopy(value)
    return out


def _register_all() -> None:
    for name, (module, steps, newest) in TASKS.items():
        for version in range(newest + 1):
            env_id = f"RigidEnv/{name}-v{version}"
            if env_id in registry:
                continue
            register(
                id=env_id,
                entry_point=f"rigid_env.envs.{module}:{name}Env",
                vector_entry_point=f"rigid_env.envs.{module}:{name}VectorEnv",
                max_episode_steps=steps,
                kwargs={"version": version} if version else {},
            )
    for variant, (name, steps, kwargs) in VARIANTS.items():
        env_id = f"RigidEnv/{variant}"
        if env_id not in registry:
            module = TASKS[name][0]
            register(
                id=env_id,
                entry_point=f"rigid_env.envs.{module}:{name}Env",
                vector_entry_point=f"rigid_env.envs.{module}:{name}VectorEnv",
                max_episode_steps=steps,
                kwargs={"variant": variant, **kwargs},
            )


_register_all()
