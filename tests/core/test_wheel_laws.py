"""The reaction wheels' laws inside a step (rigid_env.core.wheels.wheel_laws), as properties.

Over motors (1e-4 to 1e3 N m), steps (dt 0.01 to 0.2 s, 1 to 3 substeps), every integrator that
steps wheels, friction (viscous, Coulomb up to 1 N m), wheel sets (three along the principal axes,
or a pyramid of four) and starts (body rates, wheel speeds within the limit):

* no wheel's relative speed passes its limit by more than rounding;
* without a motor the kinetic energy of body + wheels never rises beyond the integrator's error;
* without outside torque the total angular momentum (body + wheels, world frame) is conserved
  to the integrator's error.

The integrator's error: a method of order ``p`` over a substep ``h`` errs by about ``(h W)^(p+1)``
of the state it advances, ``W`` the fastest rate of the smooth flow: the body's ``|w|`` (the
larger of a step's start and end), what the motors may add to it within the step (``K
max_torque h / I_min``), the wheels' gyroscopic coupling (``2 K J max_speed / I_min``) and the
bearing's viscous decay (``viscous / J``); a constant torque is integrated exactly by every method
here. The bound allowed is ``10 (h W)^(p+1)`` per substep, relative (to the energy, or to the
momentum body and wheels exchange, ``|I w| + |h|``), summed over the run (a factor 10 for the
constants of the error terms), plus 1e-12 per substep for rounding. The laws' impulses
themselves conserve momentum to rounding and never raise energy (the proof is in
:func:`rigid_env.core.wheels.wheel_laws`), so a law that added energy or momentum (the pre-fix
Coulomb sign flip: 0.50 J to 13.75 J in 20 steps) fails by orders of magnitude beyond the bound.

Examples: a small count by default (profile ``wheel_laws``); ``HYPOTHESIS_PROFILE=long`` runs 300
(profile ``wheel_laws_long``).
"""

from __future__ import annotations

import os

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rigid_env.core.effects import ReactionWheels
from rigid_env.core.state import BodyModel
from rigid_env.core.wheels import WHEEL_STEPS
from rigid_env.core.world import NumericalInstabilityError, World

ORDERS = {"explicit_euler": 1, "symplectic_euler": 1, "leapfrog": 2, "midpoint": 2, "rk4": 4}
_COMMON = {
    "deadline": None,
    "database": None,
    "print_blob": True,
    "suppress_health_check": [HealthCheck.too_slow],
}
settings.register_profile("wheel_laws", max_examples=8, **_COMMON)
settings.register_profile("wheel_laws_long", max_examples=300, derandomize=False, **_COMMON)
PROFILE = settings.get_profile(
    "wheel_laws_long" if os.environ.get("HYPOTHESIS_PROFILE") == "long" else "wheel_laws"
)
PYRAMID = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [-1.0, 0.0, 1.0], [0.0, -1.0, 1.0]])
STEPS = 20


def log_uniform(low, high):
    return st.floats(np.log10(low), np.log10(high)).map(lambda e: float(10.0**e))


