"""The B-dot law (agents/bdot.py) against its Lyapunov function and the physics it cannot
beat: its power is never positive; in a field fixed in space it damps every rotation but the
spin about the field, whose angular momentum ``L . B^`` no magnetic torque changes (the torque
lies across ``B``); the flown form (two magnetometer samples) is the rate form to first order
in ``dt``."""

from __future__ import annotations

import numpy as np

from agents.bdot import avanzini_gain, bdot_measured, bdot_rate, bdot_torque
from rigid_env.core import BodyModel, Magnetorquers, Tolerances, World
from rigid_env.core.rotation import quat_from_rotvec, quat_rotate, quat_rotate_inv
from rigid_env.envs.bdot_detumble import torque_dipoles
from rigid_env.resources import scene_path
from rigid_env.scene import load_scene

from roundoff import U

MAX_DIPOLE = np.array([0.2, 0.35, 0.5])
INERTIA = np.array([0.02, 0.03, 0.04])


def test_power_is_never_positive_even_saturated() -> None:
    """``w . (m x B_b) = m . (B_b x w) = -sum_i m_i (w x B_b)_i``, each term <= 0 since a
    saturated ``m_i`` keeps the sign of ``(w x B_b)_i``: at 10^4 random states, gains that
    saturate some axes and not others, the power is at most the rounding of its terms (a cross
    product and a dot product of numbers of size ``|m| |B| |w|``: 16 U of it)."""
    gen = np.random.default_rng(5)
    w = gen.normal(0.0, 0.1, (10_000, 3))
    b = gen.normal(0.0, 3.0e-5, (10_000, 3))
    for gain in (1e-6, 1e-4, 1e-2):
        m = bdot_rate(w, b, gain, MAX_DIPOLE) * MAX_DIPOLE
        power = np.sum(w * np.cross(m, b), axis=1)
        scale = np.linalg.norm(m, axis=1) * np.linalg.norm(b, axis=1) * np.linalg.norm(w, axis=1)
        assert np.all(power <= 16 * U * scale)
        assert np.all(power[scale > 0] < 0.0)  # and it does damp: w x B_b = 0 has measure 0


def test_detumbles_all_but_the_spin_about_the_field() -> None:
    """A tumbling box in a field fixed in space under B-dot (rate form, held over each 1 s
    step), stepped by dop853 at rtol 1e-12: ``L . B^`` (world) stays what it was, to the
    integrator's error (1e-12 per step over 1500 steps, with a factor 100 of margin: 2e-7 of
    |L|); the rest of ``L`` falls below 1 % of its start (the law's rate ``k / I`` ~ 0.04 /s
    damps it e^-60 over the run; 1 % leaves room for the slow decay near alignment)."""
    field = np.array([1.0e-5, -2.0e-5, 3.0e-5])
    coils = Magnetorquers(max_dipole=MAX_DIPOLE, field=field)
    world = World(
        BodyModel.single(2.0, INERTIA), [coils], "dop853", 1.0, tolerances=Tolerances(rtol=1e-12)
    )
    s = world.state
    s.w[:] = [0.05, -0.03, 0.04]
    world.state = s
    unit = field / np.linalg.norm(field)

    def momentum() -> np.ndarray:
        st = world.state
        return quat_rotate(st.q, INERTIA * st.w)[0]

    start = momentum()
    energy = world.kinetic_energy()[0]
    gain = 10.0 * avanzini_gain(1.1e-3, np.radians(60.0), INERTIA.min())
    for _ in range(1500):
        st = world.state
        u = bdot_rate(st.w, quat_rotate_inv(st.q, field), gain, MAX_DIPOLE)
        world.step(u)
    end = momentum()
    size = np.linalg.norm(start)
    assert abs(end @ unit - start @ unit) <= 2e-7 * size
    perpendicular = np.linalg.norm(end - (end @ unit) * unit)
    assert perpendicular < 0.01 * np.linalg.norm(start - (start @ unit) * unit)
    assert world.kinetic_energy()[0] < energy


