"""The dynamics of one body, compiled: the actuators' wrench, the active effects' forces and
torques, and Euler's equations, reading the body's model and the world's parameters by name
(:mod:`rigid_env.core.layout`).

Frames: forces on the centre of mass are world frame, torques and angular velocities body
frame (principal axes), so the inertia is the constant diagonal ``I``.
"""

from __future__ import annotations

from rigid_env.core.compose import effect_terms
from rigid_env.core.forces import add, dipole_torque
from rigid_env.core.jit import kernel
from rigid_env.core.layout import (
    ZERO3,
    command_level,
    dipole_row,
    field_of,
    map_row,
    surroundings_of,
    wheel_shape,
)
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
    """Body ``i``'s actuation ``(force, torque, dipole, field)`` of its command (``c``: the
    named ``p``; row ``i`` of ``command`` (N, A), or its only row, each ``u_a`` clipped to
    [-1, 1], :func:`rigid_env.core.layout.command_level`): the body-frame ``f_body = sum_a u_a
    F_a``, ``tau_body = sum_a u_a (r_a x F_a)`` (rows of :data:`MAPS`, or the body's own,
    :func:`map_row`), summed in a fixed order; where a dipole is commanded, the dipole ``m_b =
    m_res + sum_a u_a m_a`` (body frame) and the field ``B`` (world frame) the command carries
    (:func:`add_component`, :func:`with_field`), else zeros."""
    r = 0 if command.shape[0] == 1 else i
    act = ZERO_WRENCH
    for a in range(int(c.actions)):
        act = add_component(act, command_level(command, r, a), p, c, model, a, i)
    return with_field(act, command, r, c)


ZERO_WRENCH = (ZERO3, ZERO3, ZERO3, ZERO3)
"""No force, no torque, no dipole, no field: constants the compiler folds."""


@kernel
def add_component(act, u, p, c, model, a, i):
    """``act`` plus command component ``a`` at level ``u`` (its map row scaled, and its dipole
    where a dipole is commanded, :func:`rigid_env.core.layout.dipole_row`)."""
    force, torque = map_row(p, c, model, a, i)
    dipole = act[2]
    if c.dipoles != 0.0:
        dipole = axpy(dipole, u, dipole_row(p, c, a))
    return axpy(act[0], u, force), axpy(act[1], u, torque), dipole, act[3]


@kernel
def with_field(act, command, r, c):
    """``act`` with the body's residual dipole added to its dipole and the field of row ``r``
    of the command (:func:`rigid_env.core.layout.field_of`), where a dipole is commanded; zeros
    where the field comes from the orbit state (:func:`rigid_env.core.orbit_state.where`)."""
    if c.dipoles == 0.0:
        return act
    residual = (c.residual_dipole_x, c.residual_dipole_y, c.residual_dipole_z)
    # The field of the orbit state (c.field_degree) is set where the body is, per substep.
    field = ZERO3 if c.field_degree != 0.0 else field_of(command, r, c)
    return act[0], act[1], axpy(act[2], 1.0, residual), field


@kernel
def accelerations(x, v, q, w, act, m, c, gyro):
    """``(v', w')``: linear acceleration (world) [m/s^2] and angular acceleration (body)
    [rad/s^2] of one body at the state ``(x, v, q, w)``, from the actuation ``act = (force,
    torque, dipole, field)`` (:func:`wrench`; the body-frame force turned to the world frame)
    and the listed effects' forces and torques (:func:`rigid_env.core.compose.effect_terms`,
    each effect's own function, :mod:`rigid_env.core.forces`); where a dipole is commanded, the
    torque ``m_b x R^T B`` of its dipole and field; on the per-body path, the surroundings
    ``act`` carries as its fifth part for the effects that read them
    (:func:`rigid_env.core.layout.surroundings_of`); with ``gyro``, Euler's ``I w' = tau - w x
    I w`` (skipped for an isotropic body, where the term vanishes)."""
    fb, tb = act[0], act[1]
    if c.dipoles != 0.0:
        tb = add(tb, dipole_torque(act[2], act[3], q))
    f = (0.0, 0.0, 0.0)
    if c.actuator_force != 0.0:
        f = rotate(q, fb)
    s = surroundings_of(act)
    (fx, fy, fz), (tx, ty, tz) = effect_terms(x, v, q, w, m, c, s, f, tb)
    if gyro and m.isotropic == 0.0:
        g = gyroscopic(w, m)
        tx -= g[0]
        ty -= g[1]
        tz -= g[2]
    inv_m = m.inv_mass
    alpha = (tx * m.inv_inertia_x, ty * m.inv_inertia_y, tz * m.inv_inertia_z)
    return (fx * inv_m, fy * inv_m, fz * inv_m), alpha


@kernel
def rigid_rates(x, v, q, w, hw, act, m, c, wheels):
    """``(v', w', hw')`` of a body without wheels, as a flow of the body and its wheels reads
    them (:mod:`rigid_env.core.integrators`): its :func:`accelerations` (Euler's gyroscopic
    term included) and no wheel rates (``hw`` stays the constant zeros, whose arithmetic the
    compiler drops as unused)."""
    a, alpha = accelerations(x, v, q, w, act, m, c, True)
    return a, alpha, wheel_shape(hw)


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
