"""The envs' keyword arguments as frozen pydantic models: a task's parameters
(:class:`TaskParams`, one subclass per task, beside its ``evaluate``) and the settings every
task takes (:class:`EnvSettings`). Each field carries its unit and range; the numbers a scene
file would refuse (not finite, or a non-zero magnitude outside [1e-100, 1e100]) are refused
here by the same rule (:class:`rigid_env.scene_sections.Quantity`). A bad keyword is one line,
``field: problem; fix``; an unknown one names the keywords the task takes, the closest first.

The numbers the compiled pass reads (:func:`numbers`) are derived from the parameters model:
one field per parameter, by name, after :data:`rigid_env.envs.kernels.COMMON_NUMBERS`.
"""

from __future__ import annotations

import difflib
import os
from collections.abc import Sequence
from typing import Annotated, Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, BeforeValidator, ConfigDict, ValidationError

from rigid_env import knobs
from rigid_env.config_files import ConfigFileError, error_line
from rigid_env.core.actuator import declaration, listed
from rigid_env.core.effects import (
    AerodynamicDrag,
    Gravity,
    GravityGradient,
    MagneticDipole,
    SolarRadiationPressure,
)
from rigid_env.envs.hardware import ThrusterFaults
from rigid_env.envs.kernels import COMMON_NUMBERS
from rigid_env.envs.quantities import quantity
from rigid_env.envs.sensing import Sensors

Rate = quantity("rad/s", gt=0)
"""An angular speed [rad/s], > 0."""
Angle = quantity("rad", gt=0, le=np.pi)
"""An angle [rad] in (0, pi]."""
Seconds = quantity("s", ge=0)
"""A duration [s], >= 0."""
Weight = quantity("reward per mean |u|", ge=0)
"""The weight of the effort (mean ``|u|`` of a step) in the reward, >= 0."""
Bonus = quantity("reward", ge=0)
"""A reward, >= 0."""
Fraction = quantity("relative half-width", ge=0, lt=1)
"""A relative half-width in [0, 1)."""
NoiseRate = quantity("rad/s", ge=0)
"""A standard deviation of an angular speed [rad/s], >= 0."""
TiltDegrees = quantity("deg", ge=0, le=90)
"""A tilt angle [deg] in [0, 90]."""


def _repeats(value: Any) -> Any:
    """``randomization.action_repeat`` checked: None, or distinct integers >= 1."""
    if value is None:
        return None
    fix = "give distinct integers >= 1, e.g. [1, 2, 4] (a range as its list: [1, 2, 3, 4])"
    if not isinstance(value, list | tuple) or not value:
        raise ValueError(
            f"must be a non-empty list of world steps per action, got {value!r}; {fix}"
        )
    for k in value:
        integral = isinstance(k, int | np.integer) and not isinstance(k, bool | np.bool_)
        if not integral or k < 1:
            raise ValueError(f"must hold integers >= 1, got {k!r}; {fix}")
        if k > knobs.MAX_ACTION_REPEAT:
            raise ValueError(
                f"holds {k!r} world steps per action, above {knobs.MAX_ACTION_REPEAT} (one "
                "env.step would take minutes or never return); give a longer dt for a longer "
                "control period"
            )
    if len(set(value)) != len(value):
        raise ValueError(f"lists a repeat twice, got {list(value)!r}; {fix}")
    return tuple(int(k) for k in value)


ActionRepeats = Annotated[tuple[int, ...] | None, BeforeValidator(_repeats)]
"""World steps per action: None, or a tuple of distinct integers >= 1."""


def task_version(newest: int) -> Any:
    """The task's version (the ``-vK`` of its id), an integer from 0 to ``newest``."""

    def check(value: Any) -> int:
        integral = isinstance(value, int | np.integer) and not isinstance(value, bool)
        if not integral or not 0 <= value <= newest:
            raise ValueError(
                f"must be an integer from 0 to {newest} (the task's versions), got {value!r}; "
                "gym.make sets it from the id (RigidEnv/<Task>-vK)"
            )
        return int(value)

    return Annotated[int, BeforeValidator(check)]


