"""The world step's passes over the bodies, compiled: one integrator's substeps, the speed
limit, the damping maps after the last substep, and the guard that keeps a body's last finite
state. Written once; the compiled integrators (:func:`advance`) and the array integrator
``exact_free`` (:func:`limit_speed_pass`, :func:`kicks`, :func:`finish_pass`) share them.

Arrays: the world's parameters ``p`` and model columns (:mod:`rigid_env.core.layout`), the state
columns ``state`` (13, N) ``(x, v, q, w)``, the bodies' ``status`` (N,) uint8, the actuators'
``wrenches`` (WRENCH_WIDTH, N), the reaction wheels' ``momenta``, a K-tuple of (N,) rows (their
rows of the state, handed over as their own arrays: :meth:`rigid_env.core.world.World._wheel_rows`;
without wheels :func:`rigid_env.core.layout.no_wheel_rows`, one empty float32 row never read),
the ``places`` of a world on an orbit (:data:`rigid_env.core.layout.PLACE_ROWS`, N) (off one
:func:`rigid_env.core.layout.no_places`, never read) and the ``command`` (N | 1, A).
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange, types
from numba.extending import overload

from rigid_env.core.compose import (
    add_actuator_torque_bounds,
    add_force_bounds,
    add_potential_roots,
    add_torque_bounds,
    any_potential,
    common,
    orbiting,
    orbiting_wheeled,
    orbiting_wheeled_apart,
    per_body,
    rare,
    wheeled,
    wheeled_apart,
)
from rigid_env.core.dynamics import (
    ZERO_WRENCH,
    accelerations,
    kick,
    kinetic_energy,
    wrench,
)
from rigid_env.core.jit import is_flow, kernel, pass_kernel
from rigid_env.core.layout import (
    BAD_COMMAND,
    FAILED,
    HEALTHY,
    REACH,
    ZERO3,
    Surroundings,
    beyond_of,
    body_model,
    carries_wheels,
    failures_of,
    load,
    load_wrench,
    on_orbit,
    step_code,
    store,
    store_wrench,
    surroundings_of,
    unpack,
)
from rigid_env.core.maths import norm
from rigid_env.core.orbit_state import body_position, tick, where
from rigid_env.core.threads import split_range
from rigid_env.core.thrusters import next_switch, segment_wrench
from rigid_env.core.wheels import (
    gyrostat,
    hold,
    load_drive,
    load_wheels,
    motor_torques,
    store_motors,
    store_wheels,
    wheel_drive,
    wheel_laws,
    wheel_reach,
    wheel_records,
)


# ---- one body ---------------------------------------------------------------------------------
@kernel
def clamp(w, limit):
    """PhysX's ``setMaxAngularVelocity``: ``w`` scaled down to ``|w| = limit`` when above it,
    its direction kept (a non-finite ``w`` stays non-finite for the guard)."""
    s2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
    if s2 > limit * limit:
        f = limit / math.sqrt(s2)
        return (w[0] * f, w[1] * f, w[2] * f)
    return w


@kernel
def limit_speed(w, c):
    """``w`` under the world's speed limit, if it has one (``c``: the named parameters)."""
    return clamp(w, c.max_speed_value) if c.max_speed != 0.0 else w


@kernel
def step_maps(v, w, c):
    """The maps after a world step's last substep: the speed limit, then the seed's damping
    ``v <- alpha v``, ``w <- alpha w`` of the effects listed."""
    w = limit_speed(w, c)
    if c.linear_damping != 0.0:
        a = c.linear_alpha
        v = (v[0] * a, v[1] * a, v[2] * a)
    if c.angular_damping != 0.0:
        a = c.angular_alpha
        w = (w[0] * a, w[1] * a, w[2] * a)
    return v, w


@kernel
def _finite(x, q, energy):
    """Whether every number of a body's state is finite, without a branch: ``a - a`` is 0 for a
    finite ``a`` and NaN for an inf or a NaN; ``v`` and ``w`` by their kinetic ``energy`` (a
    sum of their squares with positive weights: finite only where they are)."""
    z = (x[0] - x[0]) + (x[1] - x[1]) + (x[2] - x[2]) + (energy - energy)
    return z + ((q[0] - q[0]) + (q[1] - q[1]) + (q[2] - q[2]) + (q[3] - q[3])) == 0.0


EXPLOSION_FACTOR = 10.0
"""How far beyond the reach of the applied forces ``sqrt(E)`` may get in one step before the
guard fails the body (its kinetic energy ``100 x`` beyond). Reach: with power ``P = F . v + tau
. w`` (drag only dissipates, ``F . v_p <= 0``) and ``|v| <= sqrt(2 E / m)``, ``|w| <= sqrt(2 E /
I_min)``, ``d sqrt(E) / dt = P / (2 sqrt(E)) <= B = (|F| / sqrt(m) + |tau| / sqrt(I_min)) /
sqrt(2)`` with ``F`` the actuators' force and the effects' bounds (gravity's ``m g``, a
conservative effect's potential span instead, :func:`energy_root`): the exact flow ends with
``sqrt(E1) <= sqrt(E0) + h B``. A method adds its own one-step error; the largest inside the
stable ranges is forward Euler's, torque-free ``E1 = E0 + h^2 / 2 f . I f`` with Euler's rates
``I_i f_i^2 = (I_j - I_k)^2 w_j^2 w_k^2 / I_i <= max(I_j, I_k) w_j^2 w_k^2 <= 2 E |w|^2`` for a
real body (``|I_j - I_k| <= I_i``), so ``E1 / E0 <= 1 + 3 (h |w|)^2``: 13 (a factor 3.6 in
``sqrt(E)``) at ``h |w| = 2``, the widest stated range (``splitting``). A factor 10 leaves room
for that and trips only where the state explodes: the three-axis splitting's ``|w|`` 2.4 ->
5e95 in one step of a needle of moment 1e-100, forward Euler past ``h |w| = 5.7``."""


