"""The built-in effects' declarations (:class:`rigid_env.core.effect.Effect`): each one's
fields, its force/torque function and its bounds for the guard, compiled per body.

Frames: forces on the centre of mass are world frame, torques body frame (principal axes).
Each ``apply`` adds its terms to the force ``f`` and torque ``tau`` accumulated so far, in a
fixed order (the registry's), component by component.
"""

from __future__ import annotations

import math

from rigid_env.core.effect import Effect
from rigid_env.core.facets import drag_wrench, plates_at, solar_pressure, srp_wrench
from rigid_env.core.jit import kernel
from rigid_env.core.maths import axpy, cross, norm, rotate, rotate_inv


@kernel
def add(f, g):
    """``f + g`` of two 3-vectors."""
    return (f[0] + g[0], f[1] + g[1], f[2] + g[2])


# ---- gravity -----------------------------------------------------------------------------------
@kernel
def gravity(x, v, q, w, m, c, f, tau):
    """Uniform gravity ``F = m g`` at the centre of mass, no torque."""
    return add(f, (m.mass * c.gravity_x, m.mass * c.gravity_y, m.mass * c.gravity_z)), tau


@kernel
def gravity_bound(m, c):
    """``|F| = m |g|`` [N]."""
    return m.mass * math.sqrt(c.gravity_x**2 + c.gravity_y**2 + c.gravity_z**2)


# ---- quadratic drag ----------------------------------------------------------------------------
@kernel
def drag(x, v, q, w, m, c, f, tau):
    """Quadratic drag ``F = -k |v_p| v_p`` at the centre of pressure ``r`` (body frame), whose
    velocity is ``v_p = v + R (w x r)``; off the centre of mass it adds ``tau = r x R^T F``.
    It only dissipates (``F . v_p <= 0``): no bound for the guard."""
    vp = v
    cop = (c.cop_x, c.cop_y, c.cop_z)
    if c.drag_offset != 0.0:
        vp = axpy(v, 1.0, rotate(q, cross(w, cop)))
    ks = -c.drag_k * norm(vp)
    force = (ks * vp[0], ks * vp[1], ks * vp[2])
    f = add(f, force)
    if c.drag_offset != 0.0:
        tau = add(tau, cross(cop, rotate_inv(q, force)))
    return f, tau


# ---- gravity-gradient torque -------------------------------------------------------------------
@kernel
def gravity_gradient(x, v, q, w, m, c, f, tau):
    """The gravity-gradient torque of a point mass ``mu = G M`` at ``c``, ``tau = 3 mu / |r|^5
    (r_b x I r_b)`` with ``r_b = R^T (x - c)`` (body axes): the torque of the potential ``mu /
    (2 |r|^3) (3 r_b . I r_b / |r|^2 - tr I)``, MacCullagh's formula, the leading term of the
    body's potential in powers of its size over ``|r|`` (Hughes, "Spacecraft Attitude
    Dynamics", Sec. 8.1)."""
    center = (c.gradient_center_x, c.gradient_center_y, c.gradient_center_z)
    rb = rotate_inv(q, (x[0] - center[0], x[1] - center[1], x[2] - center[2]))
    r2 = rb[0] * rb[0] + rb[1] * rb[1] + rb[2] * rb[2]
    k = 3.0 * c.gradient_mu / (r2 * r2 * math.sqrt(r2))
    i_rb = (m.inertia_x * rb[0], m.inertia_y * rb[1], m.inertia_z * rb[2])
    t = cross(rb, i_rb)
    return f, (tau[0] + k * t[0], tau[1] + k * t[1], tau[2] + k * t[2])


@kernel
def gravity_gradient_bound(x, m, c):
    """``sqrt(dV)``: the potential ``V = mu / (2 |r|^3) (3 r^.I r^ - tr I)`` spans ``dV = 3 mu
    (I_max - I_min) / (2 |r|^3)`` over every orientation (``|r|`` at the step's start)."""
    center = (c.gradient_center_x, c.gradient_center_y, c.gradient_center_z)
    r = norm(axpy(x, -1.0, center))
    spread = max(m.inertia_x, m.inertia_y, m.inertia_z) - min(m.inertia_x, m.inertia_y, m.inertia_z)
    return math.sqrt(1.5 * c.gradient_mu * spread / (r * r * r))


# ---- magnetic dipole torque --------------------------------------------------------------------
@kernel
def dipole_torque(dipole_body, field_world, q):
    """``tau_body = m_b x (R^T B)`` [N m]: the torque of a uniform field ``B`` (world frame) [T]
    on a magnetic dipole ``m_b`` (body frame) [A m^2], the torque of the potential ``U = -m . B
    = -m_b . R^T B`` (Griffiths, "Introduction to Electrodynamics", Sec. 6.1.2). A function of
    its own for what a commanded dipole (magnetorquers) also needs."""
    return cross(dipole_body, rotate_inv(q, field_world))


@kernel
def magnetic_dipole(x, v, q, w, m, c, f, tau):
    """A constant body dipole in a constant world field (:func:`dipole_torque`)."""
    dipole = (c.dipole_x, c.dipole_y, c.dipole_z)
    field = (c.magnetic_field_x, c.magnetic_field_y, c.magnetic_field_z)
    return f, add(tau, dipole_torque(dipole, field, q))


