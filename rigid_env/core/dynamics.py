"""The dynamics of one body, compiled: the actuators' wrench, the active effects' forces and
torques, and Euler's equations, reading the body's model and the world's parameters by name
(:mod:`rigid_env.core.layout`).

Frames: forces on the centre of mass are world frame, torques and angular velocities body
frame (principal axes), so the inertia is the constant diagonal ``I``.
"""

from __future__ import annotations

from rigid_env.core.compose import effect_terms
from rigid_env.core.jit import kernel
from rigid_env.core.layout import command_level, map_row
from rigid_env.core.maths import axpy, rotate


@kernel
def gyroscopic(w, m):
    """``w x (I w)`` [N m] for the principal moments of the body model ``m``."""
    return (
        w[1] * w[2] * (m.inertia_z - m.inertia_y),
        w[2] * w[0] * (m.inertia_x - m.inertia_z),
        w[0] * w[1] * (m.inertia_y - m.inertia_x),
    )


@kernel
def gyro_jacobian(w, m):
    """``d(w x I w)/dw = skew(w) I - skew(I w)``, row-major 9-tuple."""
    i0, i1, i2 = m.inertia_x, m.inertia_y, m.inertia_z
    l0, l1, l2 = i0 * w[0], i1 * w[1], i2 * w[2]
    return (
        0.0,
        -w[2] * i1 + l2,
        w[1] * i2 - l1,
        w[2] * i0 - l2,
        0.0,
        -w[0] * i2 + l0,
        -w[1] * i0 + l1,
        w[0] * i1 - l0,
        0.0,
    )


@kernel
def wrench(p, c, model, command, i):
    """Body-frame actuator force and torque of body ``i``'s command (``c``: the named ``p``; row
    ``i`` of ``command`` (N, A), or its only row, each ``u_a`` clipped to [-1, 1],
    :func:`rigid_env.core.layout.command_level`): ``f_body = sum_a u_a F_a``, ``tau_body = sum_a
    u_a (r_a x F_a)`` (rows of :data:`MAPS`, or the body's own, :func:`map_row`), summed in a
    fixed order."""
    r = 0 if command.shape[0] == 1 else i
    act = ZERO_WRENCH
    for a in range(command.shape[1]):
        act = add_scaled(act, command_level(command, r, a), map_row(p, c, model, a, i))
    return act


ZERO_WRENCH = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
"""No force and no torque: constants the compiler folds."""


@kernel
def add_scaled(act, u, row):
    """``act + u row`` of two ``(force, torque)`` pairs: a wrench plus a command component's
    map row scaled by its level ``u``."""
    return axpy(act[0], u, row[0]), axpy(act[1], u, row[1])


@kernel
def accelerations(x, v, q, w, act, m, c, gyro):
    """``(v', w')``: linear acceleration (world) [m/s^2] and angular acceleration (body)
    [rad/s^2] of one body at the state ``(x, v, q, w)``, from the actuators' body wrench
    ``act = (force, torque)`` (the force turned to the world frame) and the listed effects'
    forces and torques (:func:`rigid_env.core.compose.effect_terms`, each effect's own
    function, :mod:`rigid_env.core.forces`); with ``gyro``, Euler's ``I w' = tau - w x I w``
    (skipped for an isotropic body, where the term vanishes)."""
    fb, tb = act
    f = (0.0, 0.0, 0.0)
    if c.actuator_force != 0.0:
        f = rotate(q, fb)
    (fx, fy, fz), (tx, ty, tz) = effect_terms(x, v, q, w, m, c, f, tb)
    if gyro and m.isotropic == 0.0:
        g = gyroscopic(w, m)
        tx -= g[0]
        ty -= g[1]
        tz -= g[2]
    inv_m = m.inv_mass
    alpha = (tx * m.inv_inertia_x, ty * m.inv_inertia_y, tz * m.inv_inertia_z)
    return (fx * inv_m, fy * inv_m, fz * inv_m), alpha


@kernel
def kinetic_energy(v, w, m):
    """``1/2 (m |v|^2 + sum_k I_k w_k^2)`` [J]."""
    trans = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
    rot = m.inertia_x * w[0] * w[0] + m.inertia_y * w[1] * w[1] + m.inertia_z * w[2] * w[2]
    return 0.5 * (m.mass * trans + rot)


@kernel
def kick(x, v, q, w, act, m, c, h):
    """Flow of the external forces for time ``h`` with ``x, q`` frozen (gyroscopic term
    excluded): exact in one evaluation when no force depends on velocity (a constant
    acceleration), else the explicit midpoint rule, second order."""
    a, alpha = accelerations(x, v, q, w, act, m, c, False)
    if c.velocity_dependent != 0.0:
        a, alpha = accelerations(
            x, axpy(v, 0.5 * h, a), q, axpy(w, 0.5 * h, alpha), act, m, c, False
        )
    return axpy(v, h, a), axpy(w, h, alpha)