@kernel
def start_energy(x, v, w, m, c):
    """Where a body's reach starts, as an energy [J]: its kinetic energy ``E0``, or with a
    conservative effect listed ``(sqrt(E0) + sum sqrt(dV))^2`` (:func:`energy_root`)."""
    if not any_potential(c):
        return kinetic_energy(v, w, m)
    root = energy_root(x, v, w, m, c)
    return root * root


@kernel
def energy_root(x, v, w, m, c):
    """Where a body's reach starts: ``sqrt(E0)`` [J^(1/2)] plus the ``sqrt(dV)`` each listed
    conservative effect declares (its ``potential_bound``: the most potential energy it can
    release, :mod:`rigid_env.core.effect`)."""
    return add_potential_roots(math.sqrt(kinetic_energy(v, w, m)), x, m, c)


@kernel
def held_reach(span, reach):
    """``span B``: what forces of reach ``reach`` (:func:`force_reach`) held for ``span`` [s]
    add to ``sqrt(E)``, ``B = reach / sqrt(2)``."""
    return span * reach * math.sqrt(0.5)


@kernel
def within_reach(energy, reach):
    """Whether a body may end a step with the kinetic ``energy`` [J] (:data:`EXPLOSION_FACTOR`):
    ``sqrt(energy) <= 10 (sqrt(start) + span)``, ``reach = (start, span)``: ``start`` the energy
    the step started from (:func:`start_energy`), ``span`` what the forces add to ``sqrt(E)``
    over the step (the sum of :func:`held_reach`). Without a square root: with ``d = energy /
    100 - start - span^2`` that is ``d <= 0`` or ``d^2 <= 4 span^2 start`` (the inequality
    squared, both sides >= 0 where ``d > 0``). False for a NaN. Where both squares overflow
    (``d > 1e154`` J and ``span^2 start > 4e307``, far beyond any body's energy) it says within."""
    start, span = reach
    d = energy * (1.0 / (EXPLOSION_FACTOR * EXPLOSION_FACTOR)) - start - span * span
    return (d <= 0.0) | (d * d <= 4.0 * (span * span) * start)


@kernel
def force_reach(act, m, c):
    """``B sqrt(2)`` of :data:`EXPLOSION_FACTOR` for the wrench ``act`` and the listed effects'
    force and torque bounds (:mod:`rigid_env.core.effect`) and the actuators' declared torque
    bounds (:mod:`rigid_env.core.actuator`): ``(|F| + sum B_F) / sqrt(m) + (|tau| + sum B_tau)
    / sqrt(I_min)``."""
    s = surroundings_of(act)
    torque = add_actuator_torque_bounds(norm(act[1]), act, c)
    forces = add_force_bounds(norm(act[0]), m, c, s)
    return forces * m.inv_sqrt_mass + add_torque_bounds(torque, m, c, s) * m.inv_sqrt_inertia


@kernel
def guard(state, status, i, new, old, m, reach):
    """Column ``i`` of ``state`` by selects: a healthy body (:data:`HEALTHY`) takes its finite
    ``new`` state whose kinetic energy is within ``reach = (start, span)``
    (:func:`within_reach`), else keeps ``old`` and gets :data:`FAILED`; a frozen one keeps
    ``old``. Returns ``(ok, failed)``: whether ``new`` was taken, whether the body failed here."""
    x, v, q, w = new
    x0, v0, q0, w0 = old
    healthy = status[i] == HEALTHY
    energy = kinetic_energy(v, w, m)
    ok = healthy & _finite(x, q, energy) & within_reach(energy, reach)
    failed = healthy & ~ok
    status[i] = FAILED if failed else status[i]
    store(state, i, x if ok else x0, v if ok else v0, q if ok else q0, w if ok else w0)
    return ok, failed


@kernel
def beyond(w, c, ok):
    """1 if a body that took its new state spins past the integrator's stable ``|w|``, else 0."""
    fast = w[0] * w[0] + w[1] * w[1] + w[2] * w[2] > c.stable_speed * c.stable_speed
    return 1 if ok & fast & (c.stable_speed != 0.0) else 0


