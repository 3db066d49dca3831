"""Reaction wheels: momentum exchanged inside the body (a gyrostat), compiled.

Wheel ``k`` spins about the body axis ``a_k`` with axial inertia ``J_k``; its state is its
axial angular momentum ``h_k = J_k (a_k . w + Omega_k)`` [N m s] (``Omega_k`` its speed
relative to the body), rows after ``x, v, q, w`` in the state columns. With ``h = sum_k a_k
h_k`` the body obeys (Markley and Crassidis, "Fundamentals of Spacecraft Attitude Determination
and Control", Springer 2014, Sec. 3.3.5; Hughes, "Spacecraft Attitude Dynamics", Ch. 9)

    I w' = tau_ext - w x (I w + h) - sum_k a_k h_k',    h_k' = tau_motor_k + tau_friction_k

with ``I`` the body's inertia without the wheels' axial ``J_k`` (principal, as every body's).
The motor gives ``u_k max_torque_k`` (``u_k`` the command component, in [-1, 1]) and none that
would drive the wheel beyond ``max_speed_k``; the bearing's friction is ``-viscous_k Omega_k -
coulomb_k sign(Omega_k)``, stick-slip at rest. Each flow holds the friction's sign and the
motor's torque (cut where the limit is reached within it) from its start (:func:`hold`), and
:func:`wheel_laws` makes the limit and the friction hold exactly after it, by internal impulses
(the pre-fix law, kept for WheelPointing-v0 only, cuts the motor and reads the sign at each
stage). Without external torque the total ``R (I w + h)`` is constant and
friction moves momentum, never creates it.

An integrator with wheels advances ``(x, v, q, w, h_1 .. h_K)`` together, each stage reading the
wheels' momenta and rates, so it keeps its order: the explicit methods are each written once as a
flow of the body and its wheels (:mod:`rigid_env.core.integrators`), and the world step's passes
(:mod:`rigid_env.core.stepping`) step every world with them, the gyrostat's rates
(:func:`gyrostat`) where the bodies carry wheels; the methods built on the free rigid body's
exact flows refuse wheels (:data:`rigid_env.core.integrators.NO_WHEELS`).

A body's K wheels are K-tuples (momenta, rates, records; K at most
:data:`~rigid_env.core.layout.MAX_WHEELS`), K a constant of their type: the world hands the
step its wheels' rows as a K-tuple (:meth:`rigid_env.core.world.World._wheel_rows`), and every
loop over the wheels is one of K constant trips (:func:`~rigid_env.core.layout.wheel_shape`),
unrolled by the compiler for the K in use: no branch, no inner loop left, so that the
vectorised passes keep their loops.
"""

from __future__ import annotations

from numba import types
from numba.extending import overload

from rigid_env.core.dynamics import accelerations, rigid_rates
from rigid_env.core.jit import kernel
from rigid_env.core.layout import (
    MOTORS,
    ZERO3,
    command_level,
    no_wheel_records,
    wheel,
    wheel_shape,
    with_item,
)
from rigid_env.core.maths import axpy, cross


@kernel
def relative_speed(w, hk, axis, inertia):
    """``Omega_k = h_k / J_k - a_k . w`` [rad/s], the wheel's speed relative to the body."""
    return hk / inertia - (axis[0] * w[0] + axis[1] * w[1] + axis[2] * w[2])


@kernel
def wheel_records(p, c, rows):
    """The K :class:`~rigid_env.core.layout.Wheel` records of the world's K wheels (K =
    ``len(rows)``, the wheels' rows of the state: a constant of their type), read once before
    a pass over the bodies; records of zeros (constants) where the bodies carry no wheels."""
    wheels = no_wheel_records(rows)
    if c.wheels != 0.0:
        for k in range(len(rows)):
            wheels = with_item(wheels, k, wheel(p, c, k))
    return wheels


@kernel
def motor_torques(wheels, c, command, r):
    """Each wheel's motor torque ``u_k max_torque_k`` [N m] (a K-tuple) of row ``r`` of the
    command, held over the step (``wheels``: :func:`wheel_records`); zeros without wheels."""
    motors = wheel_shape(wheels)
    if c.wheels != 0.0:
        for k in range(len(wheels)):
            e = wheels[k]
            level = command_level(command, r, int(e.action))
            motors = with_item(motors, k, level * e.max_torque)
    return motors


@kernel
def wheel_drive(wheels, c, command, r):
    """``(wheels, motors, held)``: the wheel records (:func:`wheel_records`) and their
    :func:`motor_torques` of row ``r`` of the command (``held``: zeros, the signs that
    :func:`hold` sets before each flow); zeros where the bodies carry no wheels.
    Numbers only, so that the integrator's flow gets no array."""
    rest = wheel_shape(wheels)
    if c.wheels == 0.0:
        return wheels, rest, rest
    return wheels, motor_torques(wheels, c, command, r), rest


