"""Analytic baselines that act through the same env API as a trained policy.

Each controller maps a batch of observations (N, obs_dim) to thruster commands (N, A), reading
only the observation plus the task's known model (inertia, thruster layout, time step), so it
works on a single env (N = 1) and on a vector env alike.

* :class:`PDController`: a desired body torque from the angular velocity and, for orientation
  tasks, the attitude error (a law per task in :data:`PD_LAWS`, reading the observation by the
  names the task gives its parts); allocated to the thrusters by bounded least squares.
  On on/off thrusters with a minimum impulse bit, a :class:`PulseModulator` turns the
  continuous commands into valve duties.
* :class:`BdotController`: the B-dot law of magnetic detumbling (BdotDetumble).
* :class:`ZeroController` and :class:`RandomController`: the floor to beat.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.actuator import specs, where
from rigid_env.core.effects import QuadraticDrag
from rigid_env.core.rotation import (
    cross,
    matrix_to_quat,
    quat_rotate,
    quat_rotate_inv,
    quat_to_rotvec,
)
from rigid_env.envs.batch import TaskBatch
from rigid_env.envs.bdot_detumble import FIELD_SCALE, BdotDetumbleTask
from rigid_env.envs.detumble import DetumbleTask
from rigid_env.envs.reorient import ReorientTask
from rigid_env.envs.spin_stabilize import SpinStabilizeTask
from rigid_env.envs.sun_acquisition import SunAcquisitionTask
from rigid_env.envs.tumbling_fall import FALL_SPEED_SCALE, TumblingFallTask
from rigid_env.envs.wheel_pointing import WheelPointingTask

from .bdot import avanzini_gain, bdot_rate, bdot_torque
from .observing import observed, task_of
from .sun_safe import SunSafeController
from .wheel_pd import WheelPDController

FloatArray = NDArray[np.float64]


def orientation_from_obs(obs: FloatArray, rot_dim: int) -> FloatArray:
    """(N, 4) unit quaternion from the observation's rotation part (quaternion or 6-D)."""
    if rot_dim == 4:
        return obs[:, :4] / np.linalg.norm(obs[:, :4], axis=1, keepdims=True)
    c1, c2 = obs[:, 0:3], obs[:, 3:6]
    m = np.stack([c1, c2, cross(c1, c2)], axis=-1)  # columns: body x, y, z in the world
    return matrix_to_quat(m)


class BoundedAllocator:
    """Thruster commands ``u`` in [-1, 1]^A that best produce a body torque:
    ``min ||T u - tau||^2  s.t.  -1 <= u <= 1``, with ``T`` (3, A) the torque per unit command.

    Solved for the whole batch at once: the minimum-norm solution ``pinv(T) tau`` (exact and
    fuel-lean when it is feasible), then projected gradient steps ``u <- clip(u - T^T (T u -
    tau) / L)`` with ``L = sigma_max(T)^2`` (the gradient's Lipschitz constant), which converge
    to the bounded least-squares optimum when thrusters saturate.
    """

    def __init__(self, torque_map: FloatArray, iterations: int = 30) -> None:
        self.t = np.asarray(torque_map, dtype=np.float64).T  # (3, A)
        self.pinv = np.linalg.pinv(self.t)  # (A, 3)
        self.step = 1.0 / np.linalg.norm(self.t, 2) ** 2
        self.iterations = iterations

    def __call__(self, tau: FloatArray) -> FloatArray:
        """(N, A) commands for desired torques ``tau`` (N, 3) [N m], body frame."""
        u = tau @ self.pinv.T
        if np.all(np.abs(u) <= 1.0):
            return u
        u = np.clip(u, -1.0, 1.0)
        for _ in range(self.iterations):
            residual = u @ self.t.T - tau
            u = np.clip(u - self.step * residual @ self.t, -1.0, 1.0)
        return u


def _damping(pd: PDController, obs: FloatArray, w: FloatArray, inertia: FloatArray) -> FloatArray:
    """``tau = -k_d I w``: for a principal-axis body ``I w`` is the angular momentum ``L``, so
    the torque always points against ``L`` and no impulse is wasted (the fuel spent is close to
    the minimum ``|L0| / lever``)."""
    return -pd.k_d * inertia * w