def integrate(step, body, act, m, c, h, counts, i, drive):
    """``step`` of body ``i``, ``body = (x, v, q, w, hw)`` (``hw``: its wheels' momenta, a
    K-tuple), over ``h``; returns the same five. ``step`` is an explicit method's flow
    (:func:`rigid_env.core.jit.flow_kernel`), which advances the wheels too under the
    gyrostat's rates where the bodies carry wheels (``drive``: their numbers and motor
    torques, :func:`rigid_env.core.wheels.wheel_drive`), else the rigid body's; or a per-body step
    of ``(x, v, q, w)`` that leaves ``hw`` as it is (a world with wheels refuses it). Then
    ``counts`` None: a fixed-step integrator, whose step returns ``(x, v, q, w)``; else (2, N):
    an error-controlled one, whose step takes ``(h, counts[1, i])``, the substep to try first
    (0: its own guess), and returns the substeps it took, added to ``counts[0, i]``, and the
    substep the next should try first, into ``counts[1, i]``. Compiled, the choice is made by
    the types of ``step`` and ``counts`` (the overload below), so a fixed-step integrator's
    loop is unchanged. With wheels the flow holds each wheel's friction sign
    (:func:`rigid_env.core.wheels.hold`) and is followed by the wheels' laws
    (:func:`rigid_env.core.wheels.wheel_laws`: stick-slip and the speed limit, by internal
    impulses), so that no (sub)step carries a wheel past its limit or reverses it by friction."""
    if is_flow(step):
        return _wheel_flow(step, body, act, m, c, h, drive)
    x, v, q, w, hw = body
    if counts is None:
        return (*step(x, v, q, w, act, m, c, h), hw)
    x, v, q, w, n, first = step(x, v, q, w, act, m, c, (h, counts[1, i]))
    counts[0, i] += n
    counts[1, i] = first
    return x, v, q, w, hw


@kernel
def _wheel_flow(step, body, act, m, c, h, drive):
    """The flow ``step`` of ``body`` over ``h``, under the wheels' laws where it carries wheels
    (:func:`integrate`)."""
    if drive is not None and c.wheels != 0.0:
        held = hold(drive, body[3], body[4], m, h)
        x, v, q, w, hw = step(body, act, m, c, held, h)
        w, hw = wheel_laws(w, hw, held, c, m, h)
        return x, v, q, w, hw
    return step(body, act, m, c, drive, h)


def clear_counts(counts, bodies):
    """``counts[0, start:stop] = 0`` for ``bodies = (start, stop)``; nothing for None."""
    if counts is not None:
        counts[0, bodies[0] : bodies[1]] = 0


def _none(counts):
    return isinstance(counts, types.NoneType | types.Omitted)


@overload(integrate, inline="always")
def _integrate(step, body, act, m, c, h, counts, i, drive):
    if is_flow(step.dispatcher):

        def flow(step, body, act, m, c, h, counts, i, drive):
            return _wheel_flow(step, body, act, m, c, h, drive)

        return flow

    if _none(counts):

        def fixed(step, body, act, m, c, h, counts, i, drive):
            x, v, q, w, hw = body
            x1, v1, q1, w1 = step(x, v, q, w, act, m, c, h)
            return x1, v1, q1, w1, hw

        return fixed

    def counted(step, body, act, m, c, h, counts, i, drive):
        x, v, q, w, hw = body
        x1, v1, q1, w1, n, first = step(x, v, q, w, act, m, c, (h, counts[1, i]))
        counts[0, i] += n
        counts[1, i] = first
        return x1, v1, q1, w1, hw

    return counted


@overload(clear_counts, inline="always")
def _clear_counts(counts, bodies):
    if _none(counts):
        return lambda counts, bodies: None

    def clear(counts, bodies):
        for i in range(bodies[0], bodies[1]):
            counts[0, i] = 0

    return clear


@kernel
def begin_substep(state, momenta, model, i, c):
    """The first stages of a substep of body ``i``, shared by both passes: its state before
    (``old``), its model, its ``w`` under the speed limit and its wheels' momenta (the constant
    zeros without wheels)."""
    old = load(state, i)
    hw = load_wheels(momenta, i, c)
    return old, body_model(model, i), limit_speed(old[3], c), hw


@kernel
def command_row(command, i):
    """The row of the command (N | 1, A) that body ``i`` reads (of ``i``'s integer type)."""
    return i if command.shape[0] > 1 else i - i


@kernel
def end_substep(world, i, states, m, reach, c, last):
    """The last stages of a substep of body ``i``, shared by both passes: on the ``last``
    substep :func:`step_maps`, then the :func:`guard` of ``states = (new, old)``, each ``(x, v,
    q, w, hw)``, with the ``reach`` (a non-finite wheel momentum fails the body as a
    non-finite ``x`` would), and the wheels' momenta where the body took its new state.
    Returns ``(failed, beyond)``, each 0 or 1."""
    state, status, momenta = world
    (x, v, q, w, hw), (x0, v0, q0, w0, hw0) = states
    if last:
        v, w = step_maps(v, w, c)
    if c.wheels != 0.0:
        total = 0.0
        for k in range(len(hw)):
            total += hw[k]
        x = x if total - total == 0.0 else (math.nan, math.nan, math.nan)  # an inf or NaN
    ok, failed = guard(state, status, i, (x, v, q, w), (x0, v0, q0, w0), m, reach)
    store_wheels(momenta, i, c, hw if ok else hw0)
    return (1 if failed else 0), (beyond(w, c, ok) if last else 0)


