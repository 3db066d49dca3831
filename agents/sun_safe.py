"""SunAcquisition's analytic baseline: rate damping and a sun-pointing PD on the reaction
wheels, the cross-product law dumping their momentum through the magnetorquers; from the coarse
sun sensors, the gyro, the wheels' momentum and the magnetometer alone (never the attitude).

* The Sun (Wertz, *Spacecraft Attitude Determination and Control*, Sec. 6.1.1): with a cosine
  detector on each face, ``s = (I_+x - I_-x, I_+y - I_-y, I_+z - I_-z)`` is the Sun's unit vector
  in the body frame times its light (of two opposite faces only the lit one reads). Below
  :data:`LIGHT_FLOOR` the Sun is taken as absent (eclipse).
* Pointing (the law of Basilisk's ``sunSafePoint`` module: Schaub and Junkins, *Analytical
  Mechanics of Space Systems*, 4th ed., Sec. 8.2): the error is the rotation ``phi = theta (p x
  s) / |p x s|`` that turns the panel normal ``p`` onto ``s`` (``theta = acos(p . s)``; at 180 deg
  about a fixed axis normal to ``p``), clipped to ``|phi| <= k_d w_slew / k_p`` so that the slew
  runs at most at ``w_slew``. The body torque is the PD of :func:`agents.wheel_pd.pd_torque`,
  ``tau = I (k_p phi - k_d w) + w x (I w + h)``: the rate about the Sun line is damped, the
  Sun line is reached critically damped (``k_d = 2 sqrt(k_p)``).
* Eclipse: ``phi = 0``, rate damping alone: the body holds its inertial attitude, so the panel
  still faces the Sun (which turns 0.03 deg in a 34 min eclipse) when the light returns.
* Desaturation and the wheels' motors as in :mod:`agents.wheel_pd` (Camillo and Markley 1980),
  but towards a bias momentum (:data:`WHEEL_BIAS`) rather than rest, and a wheel at rest is
  pushed past its Coulomb friction the way it is asked to turn.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.actuator import where
from rigid_env.core.rotation import cross
from rigid_env.envs.sun_acquisition import FIELD_SCALE, PANEL_AXIS, SunAcquisitionTask

from .observing import observed, task_of
from .wheel_pd import desaturating_dipole, pd_torque, wheel_commands

FloatArray = NDArray[np.float64]

LIGHT_FLOOR = 0.05
"""The measured sun vector's length (its light, over full sun) below which the Sun is taken as
absent: five times a detector noise of 0.01 of full sun, a twentieth of full light."""
WHEEL_BIAS = 0.03
"""The coils desaturate each wheel towards this fraction of its capacity (19 rad/s), not to
rest: a wheel kept turning never crosses zero speed, where its Coulomb friction flips sign and
(with every wheel drained to rest) the body's rate dithers by 0.05 deg/s at each crossing, 10
deg of drift over an eclipse (seed 71). Small, because the law's gyroscopic feed-forward turns
a gyro bias ``b`` into the torque ``b x h``: at 0.1 of capacity a 1e-5 rad/s bias failed 6 of
100 episodes at the eclipse's exit, at 0.03 none (seeds 0-99)."""
AT_REST = 0.5
"""[rad/s] a wheel slower than this is taken as at rest for its friction (a step of 2 s at the
Coulomb torque, 5e-6 N m, changes its speed by 0.2 rad/s)."""
FACE_PAIRS = (("sun_+x", "sun_-x"), ("sun_+y", "sun_-y"), ("sun_+z", "sun_-z"))
"""The observation columns of opposite detectors, by body axis."""


def measured_sun(task: Any, obs: FloatArray) -> FloatArray:
    """(N, 3) the Sun's unit vector times its light, body frame, from the six detectors."""
    return np.hstack([observed(task, obs, a) - observed(task, obs, b) for a, b in FACE_PAIRS])


