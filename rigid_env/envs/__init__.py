"""Gymnasium environments, registered under the ``RigidEnv`` namespace on import.

:data:`TASKS` is the one registry of the tasks: Gymnasium's registration, the demo and the
shipped policies (:mod:`rigid_env.agents.shipped`), the learning benchmark, the tests and the
packaging checks all read it. A task ships as its module in ``rigid_env/envs/`` (a
:class:`~rigid_env.envs.batch.TaskBatch` subclass ``<Name>Task`` and its ``<Name>Env`` and
``<Name>VectorEnv``), its scene in ``configs/scenes/`` and one :class:`Task` row here; adding the
row recompiles no other task's kernels (:mod:`rigid_env.numba_cache`).
"""

from __future__ import annotations

import copy
import importlib
from dataclasses import dataclass, field
from typing import Any

from gymnasium.envs.registration import register, registry

NAMESPACE = "RigidEnv"


@dataclass(frozen=True)
class Task:
    """A registered task: where its classes and scene are and how long its episodes last.

    Every version from 0 to :attr:`newest` stays registered; version ``k >= 1`` is the same class
    made with ``version=k`` (see each env's Version History).
    """

    name: str
    """The id's task name (``RigidEnv/<name>-v<k>``) and its classes' prefix: ``<name>Env``,
    ``<name>VectorEnv`` and ``<name>Task`` in :attr:`module`."""
    module: str
    """The module under ``rigid_env/envs/`` that defines the task (``detumble``); also the stem of
    its shipped files (``configs/agents/<algo>_<module>.yaml``, ``ppo_<module>.zip``)."""
    scene: str
    """The stem of its scene file ``configs/scenes/<scene>.yaml`` (its task class's
    ``scene_name``)."""
    max_episode_steps: int
    """Control steps before an episode is truncated."""
    newest: int = 0
    """Its newest version: the one trained, reported on and played by the demo."""

    @property
    def env_id(self) -> str:
        """The newest version's id, ``RigidEnv/<name>-v<newest>``."""
        return self.version_id(self.newest)

    def version_id(self, version: int) -> str:
        """The id of one version, ``RigidEnv/<name>-v<version>``."""
        return f"{NAMESPACE}/{self.name}-v{version}"

    @property
    def env_ids(self) -> list[str]:
        """Every registered version's id, oldest first."""
        return [self.version_id(k) for k in range(self.newest + 1)]

    @property
    def entry_point(self) -> str:
        """Gymnasium's entry point of the single env (a string: nothing imported to register)."""
        return f"rigid_env.envs.{self.module}:{self.name}Env"

    @property
    def vector_entry_point(self) -> str:
        """Gymnasium's entry point of the native vector env."""
        return f"rigid_env.envs.{self.module}:{self.name}VectorEnv"

    def task_class(self) -> type:
        """Its :class:`~rigid_env.envs.batch.TaskBatch` subclass, ``<name>Task`` of its module
        (imported here: registering imports no task module)."""
        return getattr(importlib.import_module(f"rigid_env.envs.{self.module}"), f"{self.name}Task")


@dataclass(frozen=True)
class Variant:
    """A registered variant of a task: the task's classes made with other defaults."""

    name: str
    """The id's name, ``RigidEnv/<name>`` (with its version: ``DetumbleFaults-v0``)."""
    task: str
    """The name of the task (:class:`Task`) it varies."""
    max_episode_steps: int
    kwargs: dict[str, Any] = field(default_factory=dict)
    """Its defaults, merged under what ``gym.make`` is given (:func:`variant_kwargs`)."""

    @property
    def env_id(self) -> str:
        return f"{NAMESPACE}/{self.name}"


def _by_name(rows: tuple[Any, ...]) -> dict[str, Any]:
    names = [row.name for row in rows]
    if len(set(names)) != len(names):
        raise ValueError(f"TASKS: a name is listed twice in {names}")
    return {row.name: row for row in rows}