@kernel
def store_motors(wrenches, i, motors, c):
    """Body ``i``'s motor torques into its rows of the scratch ``wrenches`` (from
    :data:`rigid_env.core.layout.MOTORS`), where the bodies carry wheels."""
    if c.wheels != 0.0:
        for k in range(len(motors)):
            wrenches[MOTORS + k, i] = motors[k]


@kernel
def load_drive(wheels, wrenches, i, c):
    """``(wheels, motors, held)`` as :func:`wheel_drive`, the motor torques read from body
    ``i``'s rows of ``wrenches`` (:func:`store_motors`); zeros without wheels."""
    motors = rest = wheel_shape(wheels)
    if c.wheels != 0.0:
        for k in range(len(wheels)):
            motors = with_item(motors, k, wrenches[MOTORS + k, i])
    return wheels, motors, rest


@kernel
def _axis(e):
    """Wheel record ``e``'s spin axis (body frame)."""
    return (e.axis_x, e.axis_y, e.axis_z)


@kernel
def _sign(x):
    """1, -1 or 0: the sign of ``x``."""
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@kernel
def _wheel_rate(w, hk, e, motor, held):
    """Wheel ``e``'s torque ``h_k'`` [N m] at momentum ``hk``: the ``motor`` torque (as
    :func:`hold` left it: none that pushes a wheel at its limit further), and friction,
    Coulomb's along ``-held`` (the sign of the wheel's speed at the flow's start,
    :func:`hold`). The pre-fix law (``e.pre_fix``) cuts the motor and reads the sign at each
    stage."""
    omega = relative_speed(w, hk, _axis(e), e.inertia)
    old = e.pre_fix != 0.0
    # the pre-fix drive: no torque at a stage beyond the limit
    motor = 0.0 if old & (abs(omega) >= e.max_speed) & (motor * omega > 0.0) else motor
    sign = _sign(omega) if old else held
    return motor - e.viscous * omega - e.coulomb * sign


@kernel
def wheel_rates(w, hw, c, drive):
    """``(hw', h, sum_k a_k h_k')``: the wheels' torques (a K-tuple), and their momentum
    ``h`` and its rate as body-frame 3-vectors, at the body rate ``w`` and momenta ``hw``
    (``drive``: :func:`wheel_drive`)."""
    wheels, motors, held = drive
    rates = wheel_shape(hw)
    h = d = ZERO3
    for k in range(len(hw)):
        e = wheels[k]
        rate = _wheel_rate(w, hw[k], e, motors[k], held[k])
        rates = with_item(rates, k, rate)
        h = axpy(h, hw[k], _axis(e))
        d = axpy(d, rate, _axis(e))
    return rates, h, d


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
# The world step's passes read a world's K wheels' momenta as their own K rows ``momenta`` (a
# K-tuple of (N,) arrays, row k wheel k's: :meth:`rigid_env.core.world.World._wheel_rows`,
# views of the state columns after ``x, v, q, w``), which the compiler knows the state's other
# rows do not overlap; a world without wheels hands one empty float32 row, never read, whose
# type leaves the wheels' passes out of its step (:func:`rigid_env.core.layout.no_wheel_rows`).
@kernel
def load_wheels(momenta, i, c):
    """Body ``i``'s wheel momenta from the wheels' rows ``momenta`` as a K-tuple (the
    constant zeros where the bodies carry none)."""
    hw = wheel_shape(momenta)
    if c.wheels != 0.0:
        for k in range(len(momenta)):
            hw = with_item(hw, k, momenta[k][i])
    return hw


@kernel
def store_wheels(momenta, i, c, hw):
    """Write the wheel momenta ``hw`` into body ``i``'s column of the wheels' rows
    ``momenta`` (nothing without wheels)."""
    if c.wheels != 0.0:
        for k in range(len(momenta)):
            momenta[k][i] = hw[k]


@kernel
def wheel_reach(w, hw, drive, c, m):
    """What the wheels may add to ``B sqrt(2)`` of the guard
    (:func:`rigid_env.core.stepping.force_reach`): their torques on the body, ``sum_k
    (max_torque + coulomb + 2 viscous |Omega_k|) / sqrt(I_min)`` with ``|Omega_k|`` at least the
    wheel's limit (``w x h`` does no work on the body)."""
    wheels = drive[0]
    total = 0.0
    for k in range(len(hw)):
        e = wheels[k]
        omega = max(abs(relative_speed(w, hw[k], _axis(e), e.inertia)), e.max_speed)
        total += e.max_torque + e.coulomb + 2.0 * e.viscous * omega
    return total * m.inv_sqrt_inertia