@pass_kernel
def substep(step, c, wheels, world, at, counts):
    """One integrator step of body ``i`` in place on its column of ``state``, after the speed
    limit (if set); on the ``last`` substep also :func:`step_maps`. Then the :func:`guard`.
    ``wheels``: the wheel records (:func:`rigid_env.core.wheels.wheel_records`, read before
    the pass; their motor torques are in ``wrenches``, :data:`rigid_env.core.layout.MOTORS`),
    ``world = (model, wrenches, state, status)``, ``at = (i, last, actuated)``:
    without actuators (``actuated`` False, the same for every body of the pass) the wrench is
    the constant zero and the reach gravity's, and ``wrenches`` is not read. Where the bodies
    carry wheels (``c.wheels``, a constant of the pass) their momenta ride through the step.
    Returns ``(failed, beyond)``, each 0 or 1. ``counts``: None, or the substeps each body took
    (:func:`integrate`)."""
    model, wrenches, state, status, momenta = world
    i, last, actuated = at
    old, m, w, hw = begin_substep(state, momenta, model, i, c)
    x0, v0, q0, _ = old
    act = load_wrench(wrenches, i, c) if actuated else ZERO_WRENCH
    forces = wrenches[REACH, i] if actuated else force_reach(ZERO_WRENCH, m, c)
    drive = load_drive(wheels, wrenches, i, c)
    if c.wheels != 0.0:
        forces += wheel_reach(w, hw, drive, c, m)
    reach = (start_energy(x0, v0, w, m, c), held_reach(c.h, forces))
    new = integrate(step, (x0, v0, q0, w, hw), act, m, c, c.h, counts, i, drive)
    return end_substep((state, status, momenta), i, (new, (*old, hw)), m, reach, c, last)


@pass_kernel
def body_substep(step, p, model, command, world, when, i, counts):
    """:func:`substep` ``k`` of body ``i``, every effect included (:func:`body_advance`): the
    speed limit, then one ``step`` per segment of the substep ``[k h, (k + 1) h]`` (with
    thrusters as hardware, :mod:`rigid_env.core.thrusters`, split at the on/off switch times
    inside it; else one segment of ``h``), each with the thrusters' wrench held over it (and
    the wheels' momenta riding through it where the bodies carry wheels); on the ``last``
    substep (which ends at ``dt``) also :func:`step_maps`; then the :func:`guard`.
    Where the bodies move on an orbit (``c.orbit``, :mod:`rigid_env.core.orbit_state`) the
    substep reads where the body is at its middle from the orbit state, held over it: its ``x``
    (the effects' position: the gravity gradient's direction), with a field
    (``c.field_degree``) the field the magnetorquers act in, and the surroundings the effects
    that read them see (:class:`rigid_env.core.layout.Surroundings`: the sunlight, the air),
    carried as the actuation's fifth part (the next substep reads its own);
    the last substep leaves ``x`` at the orbit's position at the world step's end and advances
    the clock by ``dt``.
    ``world = (state, status)``, ``when = (k, last)``; ``counts`` as :func:`integrate`'s.
    Returns ``(failed, beyond)``."""
    state, status, momenta = world
    k, last = when
    c = unpack(p)
    old, m, w, hw0 = begin_substep(state, momenta, model, i, c)
    hw = hw0
    x, v, q, _ = old
    t = k * c.h
    t1 = c.dt if last else (k + 1) * c.h
    field, around = ZERO3, Surroundings(p, ZERO3, 0.0, ZERO3, 0.0)
    if c.orbit != 0.0:  # where the body is at the substep's middle, held over it
        x, field, around = where(p, c, state, i, 0.5 * (t + t1))
    start, span = start_energy(x, v, w, m, c), 0.0  # span: + s B a segment
    drive = wheel_drive(wheel_records(p, c, momenta), c, command, command_row(command, i))
    while t < t1:
        if c.hardware != 0.0:
            end = next_switch(p, c, command, i, t, t1)
            act = segment_wrench(p, c, model, command, state, i, t, end - t)
            h = end - t
        else:
            end = t1
            act = wrench(p, c, model, command, i)
            h = c.h
        if c.field_degree != 0.0:
            act = (act[0], act[1], act[2], field)
        held = (act[0], act[1], act[2], act[3], around)  # and the surroundings, held too
        forces = force_reach(held, m, c)
        if c.wheels != 0.0:
            forces += wheel_reach(w, hw, drive, c, m)
        span += held_reach(h, forces)
        x, v, q, w, hw = integrate(step, (x, v, q, w, hw), held, m, c, h, counts, i, drive)
        t = end
    if c.orbit != 0.0 and last:  # the body's position at the world step's end
        x = body_position(state, c, i, t1)
    new = (x, v, q, w, hw)
    world = (state, status, momenta)
    out = end_substep(world, i, (new, (*old, hw0)), m, (start, span), c, last)
    if c.orbit != 0.0 and last:
        tick(state, c, i, status[i] == HEALTHY)
    return out


@pass_kernel
def body_advance(step, p, model, world, command, bodies, counts):
    """:func:`advance` of bodies ``start <= i < stop`` (``bodies``) body by body, every effect
    included (the :data:`rigid_env.core.compose.RARE` ones too): each body's substeps by
    :func:`body_substep`. Returns the step's code."""
    c = unpack(p)
    start, stop = bodies
    clear_counts(counts, bodies)
    failures = over = 0
    substeps = int(c.substeps)
    for i in range(start, stop):
        for k in range(substeps):
            last = k == substeps - 1
            failed, past = body_substep(step, p, model, command, world, (k, last), i, counts)
            failures += failed
            over += past
    return step_code(failures, min(over, 1))