class TaskParams(BaseModel):
    """A task's own keyword arguments (a subclass per task): frozen, unknown keys refused, a
    docstring per field with its unit and range."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    @classmethod
    def __pydantic_init_subclass__(cls, **kwargs: Any) -> None:
        super().__pydantic_init_subclass__(**kwargs)
        clash = sorted(set(cls.model_fields) & set(COMMON_NUMBERS))
        if clash:
            raise TypeError(
                f"{cls.__name__}.{clash[0]}: the name is taken by a number every task has "
                f"({', '.join(COMMON_NUMBERS)}); rename the field"
            )


class Randomization(BaseModel):
    """Domain randomisation, drawn per episode from the environment's own generator."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    mass: Fraction = 0.0
    """Relative half-width ``a`` in [0, 1): the mass times ``U(1 - a, 1 + a)``."""
    inertia: Fraction = 0.0
    """Relative half-width in [0, 1) for each principal moment (the largest then clipped onto
    the triangle inequality so the body stays physical)."""
    thrust: Fraction = 0.0
    """Relative half-width in [0, 1) for each actuator's strength."""
    sensor_noise: NoiseRate = 0.0
    """Standard deviation of Gaussian noise on the observed angular velocity [rad/s], >= 0
    (drawn every step, every env from its own generator, all the envs in one compiled pass)."""
    thruster_misalignment: TiltDegrees = 0.0
    """Largest tilt of a thruster's direction [deg] in [0, 90]: per episode each thruster is
    tilted by an angle uniform in [0, this] about a uniform axis normal to it."""
    thruster_faults: ThrusterFaults | None = None
    """Per-episode faults: a mapping of probability (in [0, 1]), kinds (stuck_off, stuck_on,
    degraded), within_steps, stuck_level, degraded_fraction (None: no faults)."""
    action_repeat: ActionRepeats = None
    """The control period in world steps: each action is held for ``k`` steps of ``dt`` (the
    physics step unchanged), ``k`` drawn per episode uniformly from this list of distinct
    integers from 1 to 100000 (one entry: that repeat in every episode, nothing drawn; None: 1)."""

    @property
    def hardware(self) -> bool:
        """Whether any thruster draw is needed at reset (misalignment, faults)."""
        return self.thruster_misalignment > 0.0 or self.thruster_faults is not None

    @property
    def drawn_repeat(self) -> bool:
        """Whether a control period is drawn at reset (more than one ``action_repeat``)."""
        return self.action_repeat is not None and len(self.action_repeat) > 1

    @property
    def physical(self) -> bool:
        """Whether any mass-property draw is needed at reset."""
        return self.mass > 0.0 or self.inertia > 0.0


MASS_BLIND = (Gravity, GravityGradient, MagneticDipole, SolarRadiationPressure, AerodynamicDrag)
"""Force effects through which a body's mass acts on nothing: gravity's acceleration is ``g``
whatever the mass, and the others make torques alone (sunlight and air on the facets too: the
centre of mass follows its orbit); so does an actuator whose force map is zero (coils, wheels,
couples: :func:`_torque_alone`)."""


def _torque_alone(effect: object) -> bool:
    """Whether ``effect`` acts through the body's inertia alone: a :data:`MASS_BLIND` effect or
    an actuator that pushes no net force (its force map zero)."""
    if isinstance(effect, MASS_BLIND):
        return True
    return declaration(effect) is not None and not np.any(effect.force_map != 0.0)


def refuse_idle_draws(r: Randomization, scene: str, effects: Sequence[Any]) -> None:
    """Refuse a randomisation key that cannot act on a world of ``effects`` (its force effects,
    the actuators among them), in one line naming the key, why and the fix (as ``thrusters=
    "realistic"`` on a scene without thrusters is): ``thruster_misalignment`` and
    ``thruster_faults`` without thrusters (misalignment tilts force directions: any actuator
    with forces counts), ``mass`` where nothing pushes the centre of mass but gravity. The other
    keys act on every task (``inertia``, ``thrust`` scales every actuator's command,
    ``sensor_noise`` the observed rate every task observes, ``action_repeat``).

    Raises:
        ValueError: ``randomization.<key>: problem; fix``.
    """
    found = listed(effects)
    kinds = ", ".join(dict.fromkeys(a.name for _, a in found)) or "none"
    forces = any(np.any(a.force_map != 0.0) for _, a in found)
    thrusters = any(kind.fails for kind, _ in found)  # a unit that may fail: a thruster
    if r.thruster_misalignment > 0.0 and not forces:
        raise ValueError(
            f"randomization.thruster_misalignment: tilts the thrusters' directions, and scene "
            f"{scene!r} has none (its actuators: {kinds}); leave thruster_misalignment out"
        )
    if r.thruster_faults is not None and not thrusters:
        raise ValueError(
            f"randomization.thruster_faults: fails one thruster per episode, and scene {scene!r} "
            f"has none (its actuators: {kinds}); leave thruster_faults out"
        )
    if r.mass > 0.0 and all(_torque_alone(e) for e in effects):
        raise ValueError(
            f"randomization.mass: nothing in scene {scene!r} acts on the body in a way its mass "
            f"changes (its actuators, {kinds}, make torques alone; gravity, if any, accelerates "
            "every mass alike); leave mass out (randomization.inertia varies what a torque does)"
        )


def _none_is_empty(value: Any) -> Any:
    return {} if value is None else value


