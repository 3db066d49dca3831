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
from numpy.typing import NDArray

from rigid_env import knobs
from rigid_env.core import threads
from rigid_env.core.actuator import actuators, fuel_per_unit, specs
from rigid_env.core.maths import rows_product
from rigid_env.core.world import World
from rigid_env.envs import kernels as K
from rigid_env.envs.batch_actions import Actions, as_num_envs
from rigid_env.envs.batch_actions import as_actions as as_actions  # (re-exported: its old home)
from rigid_env.envs.batch_infos import Infos
from rigid_env.envs.batch_observations import PERIOD_BOUND as PERIOD_BOUND  # (re-exported)
from rigid_env.envs.batch_observations import Observations
from rigid_env.envs.batch_resets import WORLD_STARTS as WORLD_STARTS  # (re-exported)
from rigid_env.envs.batch_resets import Resets
from rigid_env.envs.batch_view import RenderViews
from rigid_env.envs.hardware import (
    FAULT_ROW,
    NO_FAULT,
    Hardware,
    preset_keywords,
    with_presets,
)
from rigid_env.envs.params import (
    EnvSettings,
    TaskParams,
    numbers,
    parse_kwargs,
    refuse_idle_draws,
)
from rigid_env.envs.sampling import sensor_noise
from rigid_env.envs.sensing import SensorSuite, own_columns
from rigid_env.envs.streams import EnvStreams
from rigid_env.resources import scene_path
from rigid_env.scene import Scene, load_scene

FloatArray = NDArray[np.float64]


class TaskBatch(Observations, Actions, Resets, Infos, RenderViews):
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

    @classmethod
    def default_sensors(cls, version: int) -> dict[str, Any]:
        """The sensors (their settings by key) that a version of the task turns on where the
        ``sensors`` keyword leaves them out, beyond any it observes through always (none here;
        WheelPointing-v2's flight sensors). A sensor given as None stays off."""
        return {}

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
        """(N, A) the last command the bodies got: :attr:`last_action` itself where the task
        has no :meth:`demand`, thrust randomisation or faults; else an array of its own (made
        by :meth:`_plan_step`), the demand times ``thrust_scale`` once thrust is randomised."""
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
        if self._commands_apart and self.command is self.last_action:
            self.command = np.zeros_like(self.last_action)  # a demand may write into it
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
            self.world_data.h_wheels[rows] = rows_product(
                self.world.wheel_momentum[rows], wheels.axes
            )
        self.before_pass(rows, reset)

    def observed_field(self, rows: NDArray[np.int64]) -> tuple[FloatArray, float] | None:
        """The magnetic field the task observes as ``field_x..field_z`` in the envs ``rows``
        (a magnetometer's truth): ((K, 3) body frame [T], the field [T] it is observed over);
        None (the default): the task observes none."""
        return None

    def demand(self, action: FloatArray) -> FloatArray:
        """The actuators' commands (N, A) in [-1, 1] for the clipped actions (N, A) (what the
        flight software makes of a command before thrust randomisation and faults act on it):
        the actions themselves by default, the same array. A task's own may write them into
        :attr:`command` (an array apart from the actions where a task has a demand) and return
        it, so that its step allocates and copies nothing."""
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
            *others, last = (a.name for a in actuators())
            raise ValueError(
                f"scene: a task needs actuators ({', '.join(others)} or {last}); the scene has none"
            )
        return world

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
                                K.EVERY_ENV, self._threaded)  # fmt: skip
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
        of the record and the observation written in place, the others kept."""
        noise = self._no_noise
        if self._sigma > 0.0:
            noise = sensor_noise(self.streams, self._sigma, idx)
        world = self.world
        arrays = self._arrays(world.columns, world.model_columns, self.command, self.target,
                              self._world_data, noise, self.record, self.obs)  # fmt: skip
        self._pass(arrays, stepped, idx, threads.threaded(idx.size))

    def _arrays(self, state, model, command, target, world, noise, record, obs) -> tuple[Any, ...]:
        """The :class:`~rigid_env.envs.kernels.EnvArrays` of a pass, as a plain tuple."""
        return (state, model, command, target, world, noise, record, obs, self.max_force)

    def _pass(
        self, arrays: tuple[Any, ...], stepped: bool, rows: NDArray[np.int64], threaded: bool
    ) -> None:
        """The task's compiled pass over the envs ``rows`` of ``arrays``
        (:data:`~rigid_env.envs.kernels.EVERY_ENV`: all), split over the cores if ``threaded``
        (many envs; each env is computed alone, so the split changes no number)."""
        job = (self.numbers, arrays, stepped, rows)
        if threaded:
            threads.call_threaded(lambda t: type(self).task_pass(job, t))
        else:
            type(self).task_pass(job, 1)