def _damping_against_drag(
    pd: PDController, obs: FloatArray, w: FloatArray, inertia: FloatArray
) -> FloatArray:
    """The damping plus a feed-forward that cancels the predicted drag torque ``r_cp x R^T F``
    at the centre of pressure, ``F = -1/2 rho C_D A |v_p| v_p``, with the velocity and the
    orientation read from the observation."""
    return _damping(pd, obs, w, inertia) - pd.drag_torque(obs, w)


def _spin_about_y(
    pd: PDController, obs: FloatArray, w: FloatArray, inertia: FloatArray
) -> FloatArray:
    """``tau = w x I w - k_d I (w - Omega e_y)``: the feed-forward cancels the gyroscopic term,
    leaving ``w' = -k_d (w - w_target)``, a stable linear error."""
    w_target = np.zeros_like(w)
    w_target[:, 1] = pd.task.params.target_spin
    return cross(w, inertia * w) - pd.k_d * inertia * (w - w_target)


def _attitude(pd: PDController, obs: FloatArray, w: FloatArray, inertia: FloatArray) -> FloatArray:
    """``tau = I (k_p phi - k_d w)`` with ``phi`` the body-frame rotation vector of the observed
    error quaternion (critically damped for ``k_d = 2 sqrt(k_p)``)."""
    q_err = observed(pd.task, obs, "error_w", "error_z")
    return inertia * (pd.k_p * quat_to_rotvec(q_err) - pd.k_d * w)


@dataclass(frozen=True)
class PDLaw:
    """A task's PD law: its default gains and its desired body torque [N m] (N, 3) from the
    controller, the observations (N, D), the body ``w`` [rad/s] and the moments (N, 3)."""

    k_p: float
    """Proportional gain [1/s^2] (0 where the law has no attitude term)."""
    k_d: float
    """Derivative gain [1/s]; ``k_d dt`` well below 1 avoids chattering at the step size."""
    torque: Callable[[PDController, FloatArray, FloatArray, FloatArray], FloatArray]


PD_LAWS: dict[type[TaskBatch], PDLaw] = {
    DetumbleTask: PDLaw(0.0, 2.0, _damping),
    TumblingFallTask: PDLaw(0.0, 4.0, _damping_against_drag),
    SpinStabilizeTask: PDLaw(0.0, 3.0, _spin_about_y),
    ReorientTask: PDLaw(1.0, 2.0, _attitude),
}
"""The PD law of each task, by its task class (a subclass, which may change what the task asks
for, needs a law of its own)."""


class PulseModulator:
    """A pulse-width modulator after the continuous law, for on/off thrusters with a minimum
    impulse bit (Wie, *Space Vehicle Dynamics and Control*, 2nd ed., Sec. 7.3; Sidi,
    *Spacecraft Dynamics and Control*, Ch. 7): the continuous command ``u`` in [-1, 1] is the
    duty cycle of the step (an on/off valve open ``|u| dt`` delivers the impulse of the ideal
    thruster at ``u``), and a duty below the minimum on-time ``J / (f_max dt)``, which the valve
    would drop, is carried over instead: the modulator fires the commanded impulse it owes (its
    running sum, ``e <- e + u``) once it reaches the minimum, as a sigma-delta modulator does, so
    no commanded impulse is lost on average. A thrust lag delays an on/off pulse but keeps its
    impulse (the lag's response to a pulse has the pulse's area), so the duty is not rescaled.

    Args:
        thrusters: the world's thruster effects (their hardware read from each); a component
            without ``on_off`` or ``min_impulse`` passes its command through.
        dt: the control step [s].
    """

    def __init__(self, thrusters: list[Any], dt: float) -> None:
        minimum = []
        for t in thrusters:
            bit = getattr(t, "min_impulse", None)
            fmax = np.linalg.norm(t.force_map, axis=1)
            per_step = np.where(fmax > 0.0, fmax * dt, 1.0)  # the impulse of a full step [N s]
            floor = np.zeros(fmax.shape) if bit is None else bit / per_step
            minimum.append(floor)
        self.minimum = np.concatenate(minimum) if minimum else np.zeros(0)
        self.active = bool(np.any(self.minimum > 0.0))
        self.owed: FloatArray | None = None

    def __call__(self, u: FloatArray) -> FloatArray:
        """(N, A) on/off duties for the continuous commands ``u`` (N, A)."""
        if not self.active:
            return u
        if self.owed is None or self.owed.shape != u.shape:
            self.owed = np.zeros_like(u)
        want = self.owed + u
        fire = np.abs(want) >= self.minimum
        out = np.where(fire, np.clip(want, -1.0, 1.0), 0.0)
        self.owed = want - out
        return out