# ---- the laws that hold inside a step: held friction sign, stick-slip, the speed limit ---------
@kernel
def effective_inertia(e, m):
    """``J_eff = (1/J + a . I^-1 a)^-1`` [kg m^2] of wheel record ``e`` on a body of model
    ``m``: an internal impulse ``dh`` (``+dh`` on the wheel, ``-a dh`` on the body) changes the
    wheel's relative speed by ``dh / J_eff``."""
    return 1.0 / (1.0 / e.inertia + _along(e, m))


@kernel
def _along(e, m):
    """``a . I^-1 a`` of wheel record ``e`` on a body of model ``m``."""
    ax, ay, az = _axis(e)
    return ax * ax * m.inv_inertia_x + ay * ay * m.inv_inertia_y + az * az * m.inv_inertia_z


@kernel
def _held_sign(w, hw, wheels, m, h, k):
    """The sign of slot ``k``'s relative speed, 0 where Coulomb friction stops the wheel within
    ``h`` (``J_eff |Omega| <= coulomb h``: it is then at rest for the step, stick-slip)."""
    e = wheels[k]
    omega = relative_speed(w, hw[k], _axis(e), e.inertia)
    rest = effective_inertia(e, m) * abs(omega) <= e.coulomb * h
    return 0.0 if rest else _sign(omega)


AT_LIMIT = 1.0 - 1e-9
"""A wheel whose relative speed is within this share of its limit is at it (the limit's impulse
puts it there to rounding of the speeds in play, which a large overshoot makes more than an
ulp): its motor gives no torque that pushes it further."""


@kernel
def _held_motor(w, hw, wheels, motors, m, h, k):
    """Slot ``k``'s motor torque held over a flow of ``h``: the drive's torque cut where the
    limit is reached within it, as an average: ``motor min(1, t* / h)``, ``t* = J_eff (max_speed
    - Omega sign(motor)) / |motor|`` the time the motor alone takes to the limit on its side
    (friction only delays it: the wheel then ends short of the limit, never past it by more
    than the gyroscopic coupling, which :func:`wheel_laws` takes back). 0 at or beyond the limit
    (to :data:`AT_LIMIT`); ``motor`` itself where it does not reach it. The pre-fix law's wheel
    keeps its torque: it cuts at each stage."""
    e = wheels[k]
    omega = relative_speed(w, hw[k], _axis(e), e.inertia)
    motor = motors[k]
    room = e.max_speed - (omega if motor > 0.0 else -omega)
    room = 0.0 if room <= e.max_speed * (1.0 - AT_LIMIT) else room
    reach = abs(motor) * h  # the impulse the motor gives over h
    share = min(1.0, effective_inertia(e, m) * room / reach) if reach > 0.0 else 1.0
    share = 0.0 if room == 0.0 else share
    return motor if e.pre_fix != 0.0 else motor * share


@kernel
def hold(drive, w, hw, m, h):
    """``drive`` for a flow of ``h`` from ``(w, hw)``: each wheel's friction sign and motor
    torque held over it (the flow's rates then smooth; where no stage crosses zero or the
    limit, the same numbers as a sign and a cut read at each stage). ``held``: the signs of the
    relative speeds, 0 for a wheel that friction stops within ``h`` (:func:`wheel_laws` then
    sticks or slips it); the motors cut where they reach the limit within ``h``
    (:func:`_held_motor`); a wheel the flow carries past it :func:`wheel_laws` puts back at
    it."""
    wheels, motors, _ = drive
    held = cut = wheel_shape(hw)
    for k in range(len(hw)):
        held = with_item(held, k, _held_sign(w, hw, wheels, m, h, k))
        cut = with_item(cut, k, _held_motor(w, hw, wheels, motors, m, h, k))
    return wheels, cut, held


@kernel
def _impulse(w, hw, drive, m, h, k, friction, inertias):
    """``(w, hw)`` after wheel ``k``'s internal impulse (:func:`wheel_laws`; ``inertias``: the
    wheels' :func:`effective_inertia`): with ``friction`` (a constant) Coulomb's stick-slip,
    then the speed limit; unchanged (by selects) for a pre-fix wheel and where no law acts."""
    wheels, motors, held = drive
    e = wheels[k]
    a = _axis(e)
    j = inertias[k]
    omega = relative_speed(w, hw[k], a, e.inertia)
    stop = -j * omega  # the impulse that stops the wheel relative to the body
    s0 = held[k]
    reach = e.coulomb * h
    slip = max(-reach, min(reach, stop))  # from rest: stuck while it stops it
    d = abs(motors[k])
    total = e.coulomb + d
    share = min(1.0, 2.0 * e.coulomb / max(total, 1e-300))
    crossed = s0 * omega < 0.0
    dh = stop * share if crossed else (slip if s0 == 0.0 else 0.0)
    dh = dh if friction else 0.0
    after = omega + dh * (1.0 / e.inertia + _along(e, m))
    target = e.max_speed if after > 0.0 else -e.max_speed
    dh += j * (target - after) if abs(after) > e.max_speed else 0.0
    on = (e.pre_fix == 0.0) & (dh != 0.0)
    w1 = (
        w[0] - dh * a[0] * m.inv_inertia_x,
        w[1] - dh * a[1] * m.inv_inertia_y,
        w[2] - dh * a[2] * m.inv_inertia_z,
    )
    return (w1 if on else w), with_item(hw, k, hw[k] + dh) if on else hw


