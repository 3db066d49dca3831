"""The task layer shared by every environment, written once for a batch of ``N`` bodies.

:class:`TaskBatch` owns a :class:`~rigid_env.core.world.World` of ``N`` bodies and a task's reset
distribution, observation, reward and episode end. :class:`RigidBodyEnv` (a ``gymnasium.Env``)
is the ``N = 1`` case of it and :class:`RigidBodyVectorEnv` (a native
``gymnasium.vector.VectorEnv``) the ``N`` case: there is no second copy of the physics.

Randomness comes only from per-environment generators (``np_random`` of the single env; one
generator per sub-environment, seeded ``seed + i``, in the vector env), so sub-environment ``i``
of a vector env reset with ``seed`` replays a single env reset with ``seed + i`` bit for bit.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
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

from rigid_env.core.columns import ARRAY, SCALAR, Ops, norm, rotate
from rigid_env.core.columns import kinetic_energy as kinetic_energy_columns
from rigid_env.core.effects import LinearActuator
from rigid_env.core.rotation import canonical, quat_to_sixd
from rigid_env.core.state import BodyModel
from rigid_env.core.world import kinetic_energy
from rigid_env.envs.rewards import fuel_rate, weighted_sum
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


def positive(name: str, value: float, unit: str) -> float:
    """``value`` as a float, or a one-line ``ValueError`` naming the argument."""
    if not (np.isfinite(value) and value > 0.0):
        raise ValueError(f"{name}: must be a finite number > 0 [{unit}], got {value}")
    return float(value)


def random_tumble(rng: np.random.Generator, max_spin: float) -> tuple[FloatArray, FloatArray]:
    """Orientation uniform on SO(3) and body angular velocity (3,) of magnitude uniform on
    [0, ``max_spin``] about a uniform direction; drawn in that order."""
    q = random_quaternion(rng)
    return q, rng.uniform(0.0, max_spin) * random_unit_vectors(rng)


class TaskBatch:
    """A task on ``num_envs`` bodies: reset distribution, observation, reward, episode end.

    Subclasses set :attr:`scene_name` and implement :meth:`sample` (one env's initial state and
    target from its generator), :meth:`task_observation`, :meth:`evaluate` and the extra
    observation bounds. Everything else (actions, thrusters, counters, randomisation, spaces)
    lives here.

    Args:
        num_envs: number of bodies ``N``.
        scene: path or dict of a scene file to use instead of the task's default.
        integrator, dt, substeps: overrides of the scene's values.
        rotation_repr: ``"quaternion"`` (canonical, 4 numbers) or ``"sixd"`` (first two columns
            of the rotation matrix, 6 numbers).
        randomization: domain randomisation (a :class:`Randomization` or a dict of its fields).
    """

    scene_name: ClassVar[str]
    task_obs_dim: ClassVar[int] = 0
    task_obs_bound: ClassVar[float] = 1.0

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
        self.ops: Ops = SCALAR if self.n == 1 else ARRAY
        """Backend of the per-env columns: Python floats for one env, (N,) arrays for a batch."""
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
        if isinstance(randomization, dict):
            randomization = Randomization(**randomization)
        self.randomization = randomization or Randomization()
        self.base_model = self.world.model
        # Per-component force at |u| = 1 [N], for the fuel measure.
        actuators = [e for e in self.world.force_effects if isinstance(e, LinearActuator)]
        self.max_force = np.concatenate([np.linalg.norm(a.force_map, axis=1) for a in actuators])
        self._max_force = self.max_force.tolist()  # the fuel sum's weights, as floats
        self.action_dim = self.world.action_dim
        self.thrust_scale: FloatArray | None = None  # (N, A) when thrust is randomised
        self.steps = np.zeros(self.n, dtype=np.int64)
        self._speed_of: object = None
        self._speed = np.zeros(self.n)
        self.fuel = np.zeros(self.n)
        self.effort: Any = 0.0 if self.n == 1 else np.zeros(self.n)
        """Mean ``|u_k|`` of the last command, the fuel term of the rewards: a float for one
        env, (N,) for a batch (as :meth:`speed`)."""
        self.success = np.zeros(self.n, dtype=bool)
        self._last_finite: dict[str, Any] = {}  # per float diagnostic, see keep_finite
        self._last_action = np.zeros((self.n, self.action_dim))
        self._last_one: list[float] | None = None  # a single env's last command, not yet stored
        self.target = np.zeros((self.n, self.target_dim))
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

    # ---- task interface ------------------------------------------------------------------
    target_dim: ClassVar[int] = 0

    def angular_velocity_scale(self) -> float:
        """Typical angular speed [rad/s] that the observation divides by."""
        raise NotImplementedError

    def sample(self, rng: np.random.Generator) -> tuple[FloatArray, ...]:
        """One env's initial ``(x (3,), v (3,), q (4,), w_body (3,), target (target_dim,))``."""
        raise NotImplementedError

    def task_columns(self) -> list[Any]:
        """The ``task_obs_dim`` extra observation components as columns: floats for one env,
        (N,) arrays for a batch (clipped into ``+-task_obs_bound`` by the observation)."""
        return []

    def task_observation(self) -> FloatArray:
        """(N, task_obs_dim) extra observation components (:meth:`task_columns`)."""
        cols = self.task_columns()
        out = np.empty((self.n, len(cols)))
        for k, c in enumerate(cols):
            out[:, k] = c
        return out

    def evaluate(self, action: Any) -> tuple[Any, Any, Any]:
        """``(reward, terminated, success)`` after a step: (N,) arrays for a batch; for one
        env floats and bools where the task computes on :meth:`speed`, :meth:`state_columns`
        and :attr:`effort` (which are floats then), else (1,) arrays. ``action`` is the command
        the bodies got (thrust randomisation included)."""
        raise NotImplementedError

    # ---- shared machinery ----------------------------------------------------------------
    def check_action(self, action: ArrayLike) -> FloatArray:
        """Validate and clip a command to (N, A) in [-1, 1].

        Raises:
            ValueError: wrong shape, or a NaN/inf entry (never silently simulated).
        """
        if self.n == 1:
            return np.array([self.check_one(action)])
        act = self._command_array(action)
        # One sum finds a NaN or inf; only a sum that overflowed needs the element-wise test.
        with np.errstate(over="ignore", invalid="ignore"):
            total = act.sum()
        if not np.isfinite(total) and not np.isfinite(act).all():
            raise ValueError(_NON_FINITE_ACTION)
        # Huge finite commands saturate like a real thruster: clipped to [-1, 1] (clipping is
        # exact, so clipping float32 into float64 equals converting first).
        # Column-major: the physics reads the command column by column.
        return np.clip(act, -1.0, 1.0, out=np.empty(act.shape, order="F"))

    def check_one(self, action: ArrayLike) -> list[float]:
        """:meth:`check_action` of a task of one body, as ``A`` floats (no NumPy call for six
        numbers; the same clipped values)."""
        act = np.asarray(action)
        if act.shape == (self.action_dim,) and act.dtype.char in "fd":
            values = act.tolist()  # the common case: one float vector
        else:
            values = self._command_array(action)[0].tolist()
        if not all(map(math.isfinite, values)):
            raise ValueError(_NON_FINITE_ACTION)
        return [-1.0 if c < -1.0 else 1.0 if c > 1.0 else float(c) for c in values]

    def _command_array(self, action: ArrayLike) -> NDArray[np.floating]:
        """``action`` as a float (N, A) array, or a one-line error naming the shapes."""
        act = np.asarray(action)
        if act.dtype not in (np.float32, np.float64):
            act = act.astype(np.float64)
        if act.shape == (self.action_dim,) and self.n == 1:
            act = act[None, :]
        if act.shape != (self.n, self.action_dim):
            raise ValueError(
                f"action: expected shape ({self.n}, {self.action_dim})"
                f"{' or (' + str(self.action_dim) + ',)' if self.n == 1 else ''}, "
                f"got {act.shape}"
            )
        return act

    def reset_envs(
        self, idx: Sequence[int] | NDArray[np.int64], rngs: Sequence[np.random.Generator]
    ) -> None:
        """Start new episodes for envs ``idx``, each drawing from ``rngs[k]`` (one per index)."""
        s = self.world.state
        draws = []
        for k, i in enumerate(idx):
            draws.append(self.sample(rngs[k]))
            self._randomize(i, rngs[k])
        if draws:
            x, v, q, w, target = (np.array(c) for c in zip(*draws, strict=True))
            s.x[idx], s.v[idx], s.q[idx], s.w[idx] = x, v, q, w
            if self.target_dim:
                self.target[idx] = target
        self._speed_of = None  # the state was changed in place
        self.steps[idx] = 0
        self.fuel[idx] = 0.0
        self.success[idx] = False
        self.last_action[idx] = 0.0
        self.world.failed[idx] = False
        self.on_reset(np.asarray(idx))

    def on_reset(self, idx: NDArray[np.int64]) -> None:
        """Hook for task counters after :meth:`reset_envs`."""

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
            if self.thrust_scale is None:
                self.thrust_scale = np.ones((self.n, self.action_dim))
            self.thrust_scale[i] = rng.uniform(1.0 - r.thrust, 1.0 + r.thrust, size=self.action_dim)

    def step(self, action: FloatArray) -> tuple[FloatArray, NDArray[np.bool_], NDArray[np.bool_]]:
        """Advance every body by ``dt`` with a checked command (N, A).

        Returns:
            reward (N,), terminated (N,), failed (N,) (state turned non-finite this step; the
            body is frozen at its last finite state and the episode must end).
        """
        if self.n == 1:
            reward, terminated, failed = self.step_one(action[0].tolist())
            return np.array([reward]), np.array([terminated]), np.array([failed])
        command = action if self.thrust_scale is None else action * self.thrust_scale
        failed = self.world.advance(command)
        self.steps += 1
        self._account([command[:, k] for k in range(self.action_dim)])
        self.last_action = action
        reward, terminated, success = self.evaluate(command)
        self.success = np.array(success, dtype=bool)  # its own copy: terminated is edited
        return reward, np.array(terminated, dtype=bool), failed

    def step_one(self, u: list[float]) -> tuple[float, bool, bool]:
        """:meth:`step` of a task of one body on floats: ``u`` is the checked command (``A``
        floats in [-1, 1], :meth:`check_one`); returns ``(reward, terminated, failed)``. The
        same operations as a batch's row, so the same numbers bit for bit."""
        command = u
        if self.thrust_scale is not None:
            command = [c * s for c, s in zip(u, self.thrust_scale[0].tolist(), strict=True)]
        world = self.world
        if world.single_body_lane:
            failed = world.advance_one(command)
        else:
            failed = bool(world.advance(np.array([command]))[0])
        self.steps[0] += 1
        self._account(command)
        self._last_one = u
        reward, terminated, success = self.evaluate(command)
        if type(success) is bool:
            self.success[0] = success
        else:
            self.success[:] = success
        return _item(reward), bool(_item(terminated)), failed

    @property
    def last_action(self) -> FloatArray:
        """(N, A) the last command each env was sent (before thrust randomisation)."""
        if self._last_one is not None:
            self._last_action[0] = self._last_one
            self._last_one = None
        return self._last_action

    @last_action.setter
    def last_action(self, action: FloatArray) -> None:
        self._last_action = action
        self._last_one = None

    def _account(self, cols: Sequence[Any]) -> None:
        """Fuel and effort of a command given as columns (floats for one env)."""
        magnitude = [abs(c) for c in cols]
        rate = fuel_rate(magnitude, self._max_force) * self.dt
        if self.n == 1:
            self.fuel[0] += rate
        else:
            self.fuel += rate
        self.effort = weighted_sum(magnitude) / self.action_dim

    def observe(
        self, rngs: Sequence[np.random.Generator], idx: NDArray[np.int64] | None = None
    ) -> NDArray[np.float32]:
        """(N, obs_dim) float32 observation, clipped into the observation space.

        Args:
            rngs: one generator per env (``idx=None``) or per entry of ``idx``; drawn from only
                when sensor noise is on.
            idx: observe only these envs (rows in that order); None = all.
        """
        s = self.world.state
        q, w = (s.q, s.w) if idx is None else (s.q[idx], s.w[idx])
        if self.randomization.sensor_noise > 0.0:
            noise = np.stack([rng.normal(0.0, self.randomization.sensor_noise, 3) for rng in rngs])
            w = w + noise
        # Built component by component (one contiguous float32 row each: about twice as fast
        # as writing strided column blocks), then laid out as (n, obs_dim).
        rows = np.empty((self.obs_dim, q.shape[0]), dtype=np.float32)
        r = 4 if self.rotation_repr == "quaternion" else 6
        if r == 4:
            _canonical_rows(q, rows[:4])
        else:
            rows[:6] = quat_to_sixd(q).T
        with np.errstate(over="ignore"):  # a frozen, diverged body: huge, then clipped
            for k in range(3):
                wk = w[:, k]
                np.clip(wk / self.w_scale, -5.0, 5.0, out=rows[r + k], casting="same_kind")
                # tanh(w / 0.1 rad/s) in float32 (the observation's precision; NumPy's float32
                # tanh is many times cheaper than its float64 one).
                np.tanh((wk / 0.1).astype(np.float32), out=rows[r + 3 + k])
        if self.task_obs_dim:
            extra = self.task_observation()
            bound = self.task_obs_bound
            extra = extra if idx is None else extra[idx]
            np.clip(extra.T, -bound, bound, out=rows[r + 6 :], casting="same_kind")
        # Rotation entries and tanh lie in [-1, 1] by construction (a unit vector's component
        # may exceed 1 by one rounding in float64, which float32 rounds back to 1).
        return np.ascontiguousarray(rows.T)

    def _columns(self, a: FloatArray) -> tuple[Ops, list[Any]]:
        """The columns of an (N, k) array with their backend: Python floats for one env (no
        NumPy call per operation), (N,) arrays for a batch; the same sums either way."""
        if self.n == 1:
            return self.ops, a[0].tolist()
        return self.ops, [a[:, k] for k in range(a.shape[1])]

    def observe_one(self, rng: np.random.Generator) -> NDArray[np.float32]:
        """(obs_dim,) observation of a task of one body: :meth:`observe` computed on floats,
        the same operations in the same order (bit-identical), at a fraction of the cost."""
        if self.randomization.sensor_noise > 0.0 or self.rotation_repr != "quaternion":
            return self.observe([rng])[0]
        qw, qx, qy, qz, wx, wy, wz = self.world.one_body_values()[6:13]
        if qw < 0.0:
            qw, qx, qy, qz = -qw, -qx, -qy, -qz
        elif qw == 0.0:
            qw, qx, qy, qz = canonical(self.world.state.q[0]).tolist()
        scale = self.w_scale
        fx, fy, fz = wx / 0.1, wy / 0.1, wz / 0.1  # tanh of these in float32, below
        values = [
            qw,
            qx,
            qy,
            qz,
            min(5.0, max(-5.0, wx / scale)),
            min(5.0, max(-5.0, wy / scale)),
            min(5.0, max(-5.0, wz / scale)),
            fx,
            fy,
            fz,
        ]
        if self.task_obs_dim:
            bound = self.task_obs_bound
            values += [min(bound, max(-bound, float(c))) for c in self.task_columns()]
        if abs(fx) < 1.0e38 and abs(fy) < 1.0e38 and abs(fz) < 1.0e38:
            obs = np.array(values, dtype=np.float32)
        else:
            with np.errstate(over="ignore"):  # a frozen, diverged body: inf in float32, tanh 1
                obs = np.array(values, dtype=np.float32)
        fine = obs[7:10]
        np.tanh(fine, out=fine)
        return obs

    def info_one(self) -> dict[str, Any]:
        """:meth:`infos` of a task of one body as Python scalars, computed on floats (the same
        operations in the same order as the batch's)."""
        values = self.world.one_body_values()
        q, w = values[6:10], values[10:13]
        mass, inertia = self.world.dynamics.model_columns[:2]
        success = bool(self.success[0])
        speed = float(self.speed())
        energy = kinetic_energy_columns(mass, inertia, values[3:6], w)
        w_world = rotate(q, w)
        if not all(map(math.isfinite, (speed, energy, *w_world))):
            return _single_info(self.infos())  # keep_finite on the batch's arrays
        last = self._last_finite
        last["angular_speed"], last["energy"], last["angular_velocity_world"] = (
            speed,
            energy,
            w_world,
        )
        return {
            "angular_speed": speed,
            "energy": energy,
            "fuel": float(self.fuel[0]),
            "success": success,
            "is_success": success,
            "numerical_error": bool(self.world.failed[0]),
            "angular_velocity_world": np.array(w_world),
        }

    def speed(self) -> Any:
        """``|w|`` [rad/s] of the current state: a float for one env, (N,) for a batch
        (computed once per state)."""
        # Keyed by the state object (a batch) or the float sequence (one body) it came from.
        if self.n == 1:
            values = self.world.one_body_values()
            if self._speed_of is not values:
                self._speed = norm(SCALAR, values[10:13])
                self._speed_of = values
            return self._speed
        state = self.world.state
        if self._speed_of is not state:
            with np.errstate(over="ignore"):  # a frozen, diverged body may be huge: inf
                self._speed = norm(ARRAY, [state.w[:, k] for k in range(3)])
            self._speed_of = state
        return self._speed

    def angular_speed(self) -> FloatArray:
        """(N,) ``|w|`` [rad/s] of the current state."""
        return np.atleast_1d(self.speed())

    def state_columns(self, name: str) -> list[Any]:
        """The components of the state's ``x``, ``v``, ``q`` or ``w``: floats for one env,
        (N,) arrays for a batch."""
        if self.n == 1:
            start = _STATE_OFFSET[name]
            return list(self.world.one_body_values()[start : start + (4 if name == "q" else 3)])
        a = getattr(self.world.state, name)
        return [a[:, k] for k in range(a.shape[1])]

    def target_columns(self) -> list[Any]:
        """The components of :attr:`target`, as :meth:`state_columns`."""
        return self._columns(self.target)[1]

    def infos(self) -> dict[str, NDArray[Any]]:
        """Per-env diagnostics: angular speed, energy, fuel, success, episode step; every float
        finite (:meth:`keep_finite`)."""
        s = self.world.state
        with np.errstate(over="ignore"):
            energy = kinetic_energy(self.world.model, s)
        return self.keep_finite(
            {
                "angular_speed": self.angular_speed(),
                "energy": energy,
                "fuel": self.fuel.copy(),
                "success": self.success.copy(),
                "is_success": self.success.copy(),  # SB3 EvalCallback logs this key
                "numerical_error": self.world.failed.copy(),
                "angular_velocity_world": _stack3(
                    rotate([s.q[:, k] for k in range(4)], [s.w[:, k] for k in range(3)])
                ),
            }
        )

    def keep_finite(self, info: dict[str, NDArray[Any]]) -> dict[str, NDArray[Any]]:
        """``info`` with each env's overflowed float diagnostic (:data:`FINITE_INFO`) replaced by
        the last finite value reported for that env, in place.

        A body on its way to a numerical failure can have a finite state whose ``|w|^2`` or
        energy exceeds the largest double (1.8e308); the world then freezes it at that state
        (``numerical_error``). Its info repeats the last finite values instead of ``inf``, so
        loggers that average them stay finite (an env that never had a finite value reports the
        largest double).
        """
        last = self._last_finite
        for key in FINITE_INFO:
            value = info[key]
            ok = np.isfinite(value) if value.ndim == 1 else np.isfinite(value).all(axis=1)
            if not ok.all():
                before = last.get(key, np.finfo(np.float64).max)
                ok = ok if value.ndim == 1 else ok[:, None]
                info[key] = value = np.where(ok, value, before)
            last[key] = value
        return info