class PDController:
    """Proportional-derivative attitude controller with bounded least-squares allocation: the
    task's law in :data:`PD_LAWS` gives a desired body torque, allocated to the thrusters.

    Args:
        env: the (single or vector, possibly wrapped) environment it will control.
        k_p: proportional gain [1/s^2] (the law's default if None).
        k_d: derivative gain [1/s] (the law's default if None).

    Raises:
        KeyError: the env's task has no PD law (add one to :data:`PD_LAWS`).
    """

    label = "PD"
    """Its row's name in the demo's table."""

    def __init__(self, env: Any, k_p: float | None = None, k_d: float | None = None) -> None:
        self.task = task_of(env)
        law = PD_LAWS.get(type(self.task))
        if law is None:
            raise KeyError(
                f"PDController: task {type(self.task).__name__} has no PD law; add one to "
                f"agents.controllers.PD_LAWS (laws: {', '.join(t.__name__ for t in PD_LAWS)})"
            )
        self.law = law
        self.k_p = self.law.k_p if k_p is None else float(k_p)
        self.k_d = self.law.k_d if k_d is None else float(k_d)
        actuators = specs(self.task.world.force_effects)
        self.allocate = BoundedAllocator(np.concatenate([a.torque_map for a in actuators]))
        self.modulate = PulseModulator(actuators, self.task.dt)
        """The hardware it is told about (the scene's on/off thrusters and their minimum
        impulse bit): a modulator after the continuous law; never the faults."""

    def __call__(self, obs: NDArray[Any]) -> NDArray[np.float32]:
        """Commands (N, A) float32 for observations (N, obs_dim) or (obs_dim,)."""
        obs = np.asarray(obs, dtype=np.float64)
        single = obs.ndim == 1
        obs = np.atleast_2d(obs)
        task = self.task
        inertia = np.broadcast_to(task.world.model.inertia, (obs.shape[0], 3))
        w = observed(task, obs, "w") * task.w_scale
        u = self.modulate(self.allocate(self.law.torque(self, obs, w, inertia)))
        u = u.astype(np.float32)
        return u[0] if single else u

    def drag_torque(self, obs: FloatArray, w: FloatArray) -> FloatArray:
        """Predicted aerodynamic torque (N, 3) body frame [N m] from the observation."""
        drag = [e for e in self.task.world.force_effects if isinstance(e, QuadraticDrag)]
        if not drag or not drag[0].offset:
            return np.zeros_like(w)
        d = drag[0]
        rot = self.task.obs_slices["orientation"]
        q = orientation_from_obs(obs, rot.stop - rot.start)
        if "v_body_x" in self.task.obs_slices:  # TumblingFall v1: the body-frame velocity
            v_body = observed(self.task, obs, "v_body_x", "v_body_z")
            v = quat_rotate(q, v_body * FALL_SPEED_SCALE)
        else:  # v0 observes the vertical speed
            v = np.zeros_like(w)
            v[:, 2] = observed(self.task, obs, "v_z")[:, 0] * FALL_SPEED_SCALE
        v_p = v + quat_rotate(q, cross(w, d.center_of_pressure))
        f = -d.k * np.linalg.norm(v_p, axis=1, keepdims=True) * v_p
        return cross(d.center_of_pressure, quat_rotate_inv(q, f))