@st.composite
def wheel_worlds(draw, *, motor: bool):
    """``(world, command, bound)``: a body with wheels, a constant command (zero without a
    ``motor``) and the integrator's error bound of a step (module docstring), a function of the
    world's present state."""
    integrator = draw(st.sampled_from(sorted(WHEEL_STEPS)))
    assert set(WHEEL_STEPS) == set(ORDERS)
    dt = draw(st.floats(0.01, 0.2))
    substeps = draw(st.integers(1, 3))
    sides = np.array([draw(st.floats(0.1, 0.4)) for _ in range(3)])  # a 2 kg box [m]
    inertia = 2.0 / 12.0 * (np.sum(sides**2) - sides**2)
    axes = draw(st.sampled_from(["principal", "pyramid"]))
    axes = np.eye(3) if axes == "principal" else PYRAMID
    k = axes.shape[0]
    j = draw(log_uniform(1e-6, 1e-4))
    limit = draw(st.floats(50.0, 1000.0))
    h = dt / substeps
    wheels = ReactionWheels(
        axes,
        inertia=j,
        max_torque=draw(log_uniform(1e-4, 1e3)),
        max_speed=limit,
        viscous=draw(st.sampled_from([0.0, 1e-9, 1e-7])),
        coulomb=draw(st.sampled_from([0.0, 1e-5, 1e-3, 1.0])),
    )
    world = World(BodyModel(np.array([2.0]), inertia[None, :]), [wheels], integrator, dt=dt,
                  substeps=substeps)  # fmt: skip
    world.state.w[:] = [draw(st.floats(-1.0, 1.0)) for _ in range(3)]
    world.set_wheel_speed([draw(st.floats(-limit, limit)) for _ in range(k)])
    command = np.array([draw(st.floats(-1.0, 1.0)) for _ in range(k)]) if motor else np.zeros(k)
    order = ORDERS[integrator]
    # within a step the motor may spin the body by max_torque h / I_min before the limit's
    # impulse takes it back
    coupling = float(np.max(wheels.max_torque)) * k * h / inertia.min()
    coupling += 2.0 * k * j * limit / inertia.min() + float(np.max(wheels.viscous)) / j

    def bound(world, body_rate):
        """Relative error of a step: its substeps' ``10 (h W)^(p+1)`` (module docstring), the
        body's rate at most ``body_rate``."""
        rate = body_rate + coupling  # the fastest rate of the flow
        return substeps * (10.0 * (h * rate) ** (order + 1) + 1e-12)

    # Speeds to rounding: the largest speed in play (a step's jump under the motor, on
    # J_eff <= J) times 1e-14 (a few dozen ulps). Wheels off the principal axes: what the four
    # sweeps of the limit leave, r^4 of the jump (rigid_env.core.wheels.wheel_laws).
    jump = float(np.max(wheels.max_torque)) * h / j + 2.0 * limit
    inverse = np.diag(1.0 / inertia)
    r = 0.0 if k == 3 else float(np.max(np.abs(axes @ inverse @ axes.T / np.sum(axes**2, 1)))) * j
    rounding = 1e-14 * jump + r**4 * jump
    return world, command, (bound, rounding)


def momentum_in_play(world):
    """``|I w| + |h|``: the momenta body and wheels exchange [N m s]."""
    h = np.linalg.norm(world.wheel_momentum[0] @ world._wheels.axes)
    return np.linalg.norm(world.model.inertia[0] * world.state.w[0]) + h


def _step(world, command) -> bool:
    """One step; False where the world said loudly that it blew up. Explicit Euler grows a free
    body's rate by ``sqrt(1 + (h w)^2)`` a step, so a fast draw (h |w| ~ 0.7, the motors spinning
    the body up) diverges within 20 steps: a clear error is the promised outcome there, and the
    laws are judged on every step before it."""
    try:
        world.step(command)
    except NumericalInstabilityError:
        return False
    return True


@PROFILE
@given(wheel_worlds(motor=True))
def test_no_wheel_passes_its_speed_limit(case):
    world, command, (_, rounding) = case
    limit = float(np.max(world._wheels.max_speed))
    for _ in range(STEPS):
        if not _step(world, command):
            return
        assert np.abs(world.wheel_speed[0]).max() <= limit + rounding, world.wheel_speed


@PROFILE
@given(wheel_worlds(motor=False))
def test_body_and_wheels_gain_no_energy_without_a_motor(case):
    world, command, (bound, _) = case
    for _ in range(STEPS):
        before, rate = world.energy()[0], np.abs(world.state.w[0]).sum()
        if not _step(world, command):
            return
        allowed = bound(world, max(rate, np.abs(world.state.w[0]).sum()))
        assert world.energy()[0] <= before * (1.0 + allowed), (before, world.energy()[0])