# ---- the world step of a compiled integrator -------------------------------------------------
@pass_kernel
def advance(step, p, model, world, command, bodies, counts=None):
    """One world step of the bodies ``start <= i < stop`` (``bodies``), in passes whose loops
    the compiler vectorises (struct-of-arrays columns; no call, inner loop or branch in the
    body, only selects): the actuators' wrench of each body's command (:func:`wrench`), if
    any, then ``substeps`` passes of the per-body ``step`` in place (:func:`substep`). These
    passes see the flags of the rarely used effects (:data:`rigid_env.core.compose.RARE`) as the
    constant 0, so a disabled one adds nothing to their loops; a world that has one is stepped
    by :func:`rare_passes`: on an orbit, in the orbit's vectorised passes (:func:`orbit_passes`),
    else body by body (:func:`body_advance`), every effect included. Where the bodies carry
    reaction wheels the passes are those compiled with the wheels' flag the constant 1
    (:func:`vector_passes`); a world without them runs passes with no wheel code.

    The world's arrays must not overlap (:data:`rigid_env.core.jit.world_kernel` compiles on
    that promise); the entries take them one by one (a tuple from Python would cost atomic
    reference counts) and hand them on grouped (``world``), which costs nothing once inlined.
    A failed body's column is left at its last finite state (before the world step for one
    substep, else before the failing substep, which :class:`rigid_env.core.world.World`
    replaces by the one before the world step); a frozen body is left alone.

    ``world = (state, status, wrenches, momenta, places)``: the state columns, the bodies'
    status, the scratch of each body's wrench and reach
    (:data:`rigid_env.core.layout.WRENCH_WIDTH`), the wheels' rows and the orbit's scratch.
    ``counts``: None for a fixed-step integrator; for an error-controlled one (2, N): row 0
    set to the substeps each body took (over the ``substeps`` passes), row 1 the substep each
    tries first, carried from step to step (:func:`integrate`).

    Returns:
        the step's code (:func:`rigid_env.core.layout.step_code`), or
        :data:`~rigid_env.core.layout.BAD_COMMAND` (nothing stepped) if the command has a NaN
        or inf.
    """
    for r in range(command.shape[0]):
        for a in range(command.shape[1]):
            if not math.isfinite(command[r, a]):
                return BAD_COMMAND
    if rare(unpack(p)):
        return rare_passes(step, p, model, world, command, bodies, counts)
    return vector_passes(step, p, model, world, command, bodies, counts)


def rare_passes(step, p, model, world, command, bodies, counts):
    """The world step of a world with a :data:`rigid_env.core.compose.RARE` flag set: the orbit's
    vectorised passes (:func:`orbit_passes`) where the bodies move on an orbit and no
    :data:`rigid_env.core.compose.PER_BODY` flag is set, else body by body
    (:func:`body_advance`). Compiled, a world off an orbit (the type of its ``places``,
    :func:`rigid_env.core.layout.on_orbit`) compiles no orbit passes (the overload below)."""
    state, status, _, momenta, _ = world
    if on_orbit_type(world) and not per_body(unpack(p)):
        return orbit_variant(step, p, model, world, command, bodies, counts)
    return body_advance(step, p, model, (state, status, momenta), command, bodies, counts)


def on_orbit_type(world) -> bool:
    """Whether ``world``'s ``places`` are a world on an orbit's (plain Python: any rows)."""
    return world[4].size > 0


def orbit_variant(step, p, model, world, command, bodies, counts):
    """:func:`orbit_passes` under the named parameters with the wheels' flags as constants
    (:func:`rigid_env.core.compose.orbiting_wheeled`, ``_apart``) where the bodies carry wheels
    and ``step`` is a flow, else without wheels (:func:`rigid_env.core.compose.orbiting`)."""
    c = unpack(p)
    if c.wheels != 0.0 and is_flow(step):
        d = orbiting_wheeled(c) if c.wheels_coupled != 0.0 else orbiting_wheeled_apart(c)
        return orbit_passes(step, d, p, model, world, command, bodies, counts)
    return orbit_passes(step, orbiting(c), p, model, world, command, bodies, counts)


@overload(rare_passes, inline="always")
def _rare_passes(step, p, model, world, command, bodies, counts):
    if on_orbit(world.types[4]):

        def either(step, p, model, world, command, bodies, counts):
            state, status, _, momenta, _ = world
            if not per_body(unpack(p)):
                return orbit_variant(step, p, model, world, command, bodies, counts)
            return body_advance(step, p, model, (state, status, momenta), command, bodies, counts)

        return either

    def body(step, p, model, world, command, bodies, counts):
        state, status, _, momenta, _ = world
        return body_advance(step, p, model, (state, status, momenta), command, bodies, counts)

    return body


@overload(orbit_variant, inline="always")
def _orbit_variant(step, p, model, world, command, bodies, counts):
    if is_flow(step.dispatcher) and carries_wheels(world.types[3]):

        def wheeled_or_not(step, p, model, world, command, bodies, counts):
            c = unpack(p)
            if c.wheels != 0.0:
                if c.wheels_coupled != 0.0:
                    d = orbiting_wheeled(c)
                    return orbit_passes(step, d, p, model, world, command, bodies, counts)
                d = orbiting_wheeled_apart(c)
                return orbit_passes(step, d, p, model, world, command, bodies, counts)
            return orbit_passes(step, orbiting(c), p, model, world, command, bodies, counts)

        return wheeled_or_not

    def plain(step, p, model, world, command, bodies, counts):
        return orbit_passes(step, orbiting(unpack(p)), p, model, world, command, bodies, counts)

    return plain


