"""A world's trajectory as the arrays ``rigid-env simulate`` writes (the contract in DESIGN.md)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core.rotation import quat_rotate
from rigid_env.core.world import World

FloatArray = NDArray[np.float64]


def simulate(
    world: World,
    steps: int,
    action: ArrayLike | None = None,
    rng: np.random.Generator | None = None,
) -> dict[str, FloatArray]:
    """Step ``world`` ``steps`` times with a constant command and record the trajectory; where
    the thrusters have ``noise``, each step's thrust factors are drawn from ``rng`` first
    (:meth:`World.draw_thrust_factors`; nothing is drawn for noise-free thrusters).

    Raises:
        ValueError: the thrusters have noise and no ``rng`` is given (a trajectory without
            the noise the scene asks for would be silently noise-free).

    Returns:
        Arrays of every body with a leading time axis of length ``T = steps + 1``: ``t (T,)``,
        ``position (T, N, 3)``, ``velocity``, ``orientation (T, N, 4)``,
        ``angular_velocity_body``, ``angular_velocity_world``, ``energy (T, N)``,
        ``angular_momentum_world (T, N, 3)`` (body and wheels); with reaction wheels also
        ``wheel_momentum (T, N, K)`` [N m s] and ``wheel_speed (T, N, K)`` [rad/s] (relative to
        the body).
    """
    if int(steps) != steps or steps < 0:
        raise ValueError(f"steps: must be an integer >= 0, got {steps}")
    rows = np.empty((int(steps) + 1, world.n, 13))
    energy = np.empty((int(steps) + 1, world.n))
    t0 = world.time
    wheels = world.wheel_momentum is not None
    momenta = np.empty((int(steps) + 1, world.n, world.wheel_momentum.shape[1] if wheels else 0))
    speeds = np.empty_like(momenta)
    rows[0] = world.rows
    energy[0] = world.energy()
    if wheels:
        momenta[0], speeds[0] = world.wheel_momentum, world.wheel_speed
    noisy = bool(np.any(world.thrust_noise > 0.0))
    if noisy and rng is None:
        raise ValueError("rng: the scene's thrusters have noise; give a generator to draw it from")
    for k in range(1, int(steps) + 1):
        if noisy:
            world.draw_thrust_factors(rng)
        world.step(action)
        rows[k] = world.rows
        energy[k] = world.energy()
        if wheels:
            momenta[k], speeds[k] = world.wheel_momentum, world.wheel_speed
    q, w = rows[..., 6:10], rows[..., 10:13]
    spin = world.model.inertia * w
    if wheels:  # the body's and the wheels' momentum (body frame), as World.angular_momentum_world
        spin = spin + momenta @ world.wheels.axes
    out = {
        "t": t0 + world.dt * np.arange(int(steps) + 1),
        "position": rows[..., 0:3].copy(),
        "velocity": rows[..., 3:6].copy(),
        "orientation": q.copy(),
        "angular_velocity_body": w.copy(),
        "angular_velocity_world": quat_rotate(q, w),
        "energy": energy,
        "angular_momentum_world": quat_rotate(q, spin),
    }
    if wheels:
        out |= {"wheel_momentum": momenta, "wheel_speed": speeds}
    return out
