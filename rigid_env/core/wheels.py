"""Reaction wheels: momentum exchanged inside the body (a gyrostat), compiled.

Wheel ``k`` spins about the body axis ``a_k`` with axial inertia ``J_k``; its state is its
axial angular momentum ``h_k = J_k (a_k . w + Omega_k)`` [N m s] (``Omega_k`` its speed
relative to the body), rows :func:`wheel_row` on in the state columns. With ``h = sum_k a_k
h_k`` the body obeys (Markley and Crassidis, "Fundamentals of Spacecraft Attitude Determination
and Control", Springer 2014, Sec. 3.3.5; Hughes, "Spacecraft Attitude Dynamics", Ch. 9)

    I w' = tau_ext - w x (I w + h) - sum_k a_k h_k',    h_k' = tau_motor_k + tau_friction_k

with ``I`` the body's inertia without the wheels' axial ``J_k`` (principal, as every body's).
The motor gives ``u_k max_torque_k`` (``u_k`` the command component, in [-1, 1]) and none that
would drive the wheel beyond ``max_speed_k`` (``|Omega_k| >= max_speed_k`` and the torque
along ``Omega_k``: the drive's speed limit); the bearing's friction is ``-viscous_k Omega_k -
coulomb_k sign(Omega_k)``. Without external torque the total ``R (I w + h)`` is constant and
friction moves momentum, never creates it.

An integrator with wheels advances ``(x, v, q, w, h_1 .. h_K)`` together, each stage reading the
wheels' momenta and rates, so it keeps its order: the explicit methods are each written once as a
flow of the body and its wheels (:mod:`rigid_env.core.integrators`), and the world step's passes
(:mod:`rigid_env.core.stepping`) step every world with them, the gyrostat's rates
(:func:`gyrostat`) where the bodies carry wheels; the methods built on the free rigid body's
exact flows refuse wheels (:data:`rigid_env.core.integrators.NO_WHEELS`).

Every body has :data:`~rigid_env.core.layout.MAX_WHEELS` slots of wheels (the 4-tuples of
momenta and rates), a slot past the last wheel giving zeros by a select (its numbers those of
the last wheel, so that no read leaves the arrays): no branch, no inner loop, so that the
vectorised passes keep their loops.
"""

from __future__ import annotations

from numba import types
from numba.extending import overload

from rigid_env.core.dynamics import accelerations, rigid_rates
from rigid_env.core.jit import kernel
from rigid_env.core.layout import (
    MAX_WHEELS,
    MOTORS,
    THRUST,
    ZERO3,
    ZERO4,
    Wheel,
    command_level,
    wheel,
    with_item,
)
from rigid_env.core.maths import axpy, cross


@kernel
def relative_speed(w, hk, axis, inertia):
    """``Omega_k = h_k / J_k - a_k . w`` [rad/s], the wheel's speed relative to the body."""
    return hk / inertia - (axis[0] * w[0] + axis[1] * w[1] + axis[2] * w[2])


@kernel
def _slot(c, k):
    """The wheel whose row slot ``k`` reads: ``k``, or the last wheel past it."""
    return min(k, int(c.wheel_count) - 1)


NO_WHEEL_RECORDS = (Wheel(*([0.0] * len(Wheel._fields))),) * MAX_WHEELS
"""The wheel records of a body without wheels: constants the compiler folds."""
NO_DRIVE = (NO_WHEEL_RECORDS, ZERO4)
"""The drive of a body without wheels (:func:`wheel_drive`)."""


@kernel
def wheel_records(p, c):
    """The :class:`~rigid_env.core.layout.Wheel` records of the
    :data:`~rigid_env.core.layout.MAX_WHEELS` slots (past the last wheel its record again),
    read once before a pass over the bodies; :data:`NO_WHEEL_RECORDS` where the bodies carry
    no wheels."""
    if c.wheels == 0.0:
        return NO_WHEEL_RECORDS
    wheels = NO_WHEEL_RECORDS
    for k in range(MAX_WHEELS):
        wheels = with_item(wheels, k, wheel(p, c, _slot(c, k)))
    return wheels


@kernel
def motor_torques(wheels, c, command, r):
    """Each slot's motor torque ``u_k max_torque_k`` [N m] (a 4-tuple) of row ``r`` of the
    command, held over the step (``wheels``: :func:`wheel_records`); zeros without wheels."""
    motors = ZERO4
    if c.wheels != 0.0:
        for k in range(MAX_WHEELS):
            e = wheels[k]
            level = command_level(command, r, int(e.action))
            motors = with_item(motors, k, level * e.max_torque)
    return motors