@kernel
def _sweep(w, hw, drive, m, h, js, friction):
    """One sweep of the wheels' impulses in wheel order (:func:`wheel_laws`; ``friction``: a
    constant)."""
    for k in range(len(hw)):
        w, hw = _impulse(w, hw, drive, m, h, k, friction, js)
    return w, hw


@kernel
def wheel_laws(w, hw, drive, c, m, h):
    """``(w, hw)`` after a flow of ``h`` of a body with wheels (``drive`` as :func:`hold` gave
    it), by internal impulses between each wheel and the body (``+dh_k`` on wheel ``k``,
    ``-I^-1 a_k dh_k`` on the body's rate), in slot order:

    * Coulomb friction, stick-slip: a wheel at rest for the step (``held`` 0, :func:`hold`;
      the flow had no Coulomb torque) gets the impulse of at most ``coulomb h`` that stops it
      relative to the body (stuck while the drive and the body's motion ask for no more:
      ``|drive| <= coulomb``);
      a wheel whose speed crossed zero under the held friction is taken back toward zero by
      ``J_eff |Omega| min(1, 2 coulomb / (coulomb + |motor|))`` (the friction past the stop
      was ``-coulomb`` held where it is ``+coulomb`` under a larger motor, ``-motor`` (stuck)
      under a smaller one), never past it;
    * the speed limit: a wheel beyond ``+-max_speed`` is put at it, ``dh = J_eff (+-max_speed -
      Omega)``; then, where the wheels couple (``c.wheels_coupled``), three sweeps of the
      limit alone (Gauss-Seidel: the other wheels' impulses move the body, so wheel ``j``'s
      speed by ``a_j . I^-1 a_k dh_k``). Wheels whose axes share no nonzero component (along
      the body's principal axes) do not couple: each is at its limit to rounding after the
      first sweep, and the three are left out. Otherwise what a sweep leaves beyond the
      limit falls each sweep by ``r = max J_eff |a_j . I^-1 a_k|`` (``J / I``: 2e-3 for a 3U
      CubeSat's wheel pyramid), to ``r^4`` of the step's overshoot after the four.

    Total momentum: ``I dw = -a_k dh_k`` and ``dh = a_k dh_k``, so ``I w + h`` is unchanged (to
    rounding). Energy: ``T = w.I w / 2 + sum_k h_k^2 / (2 J_k)``; along the impulse ``s`` from 0
    to ``dh``, ``dT/ds = h_k / J_k - a_k . w = Omega_k(s)``, linear in ``s`` with slope
    ``1 / J_eff``, so ``dT = dh (Omega + Omega') / 2``. Each impulse opposes ``Omega`` and
    leaves ``Omega'`` of its sign or zero, ``|Omega'| <= |Omega|``: ``dT = -J_eff (Omega^2 -
    Omega'^2) / 2 <= 0``. No impulse raises the kinetic energy; no friction impulse reverses a
    wheel. Where no wheel crosses its limit, none was at rest and none crossed zero, ``(w,
    hw)`` is returned as it came (selects), so the numbers are those of the flow alone."""
    wheels = drive[0]
    js = wheel_shape(hw)
    for k in range(len(hw)):
        js = with_item(js, k, effective_inertia(wheels[k], m))
    w, hw = _sweep(w, hw, drive, m, h, js, True)
    if c.wheels_coupled == 0.0:  # no impulse moved another wheel: each is at its limit
        return w, hw
    w, hw = _sweep(w, hw, drive, m, h, js, False)
    w, hw = _sweep(w, hw, drive, m, h, js, False)
    return _sweep(w, hw, drive, m, h, js, False)


def __getattr__(name: str):
    """The registry's facts about wheels, by their names here too (:data:`WHEEL_STEPS`,
    :data:`NO_WHEELS` of :mod:`rigid_env.core.integrators`, which imports this module)."""
    if name in ("WHEEL_STEPS", "NO_WHEELS", "wheel_integrators", "check_wheels"):
        from rigid_env.core import integrators

        return getattr(integrators, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