def test_measured_form_is_the_rate_form_to_first_order() -> None:
    """A body turning at constant ``w``: ``B_b(t - dt) = exp(dt [w]) B_b(t)`` exactly, and the
    difference quotient is ``-w x B_b + dt/2 w x (w x B_b) + O(dt^2 |w|^3 |B|)``; the two
    commands differ by at most ``k/|B|^2 (dt/2 |w|^2 + dt^2/6 |w|^3) |B|`` per axis over the
    coil's dipole (clipping to [-1, 1] can only shrink the gap), plus rounding."""
    gen = np.random.default_rng(9)
    n, dt, gain = 1000, 0.5, 2e-4
    w = gen.normal(0.0, 0.05, (n, 3))
    b = gen.normal(0.0, 3.0e-5, (n, 3))
    earlier = quat_rotate(quat_from_rotvec(w * dt), b)
    rate = bdot_rate(w, b, gain, MAX_DIPOLE)
    measured = bdot_measured(b, earlier, dt, gain, MAX_DIPOLE)
    speed = np.linalg.norm(w, axis=1, keepdims=True)
    size = np.linalg.norm(b, axis=1, keepdims=True)
    bound = gain / size * (dt / 2 * speed**2 + dt**2 / 6 * speed**3) / MAX_DIPOLE
    rounding = 1e-12 * gain * speed / size / MAX_DIPOLE  # a rotation of B_b, over dt: 1e4 U
    assert np.all(np.abs(measured - rate) <= bound + rounding)
    assert np.max(np.abs(measured - rate)) > 0.0  # the two forms are not the same code


def test_bdot_detumbles_the_cubesat_to_twice_the_orbit_rate() -> None:
    """The shipped scene under B-dot (rate form, Avanzini-Giulietti gain, its 5 s step) for three
    orbits: from 10 deg/s the rate falls to the law's known floor, about twice the orbital
    rate ``2 n`` (the field turns at ``2 n`` in the orbit frame, and B-dot damps only the
    rotation relative to it: Avanzini and Giulietti 2012, Sec. V); below ``3 (2 n)``, while
    ten times the start's rate would be above it."""
    scene = load_scene(scene_path("bdot_detumble"))
    world = scene.build_world()
    (coils,) = [e for e in world.force_effects if isinstance(e, Magnetorquers)]
    n = coils.orbit.orbit.mean_motion
    gain = avanzini_gain(n, np.radians(88.0), scene.inertia.min())  # 97.4 - 9.4 deg tilt
    start = np.linalg.norm(world.state.w)
    for _ in range(round(3 * coils.orbit.orbit.period / world.dt)):
        s = world.state
        world.step(bdot_rate(s.w, quat_rotate_inv(s.q, world.magnetic_field), gain, 0.35))
    assert start > 30 * 2 * n
    assert np.linalg.norm(world.state.w) < 3 * 2 * n


def test_the_torque_form_through_the_cross_product_law_is_the_dipole_form() -> None:
    """:func:`bdot_torque` asks for B-dot's torque; the cross-product law
    (:func:`rigid_env.envs.bdot_detumble.torque_dipoles`) makes of it the dipole of
    :func:`bdot_rate`, for coils of unequal limits along the body axes, wherever neither
    saturates (numbers near 1 and a few roundings each: 1e-13)."""
    rng = np.random.default_rng(4)
    n = 200
    w = rng.normal(0.0, 0.05, (n, 3))
    b = rng.normal(0.0, 3e-5, (n, 3))
    k = 5e-6
    unit = float(MAX_DIPOLE.min())
    dipole = bdot_rate(w, b, k, MAX_DIPOLE)  # coil commands in [-1, 1]
    torque = bdot_torque(w, b, k, unit)
    made = torque_dipoles(torque, b, np.diag(1.0 / MAX_DIPOLE), unit)
    free = (np.abs(dipole).max(axis=1) < 1.0) & (np.abs(torque).max(axis=1) < 1.0)
    assert free.sum() > n // 2
    np.testing.assert_allclose(made[free], dipole[free], rtol=0, atol=1e-13)