_NUMPY_VALUES = (np.ndarray, np.generic)
#: Float diagnostics of the infos, kept finite by :meth:`TaskBatch.keep_finite`.
FINITE_INFO = ("angular_speed", "energy", "angular_velocity_world")
_STATE_OFFSET = {"x": 0, "v": 3, "q": 6, "w": 10}
_NON_FINITE_ACTION = "action: contains NaN or inf; send finite thruster commands in [-1, 1]"


def _item(x: Any) -> Any:
    """A float or bool from a float, a bool, or a one-element array."""
    return x.item() if isinstance(x, _NUMPY_VALUES) else x


def _stack3(cols: Sequence[FloatArray]) -> FloatArray:
    out = np.empty((cols[0].shape[0], 3))
    for k in range(3):
        out[:, k] = cols[k]
    return out


def _canonical_rows(q: FloatArray, out: NDArray[np.float32]) -> None:
    """:func:`~rigid_env.core.rotation.canonical` of (N, 4) ``q`` into the rows of ``out``
    (4, N), sign-flipping by the ``w`` column alone where ``w != 0`` (every row but a
    measure-zero few)."""
    qw = q[:, 0]
    if not np.all(qw != 0.0):
        out[:] = canonical(q).T
        return
    sign = np.where(qw < 0.0, -1.0, 1.0)
    for k in range(4):
        np.multiply(q[:, k], sign, out=out[k], casting="same_kind")