TASKS: dict[str, Task] = _by_name(
    (
        Task("Detumble", module="detumble", scene="detumble", max_episode_steps=400),
        Task(
            "SpinStabilize",
            module="spin_stabilize",
            scene="spin_stabilize",
            max_episode_steps=200,
            newest=1,
        ),
        Task("Reorient", module="reorient", scene="reorient", max_episode_steps=300, newest=1),
        Task(
            "TumblingFall",
            module="tumbling_fall",
            scene="tumbling_fall",
            max_episode_steps=200,
            newest=1,
        ),
        Task(
            "BdotDetumble",
            module="bdot_detumble",
            scene="bdot_detumble",
            max_episode_steps=480,
            newest=2,
        ),
        Task(
            "WheelPointing",
            module="wheel_pointing",
            scene="wheel_pointing",
            max_episode_steps=120,
            newest=2,
        ),
        Task(
            "SunAcquisition",
            module="sun_acquisition",
            scene="sun_acquisition",
            max_episode_steps=2840,
        ),
    )
)
"""Every registered task by name."""

#: The newest version of each task: the ids the baselines are trained and reported on.
ENV_IDS = [task.env_id for task in TASKS.values()]


#: Registered variants of a task with other defaults, by name.
VARIANTS: dict[str, Variant] = _by_name(
    (
        # Detumble on realistic cold-gas thrusters where half the episodes lose a thruster (stuck
        # off, stuck on or degraded) from a random step in the first 20 (1 s) on; a 2 degree
        # misalignment per episode. The observation does not say which (info does).
        Variant(
            "DetumbleFaults-v0",
            task="Detumble",
            max_episode_steps=400,
            kwargs={
                "thrusters": "realistic",
                "randomization": {
                    "thruster_misalignment": 2.0,
                    "thruster_faults": {"probability": 0.5, "within_steps": 20},
                },
            },
        ),
    )
)

#: Every registered id, older versions and variants included.
ALL_ENV_IDS = [env_id for task in TASKS.values() for env_id in task.env_ids] + [
    variant.env_id for variant in VARIANTS.values()
]


def variant_kwargs(kwargs: dict) -> dict:
    """The keyword arguments a task env is made with: for a registered variant (``variant``
    names it; the registration passes it) the variant's defaults with ``kwargs`` merged over
    them, mappings key by key, so that ``gym.make("RigidEnv/DetumbleFaults-v0",
    randomization={"inertia": 0.3})`` keeps the variant's misalignment and faults (Gymnasium
    would hand over the given mapping in place of the registered one); None switches a mapping
    off. ``variant`` stays in the result: the task names itself by it in its errors. Without
    ``variant``, ``kwargs`` as given.

    Raises:
        ValueError: ``variant`` given as None (Gymnasium would then hand over a given
            ``randomization`` in place of the variant's, dropping its faults without a word) or
            not a registered variant.
    """
    kwargs = dict(kwargs)
    if "variant" not in kwargs:
        return kwargs
    name = kwargs["variant"]
    if name is None:
        raise ValueError(
            "variant: None would drop the registered variant's own defaults (DetumbleFaults-v0's "
            "faults and misalignment) for what is given; leave variant out (gym.make sets it "
            "from the id), and make RigidEnv/Detumble-v0 for the task without them"
        )
    if name not in VARIANTS:
        raise ValueError(f"variant: {name!r} is not one of {sorted(VARIANTS)}")
    return {**merge_kwargs(VARIANTS[name].kwargs, kwargs), "variant": name}


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
    for task in TASKS.values():
        for version, env_id in enumerate(task.env_ids):
            if env_id not in registry:
                register(
                    id=env_id,
                    entry_point=task.entry_point,
                    vector_entry_point=task.vector_entry_point,
                    max_episode_steps=task.max_episode_steps,
                    kwargs={"version": version} if version else {},
                )
    for variant in VARIANTS.values():
        task = TASKS[variant.task]
        if variant.env_id not in registry:
            register(
                id=variant.env_id,
                entry_point=task.entry_point,
                vector_entry_point=task.vector_entry_point,
                max_episode_steps=variant.max_episode_steps,
                kwargs={"variant": variant.name, **variant.kwargs},
            )


_register_all()