class EnvSettings(BaseModel):
    """The keyword arguments every task takes besides its own parameters."""

    model_config = ConfigDict(
        frozen=True, extra="forbid", use_attribute_docstrings=True, arbitrary_types_allowed=True
    )

    scene: str | os.PathLike[str] | dict[str, Any] | None = None
    """A scene file (path) or its dict, instead of the task's own scene."""
    integrator: Any = None
    """An integrator's name overriding the scene's (checked by the world)."""
    dt: Any = None
    """The control step [s] overriding the scene's (checked by the world)."""
    substeps: Any = None
    """Integrator steps per control step overriding the scene's (checked by the world)."""
    rtol: Any = None
    """An error-controlled integrator's (``integrator="dop853"``) relative tolerance, 2.2e-14 <=
    rtol < 1 (float64 cannot meet a tighter one), overriding the scene's (checked by the scene,
    :data:`rigid_env.knobs.Rtol`; refused for a fixed-step integrator)."""
    atol: Any = None
    """Its absolute tolerance, >= 1e-100, likewise (:data:`rigid_env.knobs.Atol`)."""
    rotation_repr: Literal["quaternion", "sixd"] = "quaternion"
    """The observed orientation: "quaternion" (canonical, 4 numbers) or "sixd" (the first two
    columns of the rotation matrix, 6 numbers)."""
    randomization: Annotated[Randomization, BeforeValidator(_none_is_empty)] = Randomization()
    """Domain randomisation: a mapping of mass, inertia, thrust, sensor_noise,
    thruster_misalignment, thruster_faults, action_repeat (None: none)."""
    observe_control_period: knobs.Flag = False
    """Append the control period ``k dt`` [s] (``randomization.action_repeat``; ``dt`` alone
    without it) to the observation, clipped into [0, 10] s."""
    thrusters: Literal["ideal", "realistic"] = "ideal"
    """The thrusters' hardware: "ideal" (as the scene says) or "realistic" (a cold-gas attitude
    thruster: on/off firing, a lag, a minimum impulse bit and thrust noise;
    :mod:`rigid_env.envs.hardware`)."""
    sensors: Annotated[Sensors, BeforeValidator(_none_is_empty)] = Sensors()
    """The observation's sensors: a mapping of each registered sensor's key (gyro,
    magnetometer, star_tracker, ...: :data:`rigid_env.envs.sensing.SENSORS`) and delay (None:
    none, the true state observed)."""


def parse_kwargs(
    params_model: type[TaskParams], task: str, kwargs: dict[str, Any]
) -> tuple[EnvSettings, TaskParams]:
    """The settings and the task's parameters from an env's keyword arguments.

    Raises:
        ValueError: one line, ``field: problem; fix``; an unknown keyword names the ones
            ``task`` takes, the closest first.
    """
    common, own = EnvSettings.model_fields, params_model.model_fields
    for key in kwargs:
        if key not in common and key not in own:
            allowed = [*own, *common]
            close = difflib.get_close_matches(str(key), allowed, n=1)
            hint = f"did you mean {close[0]}? " if close else ""
            raise ValueError(f"{key}: unknown keyword; {hint}{task} takes {', '.join(allowed)}")
    split = {k: v for k, v in kwargs.items() if k in common}
    return (
        _validated(EnvSettings, split),
        _validated(params_model, {k: v for k, v in kwargs.items() if k in own}),
    )


def _validated(model: type[BaseModel], data: dict[str, Any]) -> Any:
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        line: ConfigFileError = error_line(exc, model, "")
        raise ValueError(f"{line.path}: {line.problem}; {line.fix}") from None


def numbers(params: TaskParams, common: dict[str, float], **derived: float) -> NDArray[np.void]:
    """The numbers of a task's compiled pass: a structured array of one element with the
    ``common`` numbers (:data:`~rigid_env.envs.kernels.COMMON_NUMBERS`), each parameter of
    ``params`` by its name (a float, an integer, or a tuple of floats) and the task's
    ``derived`` numbers (e.g. a duration in control steps); a parameter that is a word (a
    mode the task's Python reads) is no number of the pass and is left out."""
    values: dict[str, Any] = {name: common[name] for name in COMMON_NUMBERS}
    values.update({k: v for k, v in params.model_dump().items() if not isinstance(v, str)})
    values.update(derived)
    fields: list[tuple[Any, ...]] = []
    for name, value in values.items():
        if isinstance(value, bool | np.bool_):
            fields.append((name, np.bool_))
        elif isinstance(value, int):
            fields.append((name, np.int64))
        elif isinstance(value, tuple | list):
            fields.append((name, np.float64, (len(value),)))
        else:
            fields.append((name, np.float64))
    out = np.zeros(1, dtype=np.dtype(fields))
    out[0] = tuple(values.values())
    return out
