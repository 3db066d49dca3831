"""A task is its physics: a parameters model and one compiled ``evaluate`` reading named state
and named numbers. What a task module may not contain, and the checks a task class gets when it
is made (a name clash with the common numbers, an extra observation it names but never gives)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np
import pytest

import rigid_env
from rigid_env.envs.detumble import DetumbleParams, DetumbleTask
from rigid_env.envs.environments import RigidBodyEnv
from rigid_env.envs.kernels import COMMON_NUMBERS, Outcome, env_pass, kernel, task_kernel
from rigid_env.envs.params import Rate, TaskParams

ENVS = Path(rigid_env.__file__).parent / "envs"
TASK_MODULES = [f"{task.module}.py" for task in rigid_env.envs.TASKS.values()]


@pytest.mark.parametrize("name", TASK_MODULES)
def test_task_module_reads_names_not_slots(name: str) -> None:
    """No function of a task module takes more than 8 parameters, and none reads the state or
    the parameters by position (``s[10]``, ``tp[...]``)."""
    source = (ENVS / name).read_text()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.FunctionDef):
            assert len(node.args.args) + len(node.args.kwonlyargs) <= 8, node.name
    assert not re.search(r"\b(s|tp|state|rec)\[", source)


def test_numbers_are_the_common_ones_then_the_parameters_by_name() -> None:
    task = DetumbleTask(1, fuel_weight=0.25)
    names = task.numbers.dtype.names
    assert names == (*COMMON_NUMBERS, *DetumbleParams.model_fields)
    assert task.numbers[0]["fuel_weight"] == 0.25 and task.numbers[0]["dt"] == task.dt


def test_a_parameter_named_like_a_common_number_is_refused_at_class_creation() -> None:
    with pytest.raises(TypeError, match=r"^ClashParams\.dt: the name is taken"):

        class ClashParams(TaskParams):
            dt: Rate = 1.0


@kernel
def _one_extra(body, effort, goal, memory, task, stepped):
    return Outcome(-effort, terminated=False, success=False, memory=memory, extra=(body.w[2],))


@task_kernel
def _one_extra_pass(job, threads): return env_pass(_one_extra, job, threads)  # fmt: skip


class TwoNamedTask(DetumbleTask):
    task_pass = _one_extra_pass
    extra_observations = ("spin_z", "spin_x")


class OneNamedTask(TwoNamedTask):
    extra_observations = ("spin_z",)


def test_an_extra_observation_named_but_not_given_is_refused_when_made() -> None:
    with pytest.raises(ValueError, match=r"^TwoNamedTask: evaluate returns 1 extra observation"):
        RigidBodyEnv(task=TwoNamedTask)
    env = RigidBodyEnv(task=OneNamedTask)
    obs, _ = env.reset(seed=0)
    w_z = env.unwrapped.task.world.state.w[0, 2]
    assert obs[env.unwrapped.task.obs_slices["spin_z"]][0] == np.float32(max(-1.0, min(1.0, w_z)))


@pytest.mark.parametrize(
    ("field", "size", "width"),
    [("target_dim", 11, "TARGET_WIDTH"), ("memory_dim", 2, "MEMORY_WIDTH")],
)
def test_a_task_declaring_more_target_or_memory_than_the_pass_holds_is_refused(
    field: str, size: int, width: str
) -> None:
    """A task declares the size of its target and of its memory; more than the pass holds
    (:data:`~rigid_env.envs.kernels.TARGET_WIDTH` numbers of target, ``MEMORY_WIDTH`` of memory)
    is refused when the class is made, naming the field and the limit."""
    limit = getattr(rigid_env.envs.kernels, width)
    with pytest.raises(TypeError, match=rf"^WideTask\.{field}: {size} numbers, .* 0 to {limit} "):
        type("WideTask", (DetumbleTask,), {field: size})
    assert type("FitsTask", (DetumbleTask,), {field: limit})  # at the limit: fine


class TargetlessTask(DetumbleTask):
    """Draws a target of 4 numbers but declares none."""

    def sample(self, rng: np.random.Generator):
        x, v, q, w, _ = super().sample(rng)
        return x, v, q, w, np.ones(4)


def test_a_target_of_another_size_than_declared_is_refused_at_reset() -> None:
    env = RigidBodyEnv(task=TargetlessTask)
    with pytest.raises(ValueError, match=r"^TargetlessTask\.sample: drew a target of shape \(4,\), "
                       r"the task declares target_dim = 0"):  # fmt: skip
        env.reset(seed=0)


def test_every_task_declares_the_target_and_memory_it_uses() -> None:
    """Every registered task's record names its scene as its class does; of the built-in tasks
    Reorient's goal is a quaternion and SpinStabilize's memory its success streak."""
    declared = {}
    for name, task in rigid_env.envs.TASKS.items():
        cls = task.task_class()
        assert cls.scene_name == task.scene and cls.__name__ == f"{name}Task"
        declared[name] = (cls.target_dim, cls.memory_dim)
    built_in = {
        "Detumble": (0, 0),
        "SpinStabilize": (0, 1),
        "Reorient": (4, 0),
        "TumblingFall": (0, 0),
    }
    assert {name: declared[name] for name in built_in} == built_in


def test_a_scene_without_actuators_is_refused_naming_every_registered_one(tmp_path) -> None:
    """The refusal lists the sections a scene may add, from the registry (a declaration added
    later is named without an edit here)."""
    import gymnasium as gym
    import yaml

    from rigid_env.core.actuator import actuators
    from rigid_env.resources import scene_path

    scene = yaml.safe_load(scene_path("detumble").read_text())
    scene["actuators"] = {}
    path = tmp_path / "bare.yaml"
    path.write_text(yaml.safe_dump(scene))
    with pytest.raises(ValueError, match=r"^scene: a task needs actuators \(") as caught:
        gym.make("RigidEnv/Detumble-v0", scene=str(path))
    message = str(caught.value)
    assert "\n" not in message and message.endswith("the scene has none")
    assert all(a.name in message for a in actuators())
