"""The tasks that ship a training configuration per algorithm (``configs/agents/<algo>_<module>
.yaml``) and a pretrained policy (``agents/pretrained/ppo_<module>.zip``): what the demo, the
baselines and their tests loop over. A registered task not listed here (a new one, before
anyone trains it) is an environment like any other, and the suite stays green without it.

Registered variants of a task (:data:`rigid_env.envs.VARIANTS`) and newer versions of a task whose
policy plays an older one may ship a PPO configuration and policy too (:data:`VARIANTS`); the demo
plays the tasks only, the policy tests every policy."""

from __future__ import annotations

from rigid_env.envs import TASKS as REGISTERED
from rigid_env.envs import Task

SHIPPED = ("Detumble", "SpinStabilize", "Reorient", "TumblingFall", "BdotDetumble", "WheelPointing")
"""Names of the registered tasks (:data:`rigid_env.envs.TASKS`) with configs and a pretrained
policy."""

TASKS: dict[str, Task] = {name: REGISTERED[name] for name in SHIPPED}
"""The registry's record of each shipped task, by name."""

TRAINED_ON: dict[str, int] = {"BdotDetumble": 1, "WheelPointing": 0}
"""The version a shipped policy was trained on, where a newer one came after it (BdotDetumble-v2
and WheelPointing-v1: the orbit as world state, not trained yet; WheelPointing-v2: the full
environment and the 0.1 deg bar, which no policy meets yet); the others' newest."""


def shipped_id(name: str) -> str:
    """The id a shipped task's policy was trained on and plays (:data:`TRAINED_ON`)."""
    task = TASKS[name]
    return task.version_id(TRAINED_ON.get(name, task.newest))


ENV_IDS = [shipped_id(name) for name in TASKS]
"""The id each shipped task's policy was trained on (its newest but for :data:`TRAINED_ON`)."""

VARIANTS: dict[str, str] = {
    "RigidEnv/DetumbleFaults-v0": "detumble_faults",
    "RigidEnv/WheelPointing-v2": "wheel_pointing_full",
}
"""Id -> the stem of its files: ``configs/agents/ppo_<stem>.yaml`` and
``agents/pretrained/ppo_<stem>.zip`` (PPO only), for a policy that ships beside its task's: a
registered variant's, or a newer version's where the task's policy plays an older one
(WheelPointing-v2, the full environment at the 0.1 deg bar, beside the 1 deg policy of v0)."""

POLICIES: dict[str, str] = {
    **{shipped_id(name): task.module for name, task in TASKS.items()},
    **VARIANTS,
}
"""Env id -> stem of its pretrained policy ``agents/pretrained/ppo_<stem>.zip``: every policy
that ships, the tasks' and the variants'."""