def _masked(value: NDArray[Any], mask: NDArray[np.bool_]) -> NDArray[Any]:
    """(N, ...) ``value`` with the rows outside ``mask`` set to 0 (False for bools)."""
    out = np.zeros_like(value)
    out[mask] = value[mask]
    return out


def _single_info(info: dict[str, NDArray[Any]]) -> dict[str, Any]:
    return {k: (v[0].copy() if v.ndim > 1 else v[0].item()) for k, v in info.items()}


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
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self.task.dt)}
        self.render_mode = render_mode
        self._renderer: Any = None
        self._has_reset = False

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """Start an episode; ``seed`` reseeds :attr:`np_random`."""
        super().reset(seed=seed)
        self.task.reset_envs([0], [self.np_random])
        self._has_reset = True
        obs = self.task.observe([self.np_random])[0]
        if self.render_mode == "human":
            self.render()
        return obs, _single_info(self.task.infos())

    def step(self, action: ArrayLike):
        """One control step of ``dt``; see the task class for reward and episode end."""
        if not self._has_reset:
            raise RuntimeError("Call reset before using step method.")
        reward, terminated, failed = self.task.step_one(self.task.check_one(action))
        obs = self.task.observe_one(self.np_random)
        info = self.task.info_one()
        if self.render_mode == "human":
            self.render()
        return obs, float(reward), terminated, failed, info

    def render(self):
        """An RGB frame (H, W, 3) uint8 in ``"rgb_array"`` mode; draws a window in ``"human"``."""
        if self.render_mode is None:
            gym.logger.warn(
                "render: no render_mode was given; pass render_mode='rgb_array' to gym.make"
            )
            return None
        from rigid_env.render import TaskRenderer

        if self._renderer is None:
            self._renderer = TaskRenderer(
                self.task, mode=self.render_mode, fps=self.metadata["render_fps"]
            )
        return self._renderer.render(0)

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
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self.task.dt)}
        self.render_mode = render_mode
        self._renderer: Any = None
        self._rngs: list[np.random.Generator] = []
        self._autoreset = np.zeros(self.num_envs, dtype=bool)
        self._obs: NDArray[np.float32] | None = None  # the observation last returned

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
        self._obs = self.task.observe(self._rngs)
        return self._obs, self._vector_info(self.task.infos())

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
        if self._obs is None:
            raise ValueError(f"{key}: reset every sub-environment first (reset without a mask)")
        return mask

    def _reset_masked(self, mask: NDArray[np.bool_], seeds: list[int | None]):
        """:meth:`reset` of the envs in ``mask`` only."""
        idx = np.flatnonzero(mask)
        for i in idx:
            if seeds[i] is not None:
                self._rngs[i] = seeding.np_random(seeds[i])[0]
        rngs = [self._rngs[i] for i in idx]
        self.task.reset_envs(idx, rngs)
        self._autoreset[idx] = False
        assert self._obs is not None  # checked by _reset_mask
        obs = self._obs.copy()
        obs[idx] = self.task.observe(rngs, idx)
        self._obs = obs
        return obs, self._vector_info(self.task.infos(), mask)

    def step(self, actions: ArrayLike):
        """Step all sub-environments; see the class docstring for autoreset."""
        if not self._rngs:
            raise RuntimeError("Call reset before using step method.")
        act = self.task.check_action(actions)
        reward, terminated, failed = self.task.step(act)
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
        self._obs = obs = self.task.observe(self._rngs)
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
        from rigid_env.render import TaskRenderer

        if self._renderer is None:
            self._renderer = TaskRenderer(
                self.task, mode=self.render_mode, fps=self.metadata["render_fps"]
            )
        return self._renderer.render(0)

    def close_extras(self, **kwargs: Any) -> None:
        """Close the renderer."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
