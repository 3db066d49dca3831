"""The task batch: a task on ``N`` bodies, written once (a single env is ``N = 1``).

:class:`TaskBatch` owns a :class:`~rigid_env.core.world.World` of ``N`` bodies and a task's
reset distribution, observation, reward and episode end. A step is two compiled calls: the
world's step, then the task's pass over the envs (:func:`rigid_env.envs.kernels.env_pass`:
fuel, reward, termination, success, observation, record). A task subclass names its parameters
model, its scene and its compiled pass, and draws one env's initial state (:meth:`sample`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces
from numpy.typing import ArrayLike, NDArray

from rigid_env import knobs
from rigid_env.core import threads
from rigid_env.core.actuator import fuel_per_unit, listed, specs
from rigid_env.core.layout import MAPS
from rigid_env.core.state import BodyModel
from rigid_env.core.world import World
from rigid_env.envs import kernels as K
from rigid_env.envs.hardware import (
    FAULT_KINDS,
    FAULT_ROW,
    NO_FAULT,
    Fault,
    Hardware,
    apply_faults,
    draw_fault,
    misaligned,
    preset_keywords,
    with_presets,
)
from rigid_env.envs.orbit_draws import place_on_orbit
from rigid_env.envs.params import (
    EnvSettings,
    TaskParams,
    numbers,
    parse_kwargs,
    refuse_idle_draws,
)
from rigid_env.envs.sampling import (
    mass_property_draws,
    random_mass_properties,
    random_thrust,
    sensor_noise,
)
from rigid_env.envs.sensing import SensorSuite, own_columns
from rigid_env.envs.sensors import RowNormals
from rigid_env.envs.streams import EnvStreams
from rigid_env.render import Frame, TaskView
from rigid_env.resources import scene_path
from rigid_env.scene import Scene, load_scene

FloatArray = NDArray[np.float64]

_NON_FINITE_ACTION = "action: contains NaN or inf; send finite thruster commands in [-1, 1]"

PERIOD_BOUND = 10.0
"""[s] the observed control period (``observe_control_period``) is clipped into [0, this]."""


def as_num_envs(value: Any) -> int:
    """``value`` as a number of envs (an integer >= 1, NumPy's included), or a one-line
    ``ValueError``."""
    integral = isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)
    if not integral or value < 1:
        raise ValueError(f"num_envs: must be an integer >= 1, got {value!r}")
    return int(value)


_COMPILED_DTYPES = frozenset(map(np.dtype, (np.float64, np.float32)))  # read as they are


def as_actions(action: ArrayLike) -> NDArray[Any]:
    """``action`` as an array of a real dtype the compiled clip reads (float64, float32, or
    integers as they are; float16, long double and byte-swapped floats converted to float64,
    which holds them exactly or, for long double, as NumPy casts), or a one-line ValueError."""
    act = action if isinstance(action, np.ndarray) else _array_of(action)
    if act.dtype in _COMPILED_DTYPES:
        return act
    kind = act.dtype.kind
    if kind not in "fiu" or (act.dtype.itemsize > 8 and kind != "f"):
        raise ValueError(
            f"action: expected real numbers (float32 or float64), got dtype {act.dtype}"
        )
    native = act.dtype.isnative and act.dtype.itemsize <= 8
    if kind == "f" and not (native and act.dtype.itemsize >= 4):
        act = act.astype(np.float64)
    elif not native:
        act = act.astype(act.dtype.newbyteorder("="))
    return act


def _array_of(action: Any) -> NDArray[Any]:
    """A NumPy array of ``action``; a tensor (torch: one that requires grad, on a GPU or in
    bfloat16, which NumPy cannot take as it is) detached to the CPU first, bfloat16 as the
    float32 that holds it exactly."""
    if hasattr(action, "detach") and hasattr(action, "cpu"):
        action = action.detach().cpu()
        if str(getattr(action, "dtype", "")) == "torch.bfloat16":
            action = action.float()
    try:
        return np.asarray(action)
    except (TypeError, ValueError, RuntimeError) as exc:
        reason = " ".join(str(exc).split())
        raise ValueError(
            f"action: expected an array of real numbers, got a {type(action).__name__} NumPy "
            f"cannot read ({reason})"
        ) from None


def _start_orbit_time(world: World, rows: NDArray[np.int64], t: FloatArray) -> None:
    world.orbit_time[rows] = t


def _start_wheel_speed(world: World, rows: NDArray[np.int64], speed: FloatArray) -> None:
    world.set_wheel_speed(speed, rows)


WORLD_STARTS: dict[str, Callable[[World, NDArray[np.int64], FloatArray], None]] = {
    "orbit_time": _start_orbit_time,
    "orbit_start": place_on_orbit,
    "wheel_speed": _start_wheel_speed,
}
"""Where an episode's world starts, by name, as a task's :meth:`TaskBatch.sample` may draw it:
``orbit_time`` the time along the orbit [s] (K,); ``orbit_start`` the orbit phase and the
Earth's rotation angle at the epoch [rad] (K, 2) where the orbit is world state
(:func:`rigid_env.envs.orbit_draws.place_on_orbit`); ``wheel_speed`` each wheel's speed
relative to the body [rad/s] (K, wheels)."""


class TaskBatch:
    """A task on ``num_envs`` bodies: reset distribution, observation, reward, episode end.

    A task subclass sets :attr:`params_model` (its keyword arguments), :attr:`scene_name`,
    :attr:`task_pass` (its one-line compiled pass naming its ``evaluate``) and, when it observes
    more than the body, :attr:`extra_observations`; it implements :meth:`sample` (one env's
    initial state and target from its generator) and :meth:`angular_velocity_scale`.
    Everything else (actions, thrusters, fuel, randomisation, spaces, buffers) lives here.

    Args:
        num_envs: number of bodies ``N``.
        **kwargs: the task's parameters (:attr:`params_model`) and the settings every task
            takes (:class:`~rigid_env.envs.params.EnvSettings`: ``scene``, ``integrator``,
            ``dt``, ``substeps``, ``rotation_repr``, ``randomization``, ``sensors``, ...).
    """

    params_model: ClassVar[type[TaskParams]]
    scene_name: ClassVar[str]
    task_pass: ClassVar[Callable[..., int]]
    extra_observations: tuple[str, ...] = ()
    """Names of the task's extra observations, in the order of ``Outcome.extra`` (a task may
    set them per instance, e.g. per version)."""
    extra_bound: ClassVar[float] = 1.0
    """The task's extra observations are clipped into +-this."""
    target_dim: ClassVar[int] = 0
    """Numbers of each env's target that :meth:`sample` draws and ``evaluate`` reads in its
    ``goal`` (at most :data:`~rigid_env.envs.kernels.TARGET_WIDTH`)."""
    memory_dim: ClassVar[int] = 0
    """Numbers of task memory ``evaluate`` keeps from step to step (its ``memory`` and
    ``Outcome.memory``; at most :data:`~rigid_env.envs.kernels.MEMORY_WIDTH`)."""
    refused_sensors: ClassVar[dict[str, str]] = {}
    """``sensors`` keys the task refuses, each with why (it observes what that sensor would
    hide: a one-line error names the sensor and this reason)."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """Refuse a task that declares more target or memory numbers than the pass holds."""
        super().__init_subclass__(**kwargs)
        for field, width, holds in (
            ("target_dim", K.TARGET_WIDTH, "TARGET_WIDTH"),
            ("memory_dim", K.MEMORY_WIDTH, "MEMORY_WIDTH"),
        ):
            size = getattr(cls, field)
            if not (isinstance(size, int) and 0 <= size <= width):
                raise TypeError(
                    f"{cls.__name__}.{field}: {size!r} numbers, but the task pass holds 0 to "
                    f"{width} (rigid_env.envs.kernels.{holds}); declare at most {width}, or "
                    f"widen {holds} and the pass's reads"
                )

    def __init__(self, num_envs: int, variant: str | None = None, **kwargs: Any) -> None:
        self.n = as_num_envs(num_envs)
        self.name: str = variant or type(self).__name__.removesuffix("Task")
        """What the errors call the task: its class's name (``Detumble``), or the registered
        variant it was made as (``DetumbleFaults-v0``)."""
        settings, self.params = parse_kwargs(self.params_model, self.name, kwargs)
        self.settings: EnvSettings = settings
        self.scene: Scene = with_presets(  # each actuator's hardware preset, by its keyword
            load_scene(
                settings.scene if settings.scene is not None else scene_path(self.version_scene())
            ),
            {keyword: getattr(settings, keyword) for keyword in preset_keywords()},
            settings.dt if isinstance(settings.dt, int | float) and settings.dt > 0 else None,
        )
        self.world = self._build_world()
        refuse_idle_draws(settings.randomization, self.scene.name, self.world.force_effects)
        self.dt = self.world.dt
        self.rotation_repr = settings.rotation_repr
        self.randomization = settings.randomization
        self.base_model = self.world.model
        # What each component spends per second at |u| = 1, as its actuator declares
        # (rigid_env.core.actuator: a thruster's force [N], spent as impulse [N s]; a coil's
        # dipole [A m^2], as dipole-time [A m^2 s], its charge and energy's measure).
        actuators = specs(self.world.force_effects)
        self.max_force = fuel_per_unit(self.world.force_effects)
        self.action_dim = self.world.action_dim
        self.w_scale = self.angular_velocity_scale()
        self._sensor_columns = own_columns(settings.sensors)
        self.obs_slices = self._observation_slices()
        """Where each observed quantity lies in an observation: ``orientation``, ``w`` (over
        :attr:`w_scale`), ``fine_w``, each of :attr:`extra_observations` and each column of a
        sensor that adds its own by name."""
        self.single_observation_space = self._observation_space()
        self.obs_dim = self.single_observation_space.shape[0]
        self.single_action_space = spaces.Box(-1.0, 1.0, shape=(self.action_dim,), dtype=np.float32)
        common = {
            "dt": self.dt,
            "w_scale": self.w_scale,
            "sixd": self.rotation_repr == "sixd",
            "extra_bound": self.extra_bound,
        }
        self.numbers = numbers(self.params, common, **self.derived_numbers())
        """(1,) the numbers of the compiled pass, by name (see
        :func:`~rigid_env.envs.params.numbers`)."""
        n, a = self.n, self.action_dim
        self.steps = np.zeros(n, dtype=np.int64)
        self.target = np.zeros((n, K.TARGET_WIDTH))
        """(N, TARGET_WIDTH) each env's target (its first :attr:`target_dim` numbers used)."""
        reads = self.world.wheels is not None or type(self).before_pass is not TaskBatch.before_pass
        self._world_data = np.zeros((n if reads else 1, K.WORLD_WIDTH))
        """(N | 1, WORLD_WIDTH) the pass's world data (:attr:`world_data` names its columns)."""
        self.thrust_scale: FloatArray | None = None
        """(N, A) strength of each actuator relative to the scene's, once thrust is randomised
        (None before: every actuator as in the scene)."""
        self.last_action = np.zeros((n, a))
        """(N, A) the last command each env was sent, clipped (before thrust randomisation)."""
        self.command = self.last_action
        """(N, A) the last command the bodies got: :attr:`last_action` itself until thrust is
        randomised, then ``last_action * thrust_scale``."""
        self.record = np.zeros(n, dtype=K.RECORD)
        """(N,) each env's :data:`~rigid_env.envs.kernels.RECORD`, written by the compiled pass."""
        self.obs = np.zeros((n, self.obs_dim), dtype=np.float32)
        """(N, obs_dim) the latest observations (overwritten by every step and reset, unless
        :meth:`observe` gave them away: then a new buffer is written)."""
        self._obs_given = False
        self.fault_rows = np.array([NO_FAULT] * n, dtype=FAULT_ROW)
        """(N,) each env's thruster fault in its episode (``randomization.thruster_faults``) as a
        :data:`~rigid_env.envs.hardware.FAULT_ROW` (:data:`~rigid_env.envs.hardware.NO_FAULT`:
        none); :attr:`faults` by env."""
        self._noisy = bool(self.world.parameters.noisy)
        self._no_noise = np.zeros((1, 3))
        self._sigma = self.randomization.sensor_noise
        self.streams = EnvStreams(n)
        """The envs' generators for the draws of a step (thrust and sensor noise), all the envs
        in one compiled pass, each from its own generator."""
        repeats = self.randomization.action_repeat or (1,)
        self.repeats = np.full(n, repeats[0], dtype=np.int64)
        """(N,) world steps each env holds an action for in its episode (its control period
        over ``dt``; ``randomization.action_repeat``)."""
        self._repeating = max(repeats) > 1
        if max(repeats) * self.world.substeps > knobs.MAX_ENV_STEP_SUBSTEPS:
            raise ValueError(
                f"randomization.action_repeat: {max(repeats)} world steps of {self.world.substeps} "
                f"substeps make one env step {max(repeats) * self.world.substeps} integrator "
                f"steps, above {knobs.MAX_ENV_STEP_SUBSTEPS}; give fewer substeps or a shorter "
                "control period"
            )
        self.substeps = np.zeros(n, dtype=np.int64)
        """(N,) the integrator steps each env's body took in its last env step (all the world
        steps of its control period; error-controlled integrators report them)."""
        self._hardware = Hardware.of(actuators, self.max_force)
        self._fuel_after: FloatArray | None = None
        self._observes_period = settings.observe_control_period
        self._check_extra_observations()
        self.sensors = SensorSuite.of(settings.sensors, self)
        """The observation's sensors (the ``sensors`` keyword; None: off, the truth observed)."""
        self._plan_step()

    def _plan_step(self) -> None:
        """Decide once what construction fixes about a step, for the step to read and not
        decide again: the action's accepted shapes, whether the bodies' command is made apart
        from the action, whether a pass over all the envs is split over the cores, whether the
        fuel is the pass's count of the commands, and which infos are reported."""
        n, a = self.n, self.action_dim
        self._action_shapes = ((n, a), (a,)) if n == 1 else ((n, a),)
        r = self.randomization
        self._commands_apart = (
            type(self).demand is not TaskBatch.demand
            or r.thrust > 0.0
            or r.thruster_faults is not None
        )
        """Whether :meth:`check_action` makes :attr:`command` apart from :attr:`last_action`
        (the task's :meth:`demand`, thrust randomisation or faults); else they are one array."""
        self._threaded = threads.threaded(n)
        """Whether a pass over all the envs is split over the cores."""
        self._reads_world = self.world.wheels is not None or (
            type(self).before_pass is not TaskBatch.before_pass
        )
        """Whether the pass reads world data (:attr:`world_data`), read before every pass."""
        self._counts_commands = self._hardware.counts_commands
        """Whether the fuel is the pass's count of the commands (no thruster hardware)."""
        self._faulty = r.thruster_faults is not None
        """Whether faults are drawn (and reported in the infos)."""
        self._reports_substeps = self.world.tolerances is not None
        """Whether the infos report the substeps (an error-controlled integrator)."""
        measuring = self.sensors is not None and self.sensors.measuring
        self._draws = self._noisy or self._sigma > 0.0 or measuring
        """Whether a step draws (thrust noise, sensor noise, sensors): the step's generators are
        then followed by :attr:`streams`."""

    # ---- task interface ------------------------------------------------------------------
    def angular_velocity_scale(self) -> float:
        """Typical angular speed [rad/s] that the observation divides by."""
        raise NotImplementedError

    def sample(self, rng: np.random.Generator) -> tuple[Any, ...]:
        """One env's initial ``(x (3,), v (3,), q (4,), w_body (3,), target (target_dim,))``,
        optionally followed by a dict of where its world starts, by the names of
        :data:`WORLD_STARTS` (``{"orbit_time": t}``)."""
        raise NotImplementedError

    version_scenes: ClassVar[dict[int, str]] = {}
    """The scene stems of the task's later versions, by the version they start at (a version
    plays the newest one at or below it; :attr:`scene_name` before the first)."""

    def version_scene(self) -> str:
        """The stem of the scene this env's version plays (:attr:`version_scenes`)."""
        version = int(getattr(self.params, "version", 0))
        starts = [k for k in self.version_scenes if k <= version]
        return self.version_scenes[max(starts)] if starts else self.scene_name

    def before_pass(self, rows: NDArray[np.int64] | slice, reset: bool) -> None:
        """Before the task's pass over the envs ``rows`` (after their world step, or their
        reset), write what of the world the framework does not read itself into their
        :attr:`world_data` by name (the field along the task's orbit); nothing by default."""

    def _read_world(self, rows: NDArray[np.int64] | slice, reset: bool) -> None:
        """The world data of the envs ``rows`` before their pass: the wheels' momentum, then the
        task's (:meth:`before_pass`)."""
        wheels = self.world.wheels
        if wheels is not None:
            self.world_data.h_wheels[rows] = self.world.wheel_momentum[rows] @ wheels.axes
        self.before_pass(rows, reset)

    def observed_field(self, rows: NDArray[np.int64]) -> tuple[FloatArray, float] | None:
        """The magnetic field the task observes as ``field_x..field_z`` in the envs ``rows``
        (a magnetometer's truth): ((K, 3) body frame [T], the field [T] it is observed over);
        None (the default): the task observes none."""
        return None

    def demand(self, action: FloatArray) -> FloatArray:
        """The actuators' commands (N, A) in [-1, 1] for the clipped actions (N, A) (what the
        flight software makes of a command before thrust randomisation and faults act on it):
        the actions themselves by default, the same array."""
        return action

    def derived_numbers(self) -> dict[str, float]:
        """Numbers ``evaluate`` reads beside the parameters, derived from them and the scene
        (none by default)."""
        return {}

    @property
    def version(self) -> int:
        """The task's version (the ``-vK`` of its id; 0 for a task with one)."""
        return int(getattr(self.params, "version", 0))

    # ---- shared machinery ----------------------------------------------------------------
    def _build_world(self) -> World:
        """The :class:`~rigid_env.core.world.World` of the ``N`` bodies, as the settings ask
        (a failed body frozen, for its episode to end)."""
        settings = self.settings
        world = self.scene.build_world(
            n=self.n,
            integrator=settings.integrator,
            dt=settings.dt,
            substeps=settings.substeps,
            on_error="freeze",
            rtol=settings.rtol,
            atol=settings.atol,
        )
        if world.action_dim == 0:
            raise ValueError(
                "scene: a task needs actuators (thrusters, point_forces, magnetorquers or "
                "reaction_wheels); the scene has none"
            )
        return world

    def _observation_space(self) -> spaces.Box:
        """One env's observation space: the bounds of :attr:`obs_slices`' parts in order."""
        period = self.settings.observe_control_period
        bound = np.concatenate(
            [
                np.ones(4 if self.rotation_repr == "quaternion" else 6),
                np.full(3, K.W_OBS_BOUND),
                np.ones(3),
                np.full(len(self.extra_observations), self.extra_bound),
                np.array([b for _, b in self._sensor_columns]),
                np.full(int(period), PERIOD_BOUND),
            ]
        ).astype(np.float32)
        low = -bound
        if period:
            low[-1] = 0.0
        return spaces.Box(low, bound, dtype=np.float32)

    def _observation_slices(self) -> dict[str, slice]:
        rot = 4 if self.rotation_repr == "quaternion" else 6
        out = {"orientation": slice(0, rot), "w": slice(rot, rot + 3)}
        out["fine_w"] = slice(rot + 3, rot + 6)
        names = [*self.extra_observations, *(name for name, _ in self._sensor_columns)]
        for k, name in enumerate(names):
            out[name] = slice(rot + 6 + k, rot + 7 + k)
        if self.settings.observe_control_period:
            end = rot + 6 + len(names)
            out["control_period"] = slice(end, end + 1)
        return out

    def _observe_period(self, idx: NDArray[np.int64] | None = None) -> None:
        """Write the control period ``k dt`` [s] of the envs ``idx`` (default all) into their
        last observation column, where it is observed (after the task's pass, which knows
        nothing of it)."""
        if self._observes_period:
            rows = slice(None) if idx is None else idx
            period = np.minimum(self.repeats[rows] * self.dt, PERIOD_BOUND)
            self.obs[rows, -1] = period.astype(np.float32)

    def _check_extra_observations(self) -> None:
        """Run the compiled pass once on a scratch env (compiling it, or loading it from the
        cache) and check that ``evaluate`` gives every extra observation the task names."""
        state = np.zeros((13, 1))
        state[6] = 1.0  # the identity orientation
        arrays = (state, self.world.model_columns[:, :1].copy(), np.zeros((1, self.action_dim)),
                  np.zeros((1, K.TARGET_WIDTH)), np.zeros((1, K.WORLD_WIDTH)), self._no_noise,
                  np.zeros(1, K.RECORD),
                  np.zeros((1, self.obs_dim), np.float32), self.max_force)  # fmt: skip
        given = type(self).task_pass((self.numbers, arrays, False), 1)
        if given < len(self.extra_observations):
            raise ValueError(
                f"{type(self).__name__}: evaluate returns {given} extra observation(s), the task "
                f"names {len(self.extra_observations)} ({', '.join(self.extra_observations)}); "
                "return them all in Outcome.extra"
            )

    @property
    def fuel(self) -> FloatArray:
        """(N,) impulse spent in the episode so far [N s] (a view of :attr:`record`)."""
        return self.record["fuel"]

    @property
    def success(self) -> NDArray[np.bool_]:
        """(N,) whether each env's task counts as solved at the current step."""
        return self.record["success"]

    def angular_speed(self) -> FloatArray:
        """(N,) ``|w|`` [rad/s] of the current state (finite for a frozen, diverged body)."""
        return self.record["speed"].copy()

    def check_action(self, action: ArrayLike) -> FloatArray:
        """Validate and clip a command to (N, A) in [-1, 1] (into :attr:`last_action`; the
        bodies' command, thrust randomisation included, into :attr:`command`).

        Raises:
            ValueError: a dtype that is not real, a wrong shape, or a NaN/inf entry (never
                silently simulated).
        """
        act = as_actions(action)
        if act.shape not in self._action_shapes:
            raise ValueError(
                f"action: expected shape ({self.n}, {self.action_dim})"
                f"{' or (' + str(self.action_dim) + ',)' if self.n == 1 else ''}, "
                f"got {act.shape}"
            )
        if K.clip_commands(np.ascontiguousarray(act), self.last_action) < 0:
            raise ValueError(_NON_FINITE_ACTION)
        if self._commands_apart:
            self._make_command()
        return self.last_action

    def _make_command(self) -> None:
        """The bodies' :attr:`command` from the clipped :attr:`last_action`: the task's
        :meth:`demand`, times the thrust scales once thrust is randomised, then the faults."""
        demand = self.demand(self.last_action)
        if self.thrust_scale is not None:
            np.multiply(demand, self.thrust_scale, out=self.command)
        elif self.randomization.thruster_faults is not None or demand is not self.last_action:
            if self.command is self.last_action:  # a command apart from the action from now on
                self.command = demand.copy()
            else:
                self.command[:] = demand
        if self.randomization.thruster_faults is not None:
            apply_faults(self.command, self.steps, self.fault_rows)

    def _draw_thrust_factors(self, skip: NDArray[np.bool_] | None = None) -> None:
        """Each env's thrust noise factors for this step from its own generator (factor 1,
        nothing drawn, for envs about to restart: as a single env's generator sees it), all
        drawn in one compiled pass (:attr:`streams`, following the step's generators)."""
        rows = None if skip is None or not skip.any() else np.flatnonzero(~skip)
        if rows is not None:
            self.world.thrust_factors[skip] = 1.0
        normals = self.streams.standard_normals(rows, self.action_dim)
        self.world.draw_thrust_factors(RowNormals(normals), rows=rows)

    def step(
        self, rngs: Sequence[np.random.Generator], restarting: NDArray[np.bool_] | None = None
    ) -> tuple[FloatArray, NDArray[np.bool_], NDArray[np.bool_]]:
        """Advance every body by ``dt`` with the command of the last :meth:`check_action`.

        Args:
            rngs: one generator per env (drawn from only for sensor noise).
            restarting: (N,) envs about to be reset (autoreset): no noise is drawn for them
                here, so each env's generator sees what a single env's would.

        Returns:
            reward (N,), terminated (N,), failed (N,) (the state turned non-finite this step;
            the body is frozen at its last finite state and the episode must end). Views of
            the task's buffers, valid until the next step.
        """
        reward, failed = self._step(rngs, restarting)
        if reward is None:
            reward = self.record["reward"]
        return reward, self.record["terminated"].copy(), failed

    def step_one(self, rng: np.random.Generator) -> tuple[K.EnvRecord, bool]:
        """:meth:`step` of a task of one env: its record as Python values and whether its body
        failed."""
        reward, failed = self._step([rng])
        record = K.EnvRecord._make(self.record.item(0))
        if reward is not None:  # the summed reward of the repeated steps
            record = record._replace(reward=float(reward[0]))
        return record, failed is not self.world.no_failures and bool(failed[0])

    def _step(
        self, rngs: Sequence[np.random.Generator], restarting: NDArray[np.bool_] | None = None
    ) -> tuple[FloatArray | None, NDArray[np.bool_]]:
        """:meth:`step`'s steps: the repeated steps' summed reward (None for one step: the
        record's) and the failed mask."""
        if self._repeating:
            return self._step_repeated(rngs, restarting)
        failed = self._step_envs(rngs, skip=restarting)
        if self.n == 1:  # a scalar add: NumPy's in-place add costs a sixth of a single env's step
            self.steps[0] += 1
        else:
            self.steps += 1
        if self._observes_period:
            self._observe_period()
        if self.sensors is not None:
            self.sensors.measure(self, rngs, restarting)
            self.sensors.delay(self)
        return None, failed

    def _step_repeated(
        self, rngs: Sequence[np.random.Generator], restarting: NDArray[np.bool_] | None = None
    ) -> tuple[FloatArray, NDArray[np.bool_]]:
        """:meth:`step` where env ``i`` holds its command for :attr:`repeats` ``[i]`` world steps:
        exactly the steps (world step, then the task's pass) a caller would make by sending the
        same action that many times, stopped after one that ends the episode; the reward is
        their sum (so an episode's return is the same however its actions are grouped), the
        record, fuel and observation those of the last. Envs about to restart are not stepped
        (their state is drawn anew). Returns the summed reward and whether each env failed."""
        reward = np.zeros(self.n)
        ended = np.zeros(self.n, dtype=bool) if restarting is None else restarting.copy()
        failed_any = np.zeros(self.n, dtype=bool)
        self.substeps[:] = 0
        for r in range(int(self.repeats.max())):
            stepping = (self.repeats > r) & ~ended
            if not stepping.any():
                break
            failed = self._step_envs(rngs, stepping=stepping)
            if self.sensors is not None:
                self.sensors.measure(self, rngs, ~stepping)
            if self.world.tolerances is not None:
                self.substeps[stepping] += self.world.substeps_taken[stepping]
            failed_any |= failed
            reward[stepping] += self.record["reward"][stepping]
            ended |= stepping & (self.record["terminated"] | failed)
        self.steps += 1
        self._own_obs(keep=True)  # no pass ran if every env was restarting
        self._observe_period()
        if self.sensors is not None:
            self.sensors.delay(self)
        return reward, failed_any

    def _step_envs(
        self,
        rngs: Sequence[np.random.Generator],
        skip: NDArray[np.bool_] | None = None,
        stepping: NDArray[np.bool_] | None = None,
    ) -> NDArray[np.bool_]:
        """The stages of a step: the thrust noise of the step, the world's step, then the task's
        pass (fuel, reward, observation). Returns the world step's failed mask.

        ``skip``: envs stepped but about to restart (no noise drawn for them). ``stepping``: the
        envs to step (default all); the others are held: their bodies frozen in the world
        (:attr:`World.failed`: a frozen body is left as it is, its thrust levels included),
        nothing drawn from their generators, and the pass run over the stepping envs only."""
        if stepping is not None and not stepping.all():
            return self._step_some(rngs, stepping)
        world = self.world
        if self._draws:
            self.streams.follow(rngs)
        if self._noisy:
            self._draw_thrust_factors(skip)
        failed = self.world.advance(self.command) if self._counts_commands else self._advance()
        if self._obs_given:
            self._own_obs(keep=stepping is not None)
        noise = self._no_noise
        if self._sigma > 0.0:
            some = skip is not None and skip.any()
            rows = np.flatnonzero(~skip) if some else None
            noise = sensor_noise(self.streams, self._sigma, rows, self.n if some else 0)
        if self._reads_world:
            self._read_world(slice(None), reset=False)
        self._pass(self._arrays(world.columns, world.model_columns, self.command, self.target,
                                self._world_data, noise, self.record, self.obs), True,
                                self._threaded)  # fmt: skip
        if not self._counts_commands:
            self._count_delivered()
        return failed

    def _step_some(
        self, rngs: Sequence[np.random.Generator], stepping: NDArray[np.bool_]
    ) -> NDArray[np.bool_]:
        """:meth:`_step_envs` of the envs ``stepping`` only, the others held."""
        if self._draws:
            self.streams.follow(rngs)
        if self._noisy:
            self._draw_thrust_factors(~stepping)
        failed = self._advance_held(~stepping & ~self.world.failed)
        self._own_obs(keep=True)
        idx = np.flatnonzero(stepping)
        self._read_world(idx, reset=False)
        self._pass_rows(idx, stepped=True)
        self._count_delivered(idx)
        return failed

    def _advance_held(self, held: NDArray[np.bool_]) -> NDArray[np.bool_]:
        """The world's step with the bodies ``held`` frozen through it."""
        world = self.world
        world.failed[held] = True
        try:
            return self._advance()
        finally:  # held bodies thaw whatever the step did (an error under on_error="raise")
            world.failed[held] = False

    def _advance(self) -> NDArray[np.bool_]:
        """The world step with :attr:`command`; where the thrusters have hardware (a lag, a
        minimum impulse bit, noise), each env's fuel after it, counted as the impulse the
        thrusters deliver (:meth:`~rigid_env.envs.hardware.Hardware.delivered`), for
        :meth:`_count_delivered` to put in place of the pass's count of the commands."""
        if self._counts_commands:
            return self.world.advance(self.command)
        levels = self.world.thrust_levels
        levels = None if levels is None else levels.copy()
        factors = self.world.thrust_factors if self._noisy else None
        impulse = self._hardware.delivered(self.command, self.dt, factors, levels)
        failed = self.world.advance(self.command)
        self._fuel_after = self.record["fuel"] + np.where(self.world.failed, 0.0, impulse)
        return failed

    def _count_delivered(self, idx: NDArray[np.int64] | None = None) -> None:
        """Each env's fuel (rows ``idx``, default all) as the impulse delivered (after the
        pass, which counts the commands)."""
        if self._fuel_after is not None:
            rows = slice(None) if idx is None else idx
            self.record["fuel"][rows] = self._fuel_after[rows]

    def _pass_rows(self, idx: NDArray[np.int64], stepped: bool) -> None:
        """The task's pass over the envs ``idx`` only (after a step of some, or a reset),
        sensor noise drawn from their generators (:attr:`streams`, following them): their rows
        of the record and the observation written, the others kept."""
        record, obs = self.record[idx], self.obs[idx]
        cols = np.ascontiguousarray(self.world.columns[:, idx])
        model = np.ascontiguousarray(self.world.model_columns[:, idx])
        noise = self._no_noise
        if self._sigma > 0.0:
            noise = sensor_noise(self.streams, self._sigma, idx)
        world = self._world_data[idx] if self._reads_world else self._world_data
        arrays = self._arrays(cols, model, self.command[idx], self.target[idx], world,
                              noise, record, obs)  # fmt: skip
        self._pass(arrays, stepped, threads.threaded(idx.size))
        self.record[idx], self.obs[idx] = record, obs

    def _arrays(self, state, model, command, target, world, noise, record, obs) -> tuple[Any, ...]:
        """The :class:`~rigid_env.envs.kernels.EnvArrays` of a pass, as a plain tuple."""
        return (state, model, command, target, world, noise, record, obs, self.max_force)

    def _pass(self, arrays: tuple[Any, ...], stepped: bool, threaded: bool) -> None:
        """The task's compiled pass over the envs of ``arrays``, split over the cores if
        ``threaded`` (many envs; each env is computed alone, so the split changes no number)."""
        job = (self.numbers, arrays, stepped)
        if threaded:
            threads.call_threaded(lambda t: type(self).task_pass(job, t))
        else:
            type(self).task_pass(job, 1)

    def _own_obs(self, keep: bool) -> None:
        """If :meth:`observe` gave :attr:`obs` away, write into a new buffer from now on (with
        the same rows if ``keep``, for a reset of some envs): what a caller got stays as it
        was, with no copy per step."""
        if self._obs_given:
            self.obs = self.obs.copy() if keep else np.empty_like(self.obs)
            self._obs_given = False

    def reset_envs(
        self, idx: Sequence[int] | NDArray[np.int64], rngs: Sequence[np.random.Generator]
    ) -> None:
        """Start new episodes for envs ``idx``, each drawing from ``rngs[k]`` (one per index),
        and observe them (:attr:`obs` rows ``idx``; sensor noise from the same generators)."""
        idx = np.asarray(idx, dtype=np.int64)
        s = self.world.state
        draws = []
        r = self.randomization
        randomized = r.physical or r.thrust > 0.0 or r.hardware or r.drawn_repeat
        # Each env draws its initial state, then its episode's randomisation, from its own
        # generator: all the envs' states, then all their randomisations (the draws of many at
        # once), unless envs share a generator: then env by env, in order.
        shared = randomized and len({id(g) for g in rngs}) < len(rngs)
        groups = [[k] for k in range(idx.size)] if shared else [list(range(idx.size))]
        for group in groups:
            for k in group:
                draws.append(self.sample(rngs[k]))
                if np.shape(draws[-1][4]) != (self.target_dim,):
                    raise ValueError(
                        f"{type(self).__name__}.sample: drew a target of shape "
                        f"{np.shape(draws[-1][4])}, the task declares target_dim = "
                        f"{self.target_dim}; return a target of target_dim numbers (or declare "
                        "its size in target_dim)"
                    )
            if randomized and group:
                self._randomize(idx[group], [rngs[k] for k in group])
        if randomized and self.randomization.physical and idx.size:
            model = self.world.model  # each body's mass properties drawn above, set at once
            self.world.set_model(BodyModel(model.mass, model.inertia))
        self.world.restart(idx)  # valves closed, dop853 from its own first guess
        if draws:
            x, v, q, w, target = (np.array(c) for c in zip(*(d[:5] for d in draws), strict=True))
            s.x[idx], s.v[idx], s.q[idx], s.w[idx] = x, v, q, w
            if self.target_dim:
                self.target[idx, : self.target_dim] = target
            if len(draws[0]) > 5:
                for name in draws[0][5]:
                    WORLD_STARTS[name](self.world, idx, np.array([d[5][name] for d in draws]))
        self.steps[idx] = 0
        self.record[idx] = 0
        self.last_action[idx] = 0.0
        self.command[idx] = 0.0
        self.world.failed[idx] = False
        if idx.size == 0:
            return
        self._own_obs(keep=True)  # rows idx are written below, the others kept
        self._read_world(idx, reset=True)
        if self._draws:
            self.streams.follow(rngs, idx)
        self._pass_rows(idx, stepped=False)
        self._observe_period(idx)
        if self.sensors is not None:
            self.sensors.reset(self, idx, rngs)

    def _randomize(self, rows: NDArray[np.int64], rngs: Sequence[np.random.Generator]) -> None:
        """The episode draws of the envs ``rows`` (``rngs``: their generators, one each): their
        mass properties and thrust scales from their uniform draws (all the envs' in one
        compiled pass), then env by env their thrusters' misalignment, fault and control
        period."""
        r = self.randomization
        physical = mass_property_draws(r)
        thrust = self.action_dim if r.thrust > 0.0 else 0
        if physical + thrust:
            self.streams.follow(rngs, rows)
            u = self.streams.randoms(rows, physical + thrust)
        if r.physical:
            if self.world.model.n == 1:  # first randomised reset: give every body its own copy
                self.world.set_model(
                    BodyModel(
                        np.repeat(self.base_model.mass, self.n),
                        np.repeat(self.base_model.inertia, self.n, axis=0),
                    )
                )
            mass, inertia = random_mass_properties(
                u[:, :physical], r, self.base_model.mass[0], self.base_model.inertia[0]
            )
            model = self.world.model  # set in the world by reset_envs, once for all its envs
            model.mass[rows] = mass
            model.inertia[rows] = inertia
        if thrust:
            if self.thrust_scale is None:  # first randomised reset: scales, and a command apart
                self.thrust_scale = np.ones((self.n, self.action_dim))
                self.command = self.last_action * self.thrust_scale
            self.thrust_scale[rows] = random_thrust(u[:, physical:], r)
        if not (r.hardware or r.drawn_repeat):
            return
        for i, rng in zip(rows.tolist(), rngs, strict=True):
            if r.thruster_misalignment > 0.0:
                self._misalign(i, rng, r.thruster_misalignment)
            if r.thruster_faults is not None:
                fault = draw_fault(rng, r.thruster_faults, self.action_dim)
                self.fault_rows[i] = NO_FAULT if fault is None else fault.row
            if r.drawn_repeat:
                choices = r.action_repeat
                self.repeats[i] = choices[int(rng.integers(len(choices)))]

    def _misalign(self, i: int, rng: np.random.Generator, degrees: float) -> None:
        """Env ``i``'s thrusters tilted for its episode (its own actuator maps in the world)."""
        if self.world.body_maps is None:  # first misaligned reset: every body its own maps
            maps = np.broadcast_to(
                self.world.params[MAPS : MAPS + 6 * self.action_dim].reshape(-1, 6),
                (self.n, self.action_dim, 6),
            )
            self.world.set_body_maps(maps[:, :, :3], maps[:, :, 3:])
        maps = self.world.body_maps
        k = 0
        for a, spec in listed(self.world.force_effects):
            rows = spec.action_dim
            if a.tilted is not None:  # its directions turned, as it declares
                force, torque = a.tilted(spec, lambda d: misaligned(d, rng, degrees))
                maps[i, k : k + rows, :3] = force
                maps[i, k : k + rows, 3:] = torque
            k += rows

    def observe(self, idx: NDArray[np.int64] | None = None) -> NDArray[np.float32]:
        """The latest observations, the caller's to keep: (N, obs_dim) (the buffer itself,
        which no later step or reset writes into), or a copy of the rows ``idx``."""
        if idx is not None:
            return self.obs[idx]
        self._obs_given = True
        return self.obs

    def infos(self) -> dict[str, NDArray[Any]]:
        """Per-env diagnostics (copies): angular speed, energy, fuel, success, failure; with an
        error-controlled integrator also the substeps each env's body took in the last step."""
        info = self._info(self._columns, self.world.failed, self._fault_infos(), self._substeps())
        return {key: value.copy() for key, value in info.items()}

    @property
    def world_data(self) -> K.WorldData:
        """Each env's world data by name (the field, the wheels' momentum), what ``evaluate``
        reads as ``body.field`` and ``body.h_wheels``: read from the world before every pass
        (one shared row of zeros where the world has neither). Views, made once per buffer
        (again after unpickling, where they would be copies)."""
        views = self.__dict__.get("_world_views")
        if views is None or views.field.base is not self._world_data:
            views = K.WorldData.of(self._world_data)
            self._world_views = views
        return views

    @property
    def _columns(self) -> K.EnvRecord:
        """:attr:`record`'s columns by name (views, made once per record buffer: again after
        unpickling, where they would be copies)."""
        columns = self.__dict__.get("_column_views")
        if columns is None or columns.speed.base is not self.record:
            columns = K.EnvRecord._make(map(self.record.__getitem__, K.RECORD.names))
            self._column_views = columns
        return columns

    def info_one(self, r: K.EnvRecord | None = None, failed: bool | None = None) -> dict[str, Any]:
        """:meth:`infos` of env 0 as Python scalars (a (3,) array for a vector): what a single
        env returns, from its record and whether its body failed (each read here if not
        given)."""
        r = K.EnvRecord._make(self.record.item(0)) if r is None else r
        failed = bool(self.world.failed[0]) if failed is None else failed
        faults = {}
        if self._faulty:
            faults = {key: column[0].item() for key, column in self._fault_infos().items()}
        taken = int(self._substeps()[0]) if self._reports_substeps else None
        out = self._info(r, failed, faults, taken)
        out["angular_velocity_world"] = r.w_world.copy()  # item() gives a view of the record
        return out

    def _info(self, r: K.EnvRecord, failed: Any, faults: dict[str, Any], substeps: Any) -> dict:
        """The diagnostics by name from a record (one env's values, or the columns of all),
        the failure flags, the fault infos and the substeps taken (None: not reported)."""
        out = {
            "angular_speed": r.speed,
            "energy": r.energy,
            "fuel": r.fuel,
            "success": r.success,
            "is_success": r.success,  # SB3 EvalCallback logs this key
            "numerical_error": failed,
            "angular_velocity_world": r.w_world,
            **faults,
        }
        if substeps is not None:
            out["substeps"] = substeps
        return out

    def _substeps(self) -> NDArray[np.int64] | None:
        """(N,) the substeps each body took in the last step, for an error-controlled
        integrator (None for a fixed-step one)."""
        if self.world.tolerances is None:
            return None
        return self.substeps if self._repeating else self.world.substeps_taken

    @property
    def faults(self) -> list[Fault | None]:
        """Each env's thruster fault in its episode (None: none), read from :attr:`fault_rows`."""
        return [
            None if k < 0 else Fault(k, step, FAULT_KINDS[kind], level)
            for k, step, kind, level in self.fault_rows.tolist()
        ]

    def _fault_infos(self) -> dict[str, NDArray[Any]]:
        """Where faults are drawn: each env's failed thruster (-1: none), the step its fault
        starts, its kind (index in :data:`~rigid_env.envs.hardware.FAULT_KINDS`, -1: none) and
        level, and whether it acts now."""
        if self.randomization.thruster_faults is None:
            return {}
        rows = self.fault_rows
        thruster, step = rows["thruster"], rows["step"]
        return {
            "fault_thruster": thruster,
            "fault_step": step,
            "fault_kind": rows["kind"],
            "fault_level": rows["level"],
            "fault_active": (thruster >= 0) & (self.steps > step),
        }

    # ---- what a renderer shows (rigid_env.render) ----------------------------------------
    def view(self) -> TaskView:
        """What the task shows: its body, its thrusters and (under gravity) the ground; a task
        adds its target and readouts."""
        title = type(self).__name__.removesuffix("Task")
        return TaskView.for_scene(
            title, self.scene, self.world.force_effects, spin_scale=self.w_scale
        )

    def readouts(self, i: int) -> tuple[float, ...]:
        """Env ``i``'s numbers for :attr:`TaskView.readouts` (none by default)."""
        return ()

    def delivered_thrust(self, i: int) -> FloatArray:
        """(A,) env ``i``'s thrust in the last step in units of each max force, as delivered:
        the lagged level at the step's end where the thrusters lag, else the command after
        faults (an on/off duty is the step's mean level), times the step's noise factors."""
        levels = self.world.thrust_levels
        if levels is not None:
            return np.clip(levels[i], -1.0, 1.0)
        out = self.command[i].copy()
        if self._noisy:
            out *= self.world.thrust_factors[i]
        return np.clip(out, -1.0, 1.0)

    def frame(self, i: int = 0) -> Frame:
        """The numbers of env ``i``'s current frame."""
        if not 0 <= i < self.n:
            raise IndexError(f"i: environment index {i} is out of range for {self.n} envs")
        s = self.world.state
        return Frame(
            q=s.q[i].copy(),
            w_body=s.w[i].copy(),
            height=float(s.x[i, 2]),
            command=self.delivered_thrust(i),
            step=int(self.steps[i]),
            angular_speed=float(self.angular_speed()[i]),
            fuel=float(self.fuel[i]),
            success=bool(self.success[i]),
            target=self.target[i, :4].copy() if self.target_dim else None,
            readouts=self.readouts(i),
        )