@kernel
def wheel_drive(wheels, c, command, r):
    """``(wheels, motors)``: the wheel records (:func:`wheel_records`) and their
    :func:`motor_torques` of row ``r`` of the command; :data:`NO_DRIVE` where the bodies carry
    no wheels. Numbers only, so that the integrator's flow gets no array."""
    if c.wheels == 0.0:
        return NO_DRIVE
    return wheels, motor_torques(wheels, c, command, r)


@kernel
def store_motors(wrenches, i, motors, c):
    """Body ``i``'s motor torques into its rows of the scratch ``wrenches`` (from
    :data:`rigid_env.core.layout.MOTORS`), where the bodies carry wheels."""
    if c.wheels != 0.0:
        for k in range(MAX_WHEELS):
            wrenches[MOTORS + k, i] = motors[k]


@kernel
def load_drive(wheels, wrenches, i, c):
    """``(wheels, motors)`` as :func:`wheel_drive`, the motor torques read from body ``i``'s
    rows of ``wrenches`` (:func:`store_motors`); :data:`NO_DRIVE` without wheels."""
    if c.wheels == 0.0:
        return NO_DRIVE
    k = MOTORS
    return wheels, (wrenches[k, i], wrenches[k + 1, i], wrenches[k + 2, i], wrenches[k + 3, i])


@kernel
def _axis(e):
    """Wheel record ``e``'s spin axis (body frame)."""
    return (e.axis_x, e.axis_y, e.axis_z)


@kernel
def _wheel_rate(w, hk, e, motor):
    """Wheel ``e``'s torque ``h_k'`` [N m] at momentum ``hk``: the ``motor`` torque under its
    speed limit, and friction."""
    omega = relative_speed(w, hk, _axis(e), e.inertia)
    # the drive gives no torque that would spin the wheel past its limit
    motor = 0.0 if (abs(omega) >= e.max_speed) & (motor * omega > 0.0) else motor
    sign = 1.0 if omega > 0.0 else (-1.0 if omega < 0.0 else 0.0)
    return motor - e.viscous * omega - e.coulomb * sign


@kernel
def _slot_rate(w, hw, c, drive, k):
    """``(h_k', a_k)`` of the wheel in slot ``k`` (a constant), or zeros past the last wheel,
    by selects."""
    wheels, motors = drive
    e = wheels[k]
    rate = _wheel_rate(w, hw[k], e, motors[k])
    on = k < int(c.wheel_count)
    return (rate if on else 0.0), (_axis(e) if on else ZERO3)


@kernel
def wheel_rates(w, hw, c, drive):
    """``(hw', h, sum_k a_k h_k')``: the wheels' torques (a 4-tuple, one per slot of
    :data:`~rigid_env.core.layout.MAX_WHEELS`, zeros past the last wheel), and their momentum
    ``h`` and its rate as body-frame 3-vectors, at the body rate ``w`` and momenta ``hw``
    (``drive``: :func:`wheel_drive`)."""
    r0, a0 = _slot_rate(w, hw, c, drive, 0)
    r1, a1 = _slot_rate(w, hw, c, drive, 1)
    r2, a2 = _slot_rate(w, hw, c, drive, 2)
    r3, a3 = _slot_rate(w, hw, c, drive, 3)
    h = axpy(axpy(axpy(axpy(ZERO3, hw[0], a0), hw[1], a1), hw[2], a2), hw[3], a3)
    d = axpy(axpy(axpy(axpy(ZERO3, r0, a0), r1, a1), r2, a2), r3, a3)
    return (r0, r1, r2, r3), h, d


@kernel
def gyrostat(x, v, q, w, hw, act, m, c, drive):
    """``(v', w', hw')`` of a body with wheels (``drive``: :func:`wheel_drive`): the rigid
    body's accelerations (:func:`rigid_env.core.dynamics.accelerations`) with ``-I^-1 (w x h +
    sum_k a_k h_k')`` added (the gyroscopic term of the wheels' momentum taken whatever the
    body's inertia)."""
    a, alpha = accelerations(x, v, q, w, act, m, c, True)
    rates, h, dh = wheel_rates(w, hw, c, drive)
    g = cross(w, h)
    alpha = (
        alpha[0] - (g[0] + dh[0]) * m.inv_inertia_x,
        alpha[1] - (g[1] + dh[1]) * m.inv_inertia_y,
        alpha[2] - (g[2] + dh[2]) * m.inv_inertia_z,
    )
    return a, alpha, rates