@pass_kernel
def orbit_passes(step, c, p, model, world, command, bodies, counts):
    """The vectorised passes of a world on an orbit (:func:`rare_passes`), under the named
    parameters ``c`` whose :data:`rigid_env.core.compose.PER_BODY` flags and wheels' flags
    are constants and whose other rare flags are read (the gravity gradient, the coils): the
    numbers of :func:`body_advance`, bit for bit, in passes over the bodies. Each body's
    wrench and its wheels' motor torques once; then per substep a pass of where each body is
    at the substep's middle (:func:`place_pass`: the orbit's Kepler solve and the field, whose
    loops keep it from vectorising) and the vectorised pass of :func:`orbit_substep`; after the
    last, each body's clock (:func:`rigid_env.core.orbit_state.tick`). Returns the step's
    code."""
    start, stop = bodies
    state, status, wrenches, momenta, places = world
    wheels = wheel_records(p, c, momenta)
    for i in range(start, stop):  # each body's wrench (the field's rows set per substep)
        store_wrench(wrenches, i, wrench(p, c, model, command, i), c)
        store_motors(wrenches, i, motor_torques(wheels, c, command, command_row(command, i)), c)
    clear_counts(counts, bodies)
    substeps = int(c.substeps)
    arrays = (model, wrenches, state, status, momenta, places)
    for k in range(substeps):
        last = k == substeps - 1
        place_pass(p, c, arrays, bodies, (k, last))
        for i in range(start, stop):
            j = np.uint64(i)  # unsigned, as in passes: the loop vectorises
            orbit_substep(step, c, wheels, arrays, (j, last), counts)
    for i in range(start, stop):
        tick(state, c, i, status[i] == HEALTHY)
    return tally(state, status, c, bodies)


@kernel
def place_pass(p, c, world, bodies, when):
    """Where each body is at the middle of substep ``k`` (``when = (k, last)``), held over it
    as :func:`body_substep` holds it: its position into rows 0:3 of ``places``, the field there
    into its wrench's field rows, its reach for the guard (:func:`force_reach`, which the coils'
    dipole in that field bounds) into :data:`REACH`; on the ``last`` substep also its position
    at the world step's end into rows 3:6."""
    model, wrenches, state, _, _, places = world
    k, last = when
    t = k * c.h
    t1 = c.dt if last else (k + 1) * c.h
    for i in range(bodies[0], bodies[1]):
        x, field, _ = where(p, c, state, i, 0.5 * (t + t1))
        places[0, i], places[1, i], places[2, i] = x
        if c.field_degree != 0.0 and c.dipoles != 0.0:
            wrenches[10, i], wrenches[11, i], wrenches[12, i] = field
        wrenches[REACH, i] = force_reach(load_wrench(wrenches, i, c), body_model(model, i), c)
        if last:
            places[3, i], places[4, i], places[5, i] = body_position(state, c, i, t1)


@pass_kernel
def orbit_substep(step, c, wheels, world, at, counts):
    """:func:`substep` of body ``i`` on its orbit (``at = (i, last)``): from its place at the
    substep's middle (:func:`place_pass`) under the wrench and reach held there; on the
    ``last`` substep it ends at its place at the world step's end. Returns ``(failed,
    beyond)``."""
    model, wrenches, state, status, momenta, places = world
    i, last = at
    old, m, w, hw = begin_substep(state, momenta, model, i, c)
    _, v0, q0, _ = old
    x = (places[0, i], places[1, i], places[2, i])
    # Where it ends, read on every substep and taken on the last (a load under a branch would
    # keep the loop scalar: measured 480 -> 160 ns per body-substep with WheelPointing's wheels)
    end = (places[3, i], places[4, i], places[5, i])
    drive = load_drive(wheels, wrenches, i, c)
    forces = wrenches[REACH, i]
    if c.wheels != 0.0:
        forces += wheel_reach(w, hw, drive, c, m)
    reach = (start_energy(x, v0, w, m, c), held_reach(c.h, forces))
    act = load_wrench(wrenches, i, c)
    x, v, q, w, hw1 = integrate(step, (x, v0, q0, w, hw), act, m, c, c.h, counts, i, drive)
    x = (end[0] if last else x[0], end[1] if last else x[1], end[2] if last else x[2])
    world = (state, status, momenta)
    return end_substep(world, i, ((x, v, q, w, hw1), (*old, hw)), m, reach, c, last)


def vector_passes(step, p, model, world, command, bodies, counts):
    """:func:`passes` with the wheels' flag of ``p`` as a constant: 1 where the bodies carry
    wheels and ``step`` is a flow that steps them (:func:`integrate`), else 0. Compiled, the
    choice is made by the type of ``step`` (the overload below): a method that steps no wheels
    compiles its passes once, without them (a world refuses wheels for it), and so does a
    world without wheels, by the type of its wheels' rows
    (:func:`rigid_env.core.layout.no_wheel_rows`)."""
    c = unpack(p)
    if c.wheels != 0.0 and is_flow(step):
        wrenched = c.actions != c.wheel_count
        d = wheeled(c) if c.wheels_coupled != 0.0 else wheeled_apart(c)
        return passes(step, d, p, model, world, command, (bodies, wrenched), counts)
    return passes(step, common(c), p, model, world, command, (bodies, True), counts)