@PROFILE
@given(wheel_worlds(motor=True))
def test_total_momentum_is_conserved_without_outside_torque(case):
    world, command, (bound, _) = case
    start = world.angular_momentum_world()[0].copy()
    allowed = 0.0
    for n in range(1, STEPS + 1):
        scale, rate = momentum_in_play(world), np.abs(world.state.w[0]).sum()
        if not _step(world, command):
            return
        rate = max(rate, np.abs(world.state.w[0]).sum())
        allowed += bound(world, rate) * max(scale, momentum_in_play(world))
        drift = np.abs(world.angular_momentum_world()[0] - start).max()
        assert drift <= allowed, (n, drift, allowed)


def test_a_huge_motor_stops_at_the_limit_in_one_step():
    # The case: one rk4 step of a 1e3 N m motor took a wheel to 1.05e7 rad/s against 628.
    # The held motor stops where the limit is reached (its average over the step) and the limit's
    # impulse takes back what the gyroscopic coupling adds: 628 to rounding of the speeds in play
    # (max_torque h / J = 1e7 rad/s times 1e-15), the total momentum kept (measured 1e-18 N m s
    # against J_eff 628 = 6e-3 N m s exchanged; allowed 1e-9 of 100 N m s, rk4's error at the
    # motor's full impulse).
    inertia = np.array([0.02, 0.03, 0.045])
    wheels = ReactionWheels(np.eye(3), inertia=1e-5, max_torque=1e3, max_speed=628.0)
    world = World(BodyModel(np.array([2.0]), inertia[None, :]), [wheels], "rk4", dt=0.1)
    world.step(np.ones(3))
    np.testing.assert_allclose(world.wheel_speed[0], 628.0, rtol=0, atol=1e-15 * 1e3 * 0.1 / 1e-5)
    np.testing.assert_allclose(world.angular_momentum_world()[0], 0.0, atol=1e-9 * 100.0)


def test_coulomb_friction_without_a_command_only_dissipates():
    # The case: coulomb 1 N m, no command, wheels at rest: the pre-fix law took body +
    # wheels from 0.50 J to 13.75 J in 20 steps. Now the wheels stick (1 N m stops them within
    # a step): the body and its wheels turn as one, energy not rising (the stick's impulses
    # take the relative speed the flow gave, so it may fall by the splitting's O(h) share).
    inertia = np.array([0.02, 0.03, 0.045])
    wheels = ReactionWheels(np.eye(3), inertia=1e-4, max_torque=1e-3, coulomb=1.0)
    world = World(BodyModel(np.array([2.0]), inertia[None, :]), [wheels], "rk4", dt=0.1)
    world.state.w[:] = [3.0, -5.0, 4.0]
    start, momentum = world.energy()[0], world.angular_momentum_world()[0].copy()
    for _ in range(20):
        before = world.energy()[0]
        world.step(np.zeros(3))
        assert world.energy()[0] <= before * (1 + 1e-14)
        np.testing.assert_allclose(world.wheel_speed[0], 0.0, atol=1e-12)
    assert world.energy()[0] >= 0.9 * start
    # rk4's error over 20 steps of h |w| = 0.7: 1e-2 relative at most
    np.testing.assert_allclose(world.angular_momentum_world()[0], momentum, rtol=1e-2)


def test_a_wheel_at_rest_sticks_while_the_drive_is_within_coulomb_and_slips_beyond():
    # One wheel along the body's z axis (no gyroscopic coupling): from rest under a motor of
    # tau against coulomb c it stays stuck while tau <= c, else its speed grows at (tau - c) /
    # J_eff (a constant torque: every step exact to rounding).
    inertia, j, c, dt = np.array([0.02, 0.03, 0.045]), 1e-5, 1e-3, 0.05
    j_eff = 1.0 / (1.0 / j + 1.0 / inertia[2])
    for tau in (0.5e-3, 1e-3, 1.5e-3):
        wheels = ReactionWheels(np.eye(3)[2:], inertia=j, max_torque=tau, coulomb=c)
        world = World(BodyModel(np.array([2.0]), inertia[None, :]), [wheels], "rk4", dt=dt)
        for n in range(1, 6):
            world.step(np.array([1.0]))
            expected = max(tau - c, 0.0) * n * dt / j_eff
            np.testing.assert_allclose(world.wheel_speed[0, 0], expected, rtol=1e-9, atol=1e-12)