def pointing_error(sun: FloatArray, panel: FloatArray) -> FloatArray:
    """(N, 3) the rotation vector [rad] that turns ``panel`` (3,) onto the directions ``sun``
    (N, 3, unit); at 180 deg about the body axis least aligned with ``panel``, normal to it."""
    axis = cross(np.broadcast_to(panel, sun.shape), sun)
    size = np.linalg.norm(axis, axis=1, keepdims=True)
    angle = np.arccos(np.clip(sun @ panel, -1.0, 1.0))[:, None]
    spare = np.eye(3)[int(np.argmin(np.abs(panel)))]
    normal = spare - (spare @ panel) * panel
    fallback = normal / np.linalg.norm(normal)
    unit = np.where(size > 1e-9, axis / np.where(size > 1e-9, size, 1.0), fallback)
    return angle * unit


class SunSafeController:
    """Rate damping and sun pointing on the wheels, cross-product desaturation on the coils,
    from the observed sun sensors, gyro, wheels' momentum and magnetometer, and the scene's
    model (module docstring).

    Args:
        env: the (single or vector, possibly wrapped) SunAcquisition environment.
        k_p: proportional gain [1/s^2] (natural frequency ``sqrt(k_p)``: 0.05 rad/s, ten
            control steps of 2 s per radian of phase).
        k_d: derivative gain [1/s] (``2 sqrt(k_p)``: critically damped; ``k_d dt = 0.2``).
        k_m: desaturation rate [1/s].
        slew_rate: the most the pointing law turns the body at [rad/s].
    """

    label = "PD"
    """Its row's name in the demo's table."""

    def __init__(
        self,
        env: Any,
        k_p: float = 0.0025,
        k_d: float = 0.1,
        k_m: float = 0.01,
        slew_rate: float = float(np.radians(2.0)),
    ) -> None:
        self.task = task_of(env)
        if not isinstance(self.task, SunAcquisitionTask):
            raise KeyError(
                f"SunSafeController: task {type(self.task).__name__} has no sun sensors, wheels "
                "and coils to find the Sun with (SunAcquisition has)"
            )
        self.gains, self.k_m = (float(k_p), float(k_d)), float(k_m)
        self.largest_error = float(k_d) * float(slew_rate) / float(k_p)
        coils = where(self.task.world.force_effects, lambda a: a.world_input == "field")[0]
        self.max_dipole = coils.max_dipole
        self.wheels = self.task.wheels
        self.panel = np.array(PANEL_AXIS)
        self.bias = WHEEL_BIAS * self.task.capacity * (self.wheels.axes.sum(axis=0))
        """The wheels' momentum the coils drain towards [N m s], body frame."""

    def __call__(self, obs: NDArray[Any]) -> NDArray[np.float32]:
        """Commands (N, 6) float32, coils then wheels, for observations (N, obs_dim) or
        (obs_dim,)."""
        obs = np.asarray(obs, dtype=np.float64)
        single = obs.ndim == 1
        obs = np.atleast_2d(obs)
        task, wheels = self.task, self.wheels
        inertia = np.broadcast_to(task.world.model.inertia, (obs.shape[0], 3))
        w = observed(task, obs, "w") * task.w_scale
        h = observed(task, obs, "momentum_x", "momentum_z") * task.capacity
        field = observed(task, obs, "field_x", "field_z") * FIELD_SCALE
        sun = measured_sun(task, obs)
        light = np.linalg.norm(sun, axis=1, keepdims=True)
        lit = light > LIGHT_FLOOR
        phi = pointing_error(sun / np.where(lit, light, 1.0), self.panel)
        size = np.linalg.norm(phi, axis=1, keepdims=True)
        phi = np.where(
            lit, phi * np.minimum(1.0, self.largest_error / np.maximum(size, 1e-12)), 0.0
        )
        dipole = desaturating_dipole(h - self.bias, field, self.k_m)
        u_coils = np.clip(dipole / self.max_dipole, -1.0, 1.0)
        coil_torque = cross(u_coils * self.max_dipole, field)
        tau = pd_torque(phi, w, h, inertia, self.gains) - coil_torque
        # A wheel (nearly) at rest must first break its Coulomb friction in the direction it is
        # asked to turn (else it sticks, and the coils' torque it should take up turns the
        # body: 0.5 deg/s before the damping's command passes the friction at these gains).
        u = np.hstack([u_coils, wheel_commands(tau, w, h, wheels, AT_REST)])
        u = u.astype(np.float32)
        return u[0] if single else u