def rates(x, v, q, w, hw, act, m, c, drive):
    """``(v', w', hw')`` that an explicit method's flow steps (:mod:`rigid_env.core.integrators`):
    the :func:`gyrostat`'s where the bodies carry wheels (``c.wheels``) and their ``drive``
    (:func:`wheel_drive`) is given, else the rigid body's
    (:func:`rigid_env.core.dynamics.rigid_rates`). Compiled, a ``drive`` of None (a per-body
    step of the rigid body) chooses by its type (the overload below)."""
    if drive is not None and c.wheels != 0.0:
        return gyrostat(x, v, q, w, hw, act, m, c, drive)
    return rigid_rates(x, v, q, w, hw, act, m, c, drive)


@overload(rates, inline="always")
def _rates(x, v, q, w, hw, act, m, c, drive):
    if isinstance(drive, types.NoneType | types.Omitted):
        return lambda x, v, q, w, hw, act, m, c, drive: rigid_rates(
            x, v, q, w, hw, act, m, c, drive
        )

    def either(x, v, q, w, hw, act, m, c, drive):
        if c.wheels != 0.0:
            return gyrostat(x, v, q, w, hw, act, m, c, drive)
        return rigid_rates(x, v, q, w, hw, act, m, c, drive)

    return either


# ---- the wheels' rows of the state columns --------------------------------------------------
@kernel
def wheel_row(c):
    """Row of the first wheel's momentum in the state columns: after ``x, v, q, w``
    (:data:`rigid_env.core.layout.THRUST`; thrusters whose levels lag, the other rows from
    there, never come with wheels: :func:`rigid_env.core.effects.pack` refuses them). A world
    with wheels has :data:`~rigid_env.core.layout.MAX_WHEELS` rows of them, zeros past the last
    wheel (they stay zero: its rates are zero), so that every row is a constant of the pass.
    The world step's passes read them as their own array ``momenta`` (those rows, row 0 the
    first wheel's), which the compiler knows the state's other rows do not overlap."""
    return THRUST


@kernel
def load_wheels(cols, row, i, c):
    """Body ``i``'s wheel momenta from rows ``row`` on of ``cols`` (the state columns, from
    :func:`wheel_row`) as a 4-tuple, zeros past the last wheel (the constant zeros where the
    bodies carry none)."""
    if c.wheels == 0.0:
        return ZERO4
    return cols[row, i], cols[row + 1, i], cols[row + 2, i], cols[row + 3, i]


@kernel
def store_wheels(cols, row, i, c, hw):
    """Write the wheel momenta ``hw`` into body ``i``'s rows from ``row`` on of ``cols``
    (nothing without wheels)."""
    if c.wheels != 0.0:
        cols[row, i], cols[row + 1, i], cols[row + 2, i], cols[row + 3, i] = hw


@kernel
def _slot_reach(w, hw, wheels, c, k):
    """Slot ``k``'s term of :func:`wheel_reach` (0 past the last wheel)."""
    e = wheels[k]
    omega = max(abs(relative_speed(w, hw[k], _axis(e), e.inertia)), e.max_speed)
    torque = e.max_torque + e.coulomb + 2.0 * e.viscous * omega
    return torque if k < int(c.wheel_count) else 0.0


@kernel
def wheel_reach(w, hw, drive, c, m):
    """What the wheels may add to ``B sqrt(2)`` of the guard
    (:func:`rigid_env.core.stepping.force_reach`): their torques on the body, ``sum_k
    (max_torque + coulomb + 2 viscous |Omega_k|) / sqrt(I_min)`` with ``|Omega_k|`` at least the
    wheel's limit (``w x h`` does no work on the body)."""
    wheels, _ = drive
    total = 0.0 + _slot_reach(w, hw, wheels, c, 0) + _slot_reach(w, hw, wheels, c, 1)
    total += _slot_reach(w, hw, wheels, c, 2) + _slot_reach(w, hw, wheels, c, 3)
    return total * m.inv_sqrt_inertia


def __getattr__(name: str):
    """The registry's facts about wheels, by their names here too (:data:`WHEEL_STEPS`,
    :data:`NO_WHEELS` of :mod:`rigid_env.core.integrators`, which imports this module)."""
    if name in ("WHEEL_STEPS", "NO_WHEELS", "wheel_integrators", "check_wheels"):
        from rigid_env.core import integrators

        return getattr(integrators, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
