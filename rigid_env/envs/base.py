"""The task layer shared by every environment, written once for a batch of ``N`` bodies.

:class:`TaskBatch` owns a :class:`~rigid_env.core.world.World` of ``N`` bodies and a task's reset
distribution, observation, reward and episode end. A step is two compiled calls: the world's
step, then the task's pass over the envs (:func:`rigid_env.envs.kernels.task_pass`: fuel,
reward, termination, success, observation, info). :class:`RigidBodyEnv` (a ``gymnasium.Env``)
is the ``N = 1`` case of it and :class:`RigidBodyVectorEnv` (a native
``gymnasium.vector.VectorEnv``) the ``N`` case: there is no second copy of anything.

Randomness comes only from per-environment generators (``np_random`` of the single env; one
generator per sub-environment, seeded ``seed + i``, in the vector env), so sub-environment ``i``
of a vector env reset with ``seed`` replays a single env reset with ``seed + i`` bit for bit.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import ArrayLike, NDArray

from rigid_env.core import world as core_world
from rigid_env.core.effects import LinearActuator
from rigid_env.core.state import BodyModel
from rigid_env.envs import kernels as T
from rigid_env.render import Frame, TaskRenderer, TaskView
from rigid_env.resources import scene_path
from rigid_env.scene import Scene, load_scene

FloatArray = NDArray[np.float64]


def default_scene_path(name: str) -> Path:
    """Path of a scene shipped in ``configs/scenes`` (in the checkout or the installed wheel)."""
    return scene_path(name)


@dataclass(frozen=True)
class Randomization:
    """Domain randomisation, drawn per episode from the environment's own generator.

    Attributes:
        mass: relative half-width ``a``: mass times ``U(1 - a, 1 + a)``.
        inertia: relative half-width for each principal moment (the largest is then clipped
            onto the triangle inequality so the body stays physical).
        thrust: relative half-width for each actuator's strength.
        sensor_noise: standard deviation of Gaussian noise on the observed angular velocity
            [rad/s] (drawn every step, for every env: a per-env loop, so off by default).
    """

    mass: float = 0.0
    inertia: float = 0.0
    thrust: float = 0.0
    sensor_noise: float = 0.0

    def __post_init__(self) -> None:
        for name in ("mass", "inertia", "thrust"):
            val = getattr(self, name)
            if not (np.isfinite(val) and 0.0 <= val < 1.0):
                raise ValueError(f"randomization.{name}: must lie in [0, 1), got {val}")
        if not (np.isfinite(self.sensor_noise) and self.sensor_noise >= 0.0):
            raise ValueError(
                f"randomization.sensor_noise: must be >= 0 [rad/s], got {self.sensor_noise}"
            )

    @property
    def physical(self) -> bool:
        """Whether any mass-property draw is needed at reset."""
        return self.mass > 0.0 or self.inertia > 0.0


def as_randomization(value: Randomization | dict[str, float] | None) -> Randomization:
    """A :class:`Randomization` from itself, a dict of its fields or None (none), or a
    one-line ``ValueError`` naming the bad key or type."""
    if value is None:
        return Randomization()
    if isinstance(value, Randomization):
        return value
    if not isinstance(value, dict):
        raise ValueError(
            f"randomization: expected a dict with keys mass, inertia, thrust, sensor_noise, "
            f"got {type(value).__name__} {value!r}"
        )
    known = {"mass", "inertia", "thrust", "sensor_noise"}
    unknown = sorted(set(map(str, value)) - known)
    if unknown:
        raise ValueError(
            f"randomization.{unknown[0]}: unknown key; use mass, inertia, thrust, sensor_noise"
        )
    for key in ("mass", "inertia", "thrust"):
        if key in value:
            bounded(f"randomization.{key}", value[key], "relative half-width", 0.0, 1.0,
                    high_open=True)  # fmt: skip
    if "sensor_noise" in value:
        bounded("randomization.sensor_noise", value["sensor_noise"], "rad/s")
    return Randomization(**{k: float(v) for k, v in value.items()})


def random_unit_vectors(rng: np.random.Generator, n: int | None = None) -> FloatArray:
    """Directions uniform on the sphere, (3,) or (n, 3)."""
    if n is None:
        v = rng.normal(size=3)
        x, y, z = v.tolist()
        return v / math.sqrt(x * x + y * y + z * z)
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_quaternion(rng: np.random.Generator) -> FloatArray:
    """Rotation uniform on SO(3) as a unit quaternion (4,) (normalised 4-D Gaussian)."""
    q = rng.normal(size=4)
    w, x, y, z = q.tolist()
    return q / math.sqrt(w * w + x * x + y * y + z * z)


def bounded(
    name: str,
    value: Any,
    unit: str,
    low: float = 0.0,
    high: float = math.inf,
    *,
    low_open: bool = False,
    high_open: bool = False,
) -> float:
    """``value`` as a float inside ``[low, high]`` (ends excluded where ``*_open``), or a
    one-line ``ValueError`` naming the argument, its unit and its range: a task's keyword
    arguments are all checked when the env is made, never late or silently."""
    ok = isinstance(value, int | float | np.integer | np.floating) and not isinstance(value, bool)
    x = float(value) if ok else math.nan
    inside = (
        math.isfinite(x)
        and (x > low if low_open else x >= low)
        and (x < high if high_open else x <= high)
    )
    if not inside:
        lo, hi = ("(" if low_open else "[") + f"{low:g}", f"{high:g}" + (")" if high_open else "]")
        raise ValueError(f"{name}: must be a finite number in {lo}, {hi} [{unit}], got {value!r}")
    return x


def positive(name: str, value: Any, unit: str) -> float:
    """``value`` as a finite float > 0, or a one-line ``ValueError`` naming the argument."""
    return bounded(name, value, unit, 0.0, low_open=True)


def task_version(name: str, value: Any, newest: int) -> int:
    """``value`` as a task version in ``0..newest``, or a one-line ``ValueError``."""
    integral = isinstance(value, int | np.integer) and not isinstance(value, bool)
    if not integral or not 0 <= value <= newest:
        raise ValueError(
            f"{name}: must be an integer from 0 to {newest} (the task's versions), got {value!r}"
        )
    return int(value)


def random_tumble(rng: np.random.Generator, max_spin: float) -> tuple[FloatArray, FloatArray]:
    """Orientation uniform on SO(3) and body angular velocity (3,) of magnitude uniform on
    [0, ``max_spin``] about a uniform direction; drawn in that order."""
    q = random_quaternion(rng)
    # max_spin * random() is rng.uniform(0, max_spin) bit for bit (0 + range * u), without
    # its argument handling: resets of thousands of envs draw this in a Python loop
    return q, (max_spin * rng.random()) * random_unit_vectors(rng)


class TaskBatch:
    """A task on ``num_envs`` bodies: reset distribution, observation, reward, episode end.

    A task subclass sets :attr:`scene_name` and its observation sizes, implements
    :meth:`sample` (one env's initial state and target from its generator) and
    :meth:`task_numbers`, and names its compiled pass (:attr:`task_pass`: the generic
    :func:`~rigid_env.envs.kernels.task_pass` with the task's per-env ``evaluate``).
    Everything else (actions, thrusters, fuel, randomisation, spaces, buffers) lives here.

    Args:
        num_envs: number of bodies ``N``.
        scene: path or dict of a scene file to use instead of the task's default.
        integrator, dt, substeps: overrides of the scene's values.
        rotation_repr: ``"quaternion"`` (canonical, 4 numbers) or ``"sixd"`` (first two columns
            of the rotation matrix, 6 numbers).
        randomization: domain randomisation (a :class:`Randomization` or a dict of its fields).
    """

    scene_name: ClassVar[str]
    task_obs_dim: int = 0  # a task may set it per instance (per version)
    task_obs_bound: ClassVar[float] = 1.0
    target_dim: ClassVar[int] = 0
    task_pass: ClassVar[Callable[..., None]]
    task_pass_threads: ClassVar[Callable[..., None] | None] = None
    """The pass over Numba's threads from 1,024 envs on (optional: None runs ``task_pass``)."""
    version: int = 0
    """The task's version (the ``-vK`` of its id); a task with several takes ``version=``."""

    def __init__(
        self,
        num_envs: int,
        *,
        scene: str | os.PathLike[str] | dict[str, Any] | None = None,
        integrator: str | None = None,
        dt: float | None = None,
        substeps: int | None = None,
        rotation_repr: str = "quaternion",
        randomization: Randomization | dict[str, float] | None = None,
    ) -> None:
        if int(num_envs) != num_envs or num_envs < 1:
            raise ValueError(f"num_envs: must be an integer >= 1, got {num_envs}")
        if rotation_repr not in ("quaternion", "sixd"):
            raise ValueError(
                f"rotation_repr: must be 'quaternion' or 'sixd', got {rotation_repr!r}"
            )
        self.n = int(num_envs)
        self.scene: Scene = load_scene(
            scene if scene is not None else default_scene_path(self.scene_name)
        )
        self.world = self.scene.build_world(
            n=self.n, integrator=integrator, dt=dt, substeps=substeps, on_error="freeze"
        )
        if self.world.action_dim == 0:
            raise ValueError(
                "scene: a task needs actuators (thrusters or point_forces); the scene has none"
            )
        self.dt = self.world.dt
        self.rotation_repr = rotation_repr
        self.randomization = as_randomization(randomization)
        self.base_model = self.world.model
        # Per-component force at |u| = 1 [N], for the fuel measure.
        actuators = [e for e in self.world.force_effects if isinstance(e, LinearActuator)]
        self.max_force = np.concatenate([np.linalg.norm(a.force_map, axis=1) for a in actuators])
        self.action_dim = self.world.action_dim
        self.w_scale = self.angular_velocity_scale()
        rot_dim = 4 if rotation_repr == "quaternion" else 6
        self.obs_dim = rot_dim + 6 + self.task_obs_dim
        bound = np.concatenate(
            [
                np.ones(rot_dim),
                np.full(3, 5.0),
                np.ones(3),
                np.full(self.task_obs_dim, self.task_obs_bound),
            ]
        ).astype(np.float32)
        self.single_observation_space = spaces.Box(-bound, bound, dtype=np.float32)
        self.single_action_space = spaces.Box(-1.0, 1.0, shape=(self.action_dim,), dtype=np.float32)
        self.tp = self.task_parameters()
        """Task parameters of the compiled pass (:mod:`rigid_env.envs.kernels`)."""
        n, a = self.n, self.action_dim
        self.steps = np.zeros(n, dtype=np.int64)
        self.target = np.zeros((n, T.TARGET_WIDTH))
        """(N, 4) each env's target (its first ``target_dim`` numbers used)."""
        self.thrust_scale: FloatArray | None = None
        """(N, A) strength of each actuator relative to the scene's, once thrust is randomised
        (None before: every actuator as in the scene)."""
        self.last_action = np.zeros((n, a))
        """(N, A) the last command each env was sent, clipped (before thrust randomisation)."""
        self.command = self.last_action
        """(N, A) the last command the bodies got: :attr:`last_action` itself until thrust is
        randomised, then ``last_action * thrust_scale``."""
        self.record = np.zeros((T.RECORD, n))
        """(RECORD, N) each env's reward, flags, info numbers, fuel and task memory (a column
        per env, the rows named in :mod:`rigid_env.envs.kernels`), written by the compiled
        pass."""
        self.obs = np.zeros((n, self.obs_dim), dtype=np.float32)
        """(N, obs_dim) the latest observations (overwritten by every step and reset, unless
        :meth:`observe` gave them away: then a new buffer is written)."""
        self._obs_given = False
        self._no_noise = np.zeros((1, 3))
        self._sigma = self.randomization.sensor_noise

    # ---- task interface ------------------------------------------------------------------
    def angular_velocity_scale(self) -> float:
        """Typical angular speed [rad/s] that the observation divides by."""
        raise NotImplementedError

    def sample(self, rng: np.random.Generator) -> tuple[FloatArray, ...]:
        """One env's initial ``(x (3,), v (3,), q (4,), w_body (3,), target (target_dim,))``."""
        raise NotImplementedError

    def task_numbers(self) -> list[float]:
        """The task's own parameters, from :data:`rigid_env.envs.kernels.TASK` on (in the
        order its ``evaluate`` reads them)."""
        return []

    def task_parameters(self) -> FloatArray:
        """The float64 array of task parameters: the common header, :meth:`task_numbers` and
        each actuator's force at ``|u| = 1`` (the fuel weights)."""
        numbers = self.task_numbers()
        if len(numbers) > T.FMAX - T.TASK:
            raise ValueError(f"task_numbers: at most {T.FMAX - T.TASK}, got {len(numbers)}")
        tp = np.zeros(T.FMAX + self.action_dim)
        tp[T.DT] = self.dt
        tp[T.W_SCALE] = self.w_scale
        tp[T.SIXD] = 1.0 if self.rotation_repr == "sixd" else 0.0
        tp[T.EXTRA_BOUND] = self.task_obs_bound
        tp[T.FUEL_WEIGHT] = getattr(self, "fuel_weight", 0.0)
        tp[T.TASK : T.TASK + len(numbers)] = numbers
        tp[T.FMAX :] = self.max_force
        return tp

    # ---- shared machinery ----------------------------------------------------------------
    @property
    def fuel(self) -> FloatArray:
        """(N,) impulse spent in the episode so far [N s] (a view of :attr:`record`)."""
        return self.record[T.FUEL]

    @property
    def success(self) -> NDArray[np.bool_]:
        """(N,) whether each env's task counts as solved at the current step."""
        return self.record[T.SUCCESS] != 0.0

    def angular_speed(self) -> FloatArray:
        """(N,) ``|w|`` [rad/s] of the current state (finite for a frozen, diverged body)."""
        return self.record[T.SPEED].copy()

    def check_action(self, action: ArrayLike) -> FloatArray:
        """Validate and clip a command to (N, A) in [-1, 1] (into :attr:`last_action`; the
        bodies' command, thrust randomisation included, into :attr:`command`).

        Raises:
            ValueError: wrong shape, or a NaN/inf entry (never silently simulated).
        """
        act = action if isinstance(action, np.ndarray) else np.asarray(action)
        if act.dtype.kind not in "fiu":
            raise ValueError(
                f"action: expected real numbers (float32 or float64), got dtype {act.dtype}"
            )
        if act.shape != (self.n, self.action_dim):
            if self.n == 1 and act.shape == (self.action_dim,):
                act = act.reshape(1, -1)
            else:
                raise ValueError(
                    f"action: expected shape ({self.n}, {self.action_dim})"
                    f"{' or (' + str(self.action_dim) + ',)' if self.n == 1 else ''}, "
                    f"got {act.shape}"
                )
        if T.clip_commands(np.ascontiguousarray(act), self.last_action) < 0:
            raise ValueError(_NON_FINITE_ACTION)
        if self.thrust_scale is not None:
            np.multiply(self.last_action, self.thrust_scale, out=self.command)
        return self.last_action

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
        failed = self.world.advance(self.command)
        self.steps += 1
        self._own_obs(keep=False)
        noise = self._no_noise if self._sigma <= 0.0 else self._noise(rngs, restarting)
        self._pass(self.world.columns, self.world.model_columns, self.command, self.target, noise,
                   True, self.record, self.obs)  # fmt: skip
        r = self.record
        return r[T.REWARD], r[T.TERMINATED] != 0.0, failed

    def step_one(self, rng: np.random.Generator) -> tuple[list[float], bool]:
        """:meth:`step` of a task of one env: its record (:data:`rigid_env.envs.kernels`
        columns) as floats, and whether its body failed."""
        failed = self.world.advance(self.command)
        self.steps[0] += 1
        self._own_obs(keep=False)
        noise = self._no_noise if self._sigma <= 0.0 else self._noise([rng])
        self._pass(self.world.columns, self.world.model_columns, self.command, self.target, noise,
                   True, self.record, self.obs)  # fmt: skip
        return self.record[:, 0].tolist(), failed is not self.world.no_failures

    def _pass(self, cols, model, command, target, noise, stepped, record, obs) -> None:
        """The task's compiled pass over the envs of the state and model columns ``cols``,
        ``model`` (split over the cores when many; each env is computed alone, so the split
        changes no number)."""
        args = (self.tp, cols, model, command, target, noise, stepped, record, obs, 0)
        n = cols.shape[1]
        threads = self.task_pass_threads
        if threads is None or not core_world.threaded(n):
            self.task_pass(*args, n)
        else:
            core_world.call_threaded(lambda t: threads(*args, n, t))

    def _own_obs(self, keep: bool) -> None:
        """If :meth:`observe` gave :attr:`obs` away, write into a new buffer from now on (with
        the same rows if ``keep``, for a reset of some envs): what a caller got stays as it
        was, with no copy per step."""
        if self._obs_given:
            self.obs = self.obs.copy() if keep else np.empty_like(self.obs)
            self._obs_given = False

    def _noise(
        self, rngs: Sequence[np.random.Generator], skip: NDArray[np.bool_] | None = None
    ) -> FloatArray:
        """(K, 3) sensor noise on the observed ``w`` [rad/s], one row per generator (zeros,
        nothing drawn, where ``skip``); one shared zero row when there is no noise."""
        sigma = self.randomization.sensor_noise
        if sigma <= 0.0:
            return self._no_noise
        if skip is None or not skip.any():
            return np.stack([rng.normal(0.0, sigma, 3) for rng in rngs])
        return np.stack(
            [
                np.zeros(3) if s else rng.normal(0.0, sigma, 3)
                for rng, s in zip(rngs, skip.tolist(), strict=True)
            ]
        )

    def reset_envs(
        self, idx: Sequence[int] | NDArray[np.int64], rngs: Sequence[np.random.Generator]
    ) -> None:
        """Start new episodes for envs ``idx``, each drawing from ``rngs[k]`` (one per index),
        and observe them (:attr:`obs` rows ``idx``; sensor noise from the same generators)."""
        idx = np.asarray(idx, dtype=np.int64)
        s = self.world.state
        draws = []
        randomized = self.randomization.physical or self.randomization.thrust > 0.0
        for k, i in enumerate(idx.tolist()):
            draws.append(self.sample(rngs[k]))
            if randomized:
                self._randomize(i, rngs[k])
        if draws:
            x, v, q, w, target = (np.array(c) for c in zip(*draws, strict=True))
            s.x[idx], s.v[idx], s.q[idx], s.w[idx] = x, v, q, w
            if self.target_dim:
                self.target[idx, : self.target_dim] = target
        self.steps[idx] = 0
        self.record[:, idx] = 0.0
        self.last_action[idx] = 0.0
        self.command[idx] = 0.0
        self.world.failed[idx] = False
        if idx.size == 0:
            return
        self._own_obs(keep=True)  # rows idx are written below, the others kept
        record, obs = np.ascontiguousarray(self.record[:, idx]), self.obs[idx]
        cols = np.ascontiguousarray(self.world.columns[:, idx])
        model = np.ascontiguousarray(self.world.model_columns[:, idx])
        noise = self._noise(rngs)
        self._pass(cols, model, self.command[idx], self.target[idx], noise, False, record, obs)
        self.record[:, idx], self.obs[idx] = record, obs

    def _randomize(self, i: int, rng: np.random.Generator) -> None:
        r = self.randomization
        if r.physical:
            if self.world.model.n == 1:  # first randomised reset: give every body its own copy
                self.world.set_model(
                    BodyModel(
                        np.repeat(self.base_model.mass, self.n),
                        np.repeat(self.base_model.inertia, self.n, axis=0),
                    )
                )
            m0 = self.base_model.mass[0]
            i0 = self.base_model.inertia[0]
            mass = m0 * rng.uniform(1.0 - r.mass, 1.0 + r.mass) if r.mass > 0 else m0
            inertia = (
                i0 * rng.uniform(1.0 - r.inertia, 1.0 + r.inertia, size=3)
                if r.inertia > 0
                else i0.copy()
            )
            # Keep I_max <= I_a + I_b (a physical body), clipping the largest moment.
            k = int(np.argmax(inertia))
            inertia[k] = min(inertia[k], inertia.sum() - inertia[k])
            model = self.world.model
            model.mass[i] = mass
            model.inertia[i] = inertia
            self.world.set_model(BodyModel(model.mass, model.inertia))
        if r.thrust > 0.0:
            if self.thrust_scale is None:  # first randomised reset: scales, and a command apart
                self.thrust_scale = np.ones((self.n, self.action_dim))
                self.command = self.last_action * self.thrust_scale
            self.thrust_scale[i] = rng.uniform(1.0 - r.thrust, 1.0 + r.thrust, size=self.action_dim)

    def observe(self, idx: NDArray[np.int64] | None = None) -> NDArray[np.float32]:
        """The latest observations, the caller's to keep: (N, obs_dim) (the buffer itself,
        which no later step or reset writes into), or a copy of the rows ``idx``."""
        if idx is not None:
            return self.obs[idx]
        self._obs_given = True
        return self.obs

    def infos(self) -> dict[str, NDArray[Any]]:
        """Per-env diagnostics (copies): angular speed, energy, fuel, success, failure."""
        r = self.record
        success = r[T.SUCCESS] != 0.0
        return {
            "angular_speed": r[T.SPEED].copy(),
            "energy": r[T.ENERGY].copy(),
            "fuel": r[T.FUEL].copy(),
            "success": success,
            "is_success": success.copy(),  # SB3 EvalCallback logs this key
            "numerical_error": self.world.failed.copy(),
            # (N, 3) in the record's order (each component contiguous): a plain copy, ~8x
            # cheaper than a transposing one at 4,096 envs
            "angular_velocity_world": r[T.W_WORLD : T.W_WORLD + 3].T.copy(order="K"),
        }

    def info_one(self, r: list[float] | None = None) -> dict[str, Any]:
        """:meth:`infos` of env 0 as Python scalars (what a single env returns), from its
        record as floats (read here if not given)."""
        r = self.record[:, 0].tolist() if r is None else r
        success = r[T.SUCCESS] != 0.0
        return {
            "angular_speed": r[T.SPEED],
            "energy": r[T.ENERGY],
            "fuel": r[T.FUEL],
            "success": success,
            "is_success": success,
            "numerical_error": bool(self.world.failed[0]),
            "angular_velocity_world": np.array(r[T.W_WORLD : T.W_WORLD + 3]),
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

    def frame(self, i: int = 0) -> Frame:
        """The numbers of env ``i``'s current frame."""
        if not 0 <= i < self.n:
            raise IndexError(f"i: environment index {i} is out of range for {self.n} envs")
        s = self.world.state
        return Frame(
            q=s.q[i].copy(),
            w_body=s.w[i].copy(),
            height=float(s.x[i, 2]),
            command=self.last_action[i].copy(),
            step=int(self.steps[i]),
            angular_speed=float(self.angular_speed()[i]),
            fuel=float(self.fuel[i]),
            success=bool(self.success[i]),
            target=self.target[i].copy() if self.target_dim else None,
            readouts=self.readouts(i),
        )


_NON_FINITE_ACTION = "action: contains NaN or inf; send finite thruster commands in [-1, 1]"


def _masked(value: NDArray[Any], mask: NDArray[np.bool_]) -> NDArray[Any]:
    """(N, ...) ``value`` with the rows outside ``mask`` set to 0 (False for bools)."""
    out = np.zeros_like(value)
    out[mask] = value[mask]
    return out


class RigidBodyEnv(gym.Env[NDArray[np.float32], NDArray[np.float32]]):
    """Base of the single environments: a :class:`TaskBatch` of one body.

    Keyword arguments go to the task (see its class); ``render_mode`` is ``None``,
    ``"rgb_array"`` or ``"human"``.
    """

    task_cls: ClassVar[type[TaskBatch]]
    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array", "human"], "render_fps": 20}

    def __init__(self, render_mode: str | None = None, **kwargs: Any) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode: {render_mode!r} is not one of {self.metadata['render_modes']}"
            )
        self.task = self.task_cls(1, **kwargs)
        self.observation_space = self.task.single_observation_space
        self.action_space = self.task.single_action_space
        self.metadata = {**self.metadata, "render_fps": max(1, round(1.0 / self.task.dt))}
        self.render_mode = render_mode
        self._renderer: Any = None
        self._has_reset = False

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """Start an episode; ``seed`` reseeds :attr:`np_random`."""
        super().reset(seed=seed)
        self.task.reset_envs([0], [self.np_random])
        self._rngs = [self.np_random]
        self._has_reset = True
        if self.render_mode == "human":
            self.render()
        return self.task.obs[0].copy(), self.task.info_one()

    def step(self, action: ArrayLike):
        """One control step of ``dt``; see the task class for reward and episode end."""
        if not self._has_reset:
            raise RuntimeError("Call reset before using step method.")
        task = self.task
        task.check_action(action)
        r, failed = task.step_one(self._rngs[0])
        info = task.info_one(r)
        if self.render_mode == "human":
            self.render()
        return task.obs[0].copy(), r[T.REWARD], r[T.TERMINATED] != 0.0, failed, info

    def render(self):
        """An RGB frame (H, W, 3) uint8 in ``"rgb_array"`` mode; draws a window in ``"human"``."""
        if self.render_mode is None:
            gym.logger.warn(
                "render: no render_mode was given; pass render_mode='rgb_array' to gym.make"
            )
            return None
        if self._renderer is None:
            self._renderer = TaskRenderer(
                self.task.view(), mode=self.render_mode, fps=self.metadata["render_fps"]
            )
        return self._renderer.render(self.task.frame(0))

    def close(self) -> None:
        """Close the window, if any."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


class RigidBodyVectorEnv(VectorEnv):
    """Base of the native vector environments: all ``num_envs`` bodies in one NumPy call.

    Autoreset mode ``NEXT_STEP``: an env that terminates or truncates in one ``step`` is reset
    by the next ``step`` (its action then is ignored, its reward is 0, and the returned
    observation is the first of the new episode).

    Args:
        num_envs: number of sub-environments.
        max_episode_steps: truncation length (given by ``gym.make_vec`` from the registry).
        render_mode: ``None`` or ``"rgb_array"`` (renders sub-environment 0).
        **kwargs: passed to the task (see the single env's class).
    """

    task_cls: ClassVar[type[TaskBatch]]
    metadata: ClassVar[dict[str, Any]] = {
        "render_modes": ["rgb_array"],
        "render_fps": 20,
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }

    def __init__(
        self,
        num_envs: int = 1,
        max_episode_steps: int | None = None,
        render_mode: str | None = None,
        **kwargs: Any,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode: {render_mode!r} is not one of {self.metadata['render_modes']} "
                "(a vector env renders sub-environment 0 as an RGB array)"
            )
        self.task = self.task_cls(num_envs, **kwargs)
        self.num_envs = self.task.n
        self.max_episode_steps = max_episode_steps
        self.single_observation_space = self.task.single_observation_space
        self.single_action_space = self.task.single_action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.metadata = {**self.metadata, "render_fps": max(1, round(1.0 / self.task.dt))}
        self.render_mode = render_mode
        self._renderer: Any = None
        self._rngs: list[np.random.Generator] = []
        self._autoreset = np.zeros(self.num_envs, dtype=bool)

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ):
        """Reset every sub-environment, or only those of ``options["reset_mask"]``.

        An int ``seed`` seeds sub-env ``i`` with ``seed + i``, a list with ``seed[i]``; None
        continues each env's generator. With a ``reset_mask`` ((N,) bool array, at least one
        True; Gymnasium's ``SyncVectorEnv`` semantics) only the masked envs are reset (and
        seeded); the others keep their state, generator and pending autoreset, their rows of
        the observation are those last returned, and the infos hold the masked envs only
        (``info["_key"]`` is the mask, the other entries 0).
        """
        super().reset(seed=seed if isinstance(seed, int) else None)
        if seed is None:
            seeds: list[int | None] = [None] * self.num_envs
        elif isinstance(seed, int):
            seeds = [seed + i for i in range(self.num_envs)]
        else:
            if len(seed) != self.num_envs:
                raise ValueError(f"seed: expected {self.num_envs} seeds, got {len(seed)}")
            seeds = list(seed)
        mask = self._reset_mask(options)
        if mask is not None:
            return self._reset_masked(mask, seeds)
        if not self._rngs or seed is not None:
            self._rngs = [seeding.np_random(s)[0] for s in seeds]
        self.task.reset_envs(np.arange(self.num_envs), self._rngs)
        self._autoreset[:] = False
        return self.task.observe(), self._vector_info(self.task.infos())

    def _reset_mask(self, options: dict[str, Any] | None) -> NDArray[np.bool_] | None:
        """``options["reset_mask"]`` checked as ``SyncVectorEnv`` checks it (same errors)."""
        if options is None or "reset_mask" not in options:
            return None
        mask = options["reset_mask"]
        key = "options['reset_mask']"
        if not isinstance(mask, np.ndarray):
            raise TypeError(f"{key}: must be a numpy array, got {type(mask).__name__}")
        if mask.shape != (self.num_envs,):
            raise ValueError(f"{key}: must have shape ({self.num_envs},), got {mask.shape}")
        if mask.dtype != np.bool_:
            raise TypeError(f"{key}: must have dtype bool, got {mask.dtype}")
        if not mask.any():
            raise ValueError(f"{key}: must have at least one True entry (the envs to reset)")
        if not self._rngs:
            raise ValueError(f"{key}: reset every sub-environment first (reset without a mask)")
        return mask

    def _reset_masked(self, mask: NDArray[np.bool_], seeds: list[int | None]):
        """:meth:`reset` of the envs in ``mask`` only (the other rows of the observation are
        the ones last returned: the task's observation buffer keeps them)."""
        idx = np.flatnonzero(mask)
        for i in idx:
            if seeds[i] is not None:
                self._rngs[i] = seeding.np_random(seeds[i])[0]
        self.task.reset_envs(idx, [self._rngs[i] for i in idx])
        self._autoreset[idx] = False
        return self.task.observe(), self._vector_info(self.task.infos(), mask)

    def step(self, actions: ArrayLike):
        """Step all sub-environments; see the class docstring for autoreset."""
        if not self._rngs:
            raise RuntimeError("Call reset before using step method.")
        self.task.check_action(actions)
        reward, terminated, failed = self.task.step(self._rngs, self._autoreset)
        reward = reward.copy()
        truncated = failed.copy()
        if self.max_episode_steps is not None:
            truncated |= self.task.steps >= self.max_episode_steps
        restarting = self._autoreset
        if restarting.any():
            idx = np.flatnonzero(restarting)
            self.task.reset_envs(idx, [self._rngs[i] for i in idx])
            reward[idx] = 0.0
            terminated[idx] = False
            truncated[idx] = False
        self._autoreset = terminated | truncated
        obs = self.task.observe()
        return obs, reward, terminated, truncated, self._vector_info(self.task.infos())

    def _vector_info(
        self, info: dict[str, NDArray[Any]], mask: NDArray[np.bool_] | None = None
    ) -> dict[str, Any]:
        """Gymnasium's vector infos: each key with its ``_key`` mask (all envs, or ``mask``
        with the other entries set to 0, as ``SyncVectorEnv`` leaves them)."""
        out: dict[str, Any] = {}
        if mask is None:
            mask = np.ones(self.num_envs, dtype=bool)
        else:
            info = {k: _masked(v, mask) for k, v in info.items()}
        for k, v in info.items():
            out[k] = v
            out[f"_{k}"] = mask
        return out

    def render(self):
        """RGB frame of sub-environment 0."""
        if self.render_mode is None:
            return None
        if self._renderer is None:
            self._renderer = TaskRenderer(
                self.task.view(), mode=self.render_mode, fps=self.metadata["render_fps"]
            )
        return self._renderer.render(self.task.frame(0))

    def close_extras(self, **kwargs: Any) -> None:
        """Close the renderer."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