class BdotController:
    """The B-dot law (:func:`agents.bdot.bdot_rate`) from the observed gyro ``w`` and
    magnetometer field, for a task on magnetorquers along an orbit (BdotDetumble): the gain of
    Avanzini and Giulietti for the orbit's rate and its inclination to the geomagnetic
    equator, the coils' dipoles read from the scene. On a task whose actions are wanted
    torques (BdotDetumble's ``command="torque"``) it asks for B-dot's torque instead
    (:func:`agents.bdot.bdot_torque`), which the task's cross-product law turns back into
    B-dot's dipole.

    Args:
        env: the (single or vector, possibly wrapped) environment it will control.
        gain: ``k`` [kg m^2/s] (default :func:`agents.bdot.avanzini_gain`).
    """

    label = "B-dot"
    """Its row's name in the demo's table."""

    def __init__(self, env: Any, gain: float | None = None) -> None:
        self.task = task_of(env)
        world = self.task.world
        coils = where(world.force_effects, lambda a: a.world_input == "field")
        motion = world.motion if world.orbit_field(slice(0, 0)) is not None else None
        on_orbit = bool(coils) and (coils[0].orbit is not None or motion is not None)
        if not on_orbit or "field_x" not in self.task.obs_slices:
            raise KeyError(
                f"BdotController: task {type(self.task).__name__} observes no magnetometer on "
                "magnetorquers along an orbit (BdotDetumble does)"
            )
        self.max_dipole = coils[0].max_dipole
        if motion is not None:  # the orbit as world state: the IGRF's dipole terms
            model = motion.field_model()
            g10, g11, h11 = model.g[1, 0], model.g[1, 1], model.h[1, 1]
            tilt = float(np.arccos(-g10 / np.sqrt(g10 * g10 + g11 * g11 + h11 * h11)))
            n, orbit_inclination = motion.orbit.mean_motion, motion.orbit.inclination
        else:
            orbit = coils[0].orbit
            tilt = orbit.dipole.tilt
            n, orbit_inclination = orbit.orbit.mean_motion, orbit.orbit.inclination
        # the orbit's inclination to the geomagnetic equator, at most
        inclination = min(orbit_inclination, np.pi - orbit_inclination) + tilt
        least = float(np.min(world.model.inertia))
        self.gain = avanzini_gain(n, inclination, least) if gain is None else gain

    def __call__(self, obs: NDArray[Any]) -> NDArray[np.float32]:
        """Commands (N, 3) float32 for observations (N, obs_dim) or (obs_dim,)."""
        obs = np.asarray(obs, dtype=np.float64)
        single = obs.ndim == 1
        obs = np.atleast_2d(obs)
        w = observed(self.task, obs, "w") * self.task.w_scale
        field = observed(self.task, obs, "field_x", "field_z") * FIELD_SCALE
        if getattr(self.task.params, "command", "dipole") == "torque":
            u = bdot_torque(w, field, self.gain, float(np.min(self.max_dipole)))
        else:
            u = bdot_rate(w, field, self.gain, self.max_dipole)
        u = u.astype(np.float32)
        return u[0] if single else u


class ZeroController:
    """Never fires (shows what the uncontrolled body does)."""

    def __init__(self, env: Any) -> None:
        self.action_dim = task_of(env).action_dim

    def __call__(self, obs: NDArray[Any]) -> NDArray[np.float32]:
        obs = np.asarray(obs)
        shape = (self.action_dim,) if obs.ndim == 1 else (obs.shape[0], self.action_dim)
        return np.zeros(shape, dtype=np.float32)


class RandomController:
    """Uniform random commands from its own seeded generator."""

    def __init__(self, env: Any, seed: int = 0) -> None:
        self.action_dim = task_of(env).action_dim
        self.rng = np.random.default_rng(seed)

    def __call__(self, obs: NDArray[Any]) -> NDArray[np.float32]:
        obs = np.asarray(obs)
        shape = (self.action_dim,) if obs.ndim == 1 else (obs.shape[0], self.action_dim)
        return self.rng.uniform(-1.0, 1.0, size=shape).astype(np.float32)


def analytic_controller(
    env: Any,
) -> PDController | BdotController | WheelPDController | SunSafeController:
    """The task's analytic baseline: B-dot for a task on magnetorquers alone (:data:`ANALYTIC`),
    else its PD law (:data:`PD_LAWS`)."""
    return ANALYTIC.get(type(task_of(env)), PDController)(env)


ANALYTIC: dict[type[TaskBatch], type] = {
    BdotDetumbleTask: BdotController,
    WheelPointingTask: WheelPDController,
    SunAcquisitionTask: SunSafeController,
}
"""The tasks whose analytic baseline is not a PD law, by task class."""

CONTROLLERS = {"pd": analytic_controller, "zero": ZeroController, "random": RandomController}
"""The baselines a policy is compared with, by the name of their rows: ``pd`` is the task's
analytic baseline (:func:`analytic_controller`: B-dot on BdotDetumble, the wheels' PD with
desaturation on WheelPointing, sun-safe pointing on SunAcquisition)."""