@kernel
def magnetic_dipole_bound(x, m, c):
    """``sqrt(dV)``: ``U = -m . B`` spans ``[-|m| |B|, |m| |B|]``, ``dV = 2 |m| |B|``."""
    dipole = (c.dipole_x, c.dipole_y, c.dipole_z)
    field = (c.magnetic_field_x, c.magnetic_field_y, c.magnetic_field_z)
    return math.sqrt(2.0 * norm(dipole) * norm(field))


# ---- facets: sunlight and air ------------------------------------------------------------------
@kernel
def solar_radiation_pressure(x, v, q, w, m, c, s, f, tau):
    """The torque of the Sun's light on the body's facets, ``tau = sum_k c_k x F_k``, each
    ``F_k = -P A cos t ((1 - rho_s) s + 2 (rho_s cos t + rho_d / 3) n)`` at this stage's
    attitude ``q`` (:func:`rigid_env.core.facets.srp_wrench`; Montenbruck and Gill, *Satellite
    Orbits*, 2000, Sec. 3.4), in the sunlight ``s`` held over the substep (none in the umbra).
    Torque only: the body's centre of mass follows its orbit, which the force (about 1e-7 m/s^2
    for a small satellite) leaves as it is."""
    plates = plates_at(s.params, c.srp_rows, c.srp_plates)
    _, torque = srp_wrench(plates, q, s.to_sun, s.light)
    return f, add(tau, torque)


@kernel
def solar_radiation_pressure_bound(m, c, s):
    """``|tau| <= P sum_k |c_k| A_k (1 + rho_s + 2 rho_d / 3)`` [N m] at the pressure ``P`` of
    the sunlight held over the substep (:func:`rigid_env.core.facets.srp_torque_arm`)."""
    return solar_pressure(s.light, norm(s.to_sun)) * c.srp_arm


@kernel
def aerodynamic_drag(x, v, q, w, m, c, s, f, tau):
    """The torque of the air on the body's facets, ``tau = sum_k c_k x F_k``, each ``F_k = -1/2
    rho C_d A cos t |v_rel|^2 u`` at this stage's attitude ``q``
    (:func:`rigid_env.core.facets.drag_wrench`; Vallado 2013, ch. 8, per plate), in the air
    held over the substep: ``v_rel = v - w_E x r`` of the orbit, Vallado's density at its
    height. The body's own turn adds ``w x c`` to each facet's wind, under 1e-4 of ``v_rel``
    (0.1 rad/s at 1 m against 7.5 km/s), and is left out. Torque only, as
    :func:`solar_radiation_pressure`."""
    plates = plates_at(s.params, c.aero_rows, c.aero_plates)
    _, torque = drag_wrench(plates, q, s.air_velocity, s.air_density)
    return f, add(tau, torque)


@kernel
def aerodynamic_drag_bound(m, c, s):
    """``|tau| <= rho |v_rel|^2 sum_k |c_k| C_d A_k / 2`` [N m] in the air held over the
    substep (:func:`rigid_env.core.facets.drag_torque_arm`)."""
    u = s.air_velocity
    return s.air_density * (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) * c.aero_arm


BUILT_IN = (
    Effect(
        "gravity",
        ("gravity_x", "gravity_y", "gravity_z"),  # g, world frame [m/s^2]
        gravity,
        force_bound=gravity_bound,
    ),
    Effect(
        "drag",
        # k = rho cd A / 2 [kg/m]; flag: the centre of pressure is off the centre of mass;
        # the centre of pressure, body frame [m]
        ("drag_k", "drag_offset", "cop_x", "cop_y", "cop_z"),
        drag,
        velocity_dependent=True,
    ),
    Effect(
        "gravity_gradient",
        # mu = G M of the attracting body [m^3/s^2]; its centre, world frame [m]
        ("gradient_mu", "gradient_center_x", "gradient_center_y", "gradient_center_z"),
        gravity_gradient,
        rare=True,
        potential_bound=gravity_gradient_bound,
    ),
    Effect(
        "magnetic_dipole",
        # the body's dipole, body frame [A m^2]; the field, world frame [T]
        (
            *("dipole_x", "dipole_y", "dipole_z"),
            *("magnetic_field_x", "magnetic_field_y", "magnetic_field_z"),
        ),
        magnetic_dipole,
        rare=True,
        potential_bound=magnetic_dipole_bound,
    ),
    Effect(
        "solar_radiation_pressure",
        # the offset of its facets' rows in the parameters (plate_rows), their count K;
        # sum_k |c_k| A_k (1 + rho_s + 2 rho_d / 3) [m^3], for its bound
        ("srp_rows", "srp_plates", "srp_arm"),
        solar_radiation_pressure,
        rare=True,
        torque_bound=solar_radiation_pressure_bound,
        reads=("sunlight",),
    ),
    Effect(
        "aerodynamic_drag",
        # the same for its facets; sum_k |c_k| C_d A_k / 2 [m^3], for its bound
        ("aero_rows", "aero_plates", "aero_arm"),
        aerodynamic_drag,
        rare=True,
        torque_bound=aerodynamic_drag_bound,
        reads=("air",),
    ),
)
"""The built-in effects, in the order their terms are summed."""