@overload(vector_passes, inline="always")
def _vector_passes(step, p, model, world, command, bodies, counts):
    if is_flow(step.dispatcher) and carries_wheels(world.types[3]):

        def both(step, p, model, world, command, bodies, counts):
            c = unpack(p)
            if c.wheels != 0.0:
                span = (bodies, c.actions != c.wheel_count)  # False: the wheels alone, no wrench
                if c.wheels_coupled != 0.0:
                    return wheel_passes(step, wheeled(c), p, model, world, command, span, counts)
                d = wheeled_apart(c)
                return wheel_passes(step, d, p, model, world, command, span, counts)
            return passes(step, common(c), p, model, world, command, (bodies, True), counts)

        return both

    def plain(step, p, model, world, command, bodies, counts):
        return passes(step, common(unpack(p)), p, model, world, command, (bodies, True), counts)

    return plain


@pass_kernel
def wheel_passes(step, c, p, model, world, command, span, counts):
    """:func:`passes` of a world with wheels: without a wrench (the constant ``False``) where
    the command drives only the wheels."""
    bodies, wrenched = span
    if wrenched:
        return passes(step, c, p, model, world, command, (bodies, True), counts)
    return passes(step, c, p, model, world, command, (bodies, False), counts)


@pass_kernel
def passes(step, c, p, model, world, command, span, counts):
    """The vectorised passes of :func:`advance` under the named parameters ``c`` (whose rare
    flags are constants): each body's wrench and reach into ``wrenches`` and its wheels'
    motor torques, then the ``substeps`` passes of :func:`substep`. ``span = (bodies,
    wrenched)``: ``wrenched`` False (a constant, where the command drives only wheels: their
    maps are zero) leaves the wrench out, so that the passes neither write the zeros nor read
    them. Returns the step's code."""
    (start, stop), wrenched = span
    state, status, wrenches, momenta, _ = world
    commanded = command.shape[1] > 0
    actuated = commanded and wrenched
    wheels = wheel_records(p, c, momenta)  # read once, not per body: the loop keeps its form
    if actuated:
        for i in range(start, stop):  # each body's wrench, its reach and its wheels' motors
            act = wrench(p, c, model, command, i)
            store_wrench(wrenches, i, act, c)
            wrenches[REACH, i] = force_reach(act, body_model(model, i), c)
            store_motors(wrenches, i, motor_torques(wheels, c, command, command_row(command, i)), c)
    elif commanded and c.wheels != 0.0:
        for i in range(start, stop):  # the wheels' motors alone
            store_motors(wrenches, i, motor_torques(wheels, c, command, command_row(command, i)), c)
    clear_counts(counts, (start, stop))
    substeps = int(c.substeps)
    arrays = (model, wrenches, state, status, momenta)
    for k in range(substeps):
        last = k == substeps - 1
        for i in range(start, stop):
            # An unsigned index: no wraparound of negative indices to compute, which would
            # keep the compiler from vectorising the loop.
            j = np.uint64(i)
            substep(step, c, wheels, arrays, (j, last, actuated), counts)
    return tally(state, status, c, (start, stop))


@kernel
def tally(state, status, c, bodies):
    """The code of a world step of the vectorised passes, counted after them from what they
    left: the bodies that failed in it (:data:`FAILED`: none is at its start, as the world
    turns each into frozen or healthy), and whether a healthy one spins past the integrator's
    stable ``|w|`` (:func:`beyond`, from its ``w`` as stored). Counted here, not summed in the
    substeps' loop: a sum there makes the compiler interleave that loop's vector code four
    times, and the wheels' passes spill their registers (measured: 0.53x -> 0.6x rk4's rate)."""
    start, stop = bodies
    failures = over = 0
    for i in range(start, stop):
        w = (state[10, i], state[11, i], state[12, i])
        failures += 1 if status[i] == FAILED else 0
        over += beyond(w, c, status[i] == HEALTHY)
    return step_code(failures, min(over, 1))


@pass_kernel
def over_threads(entry, world, start, stop, threads):
    """A world step ``entry(*world, start, stop)`` (one integrator's compiled :func:`advance`)
    of ``start <= i < stop`` split into ``threads`` contiguous ranges over Numba's threads
    (``prange``; each body is computed alone, so the split changes no number); ``entry`` is
    called, not inlined again. ``threads`` is an argument (``numba.get_num_threads()`` in
    Python): called in here it would keep the function from being cached. ``world = (p,
    model, state, status, wrenches, momenta, places[, counts], command)``: the wheels'
    ``momenta`` (a tuple of rows) are taken out of it before the loop, as ``prange`` hands its
    body each tuple it reads as its items, one level deep only."""
    codes = np.empty(threads, np.int64)  # (no array expressions here: each would be a parfor)
    head, momenta, tail = world[:5], world[5], world[6:]
    for t in prange(threads):
        codes[t] = entry(*head, momenta, *tail, *split_range(start, stop, t, threads))
    failures = over = 0
    for t in range(threads):
        if codes[t] == BAD_COMMAND:
            return BAD_COMMAND  # every range checks the command before it steps: nothing stepped
        failures += failures_of(codes[t])
        over = max(over, beyond_of(codes[t]))
    return step_code(failures, over)


# ---- passes of the array integrator exact_free and of a reference solver ---------------------
@kernel
def limit_speed_pass(p, state):
    """:func:`limit_speed` of every body's ``w`` in the state columns, in place."""
    c = unpack(p)
    for i in range(state.shape[1]):
        x, v, q, w = load(state, i)
        store(state, i, x, v, q, limit_speed(w, c))


@kernel
def kicks(p, model, state, command, h):
    """:func:`kick` of every body for time ``h``, in place on the ``v, w`` of ``state``."""
    c = unpack(p)
    for i in range(state.shape[1]):
        act = wrench(p, c, model, command, i)
        x, v, q, w = load(state, i)
        v, w = kick(x, v, q, w, act, body_model(model, i), c, h)
        store(state, i, x, v, q, w)


@kernel
def segments_pass(p, model, state, command, span, out):
    """The next segment of every body with thrusters as hardware (``exact_free``'s
    :func:`body_substep`), ``span = (t, t1)``, ``out = (lengths, wrenches, roots)``: from each
    body's time ``t[i]`` (advanced in place) to the next switch time or ``t1`` [s from the
    step's start], its length into ``lengths`` (N,) (0 when the body has reached ``t1``) and
    its thrusters' wrench into ``wrenches`` (WRENCH_WIDTH, N), lagging levels advanced in
    ``state``, its reach ``s B`` added to ``roots`` (N,). Returns whether some body has a
    segment."""
    t, t1 = span
    lengths, wrenches, roots = out
    c = unpack(p)
    more = False
    for i in range(state.shape[1]):
        lengths[i] = 0.0
        if t[i] < t1:
            end = next_switch(p, c, command, i, t[i], t1)
            act = segment_wrench(p, c, model, command, state, i, t[i], end - t[i])
            store_wrench(wrenches, i, act, c)
            lengths[i] = end - t[i]
            roots[i] += held_reach(lengths[i], force_reach(act, body_model(model, i), c))
            t[i] = end
            more = True
    return more


@kernel
def energy_roots(p, model, state, command, span):
    """(N,) each body's ``sqrt(E)`` [J^(1/2)] plus the conservative effects' ``sqrt(dV)``
    (:func:`energy_root`) and, for ``span > 0`` [s], the reach ``span B`` of the command's
    wrench held over it (:func:`held_reach`; thrusters as hardware add their segments'
    instead, :func:`segments_pass`): where ``sqrt(E)`` may reach over the step, over 10
    (:func:`finish_pass`)."""
    c = unpack(p)
    out = np.empty(state.shape[1])
    for i in range(state.shape[1]):
        x, v, _, w = load(state, i)
        m = body_model(model, i)
        out[i] = energy_root(x, v, w, m, c)
        if span > 0.0:
            out[i] += held_reach(span, force_reach(wrench(p, c, model, command, i), m, c))
    return out


@kernel
def finish_pass(p, model, state, before, status, roots):
    """The end of an array integrator's world step: :func:`step_maps` and the :func:`guard`
    of every body against its columns ``before`` the step, with the reach ``roots`` (N,) it
    had over the step (:func:`energy_roots`; :func:`within_reach` with ``start = root^2``).
    Returns the step's code."""
    c = unpack(p)
    failures = over = 0
    for i in range(state.shape[1]):
        x, v, q, w = load(state, i)
        v, w = step_maps(v, w, c)
        m = body_model(model, i)
        reach = (roots[i] * roots[i], 0.0)  # sqrt(E) may reach 10 roots[i]
        ok, failed = guard(state, status, i, (x, v, q, w), load(before, i), m, reach)
        failures += 1 if failed else 0
        over += beyond(w, c, ok)
    return step_code(failures, min(over, 1))


@kernel
def segment_kicks(p, model, state, wrenches, lengths, fraction):
    """:func:`kick` of every body for ``fraction`` of its segment ``lengths[i]`` (none where
    0) under its wrench in ``wrenches`` (WRENCH_WIDTH, N), in place on ``v, w``."""
    c = unpack(p)
    for i in range(state.shape[1]):
        if lengths[i] > 0.0:
            x, v, q, w = load(state, i)
            m = body_model(model, i)
            v, w = kick(x, v, q, w, load_wrench(wrenches, i, c), m, c, fraction * lengths[i])
            store(state, i, x, v, q, w)


@kernel
def derivatives(p, model, state, momenta, command, out):
    """``(v', w')`` of every body's state column into ``out`` (N, 6): the linear (world) and
    angular (body, Euler's equations included) accelerations of
    :func:`rigid_env.core.dynamics.accelerations`, the gyrostat's
    (:func:`rigid_env.core.wheels.gyrostat`) at the wheels' momenta in the state columns where
    the bodies carry wheels (``momenta``: their rows, as the world step's): the right-hand side
    a reference solver needs."""
    c = unpack(p)
    for i in range(state.shape[1]):
        act = wrench(p, c, model, command, i)
        x, v, q, w = load(state, i)
        around = Surroundings(p, ZERO3, 0.0, ZERO3, 0.0)
        if c.orbit != 0.0:  # where the body is now, the field and its surroundings there
            x, field, around = where(p, c, state, i, 0.0)
            if c.field_degree != 0.0:
                act = (act[0], act[1], act[2], field)
        held = (act[0], act[1], act[2], act[3], around)
        m = body_model(model, i)
        if c.wheels != 0.0:
            drive = wheel_drive(wheel_records(p, c, momenta), c, command, command_row(command, i))
            hw = load_wheels(momenta, i, c)
            drive = hold(drive, w, hw, m, 0.0)  # Coulomb's sign at this state
            a, alpha, _ = gyrostat(x, v, q, w, hw, held, m, c, drive)
        else:
            a, alpha = accelerations(x, v, q, w, held, m, c, True)
        out[i, 0], out[i, 1], out[i, 2] = a
        out[i, 3], out[i, 4], out[i, 5] = alpha
