"""Property-based checks: random valid inertias, spins, thruster layouts and commands.

Invariants: q stays a unit quaternion under every integrator; torque-free ``splitting`` keeps
the angular momentum; torque-free ``implicit_gyro`` never gains energy. Example counts are
modest (50, no deadline) so that CI stays fast.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from rigid_env.bench.stability_cases import ENERGY_GAIN_RTOL, energy, torque_free_world
from rigid_env.core import INTEGRATORS, BodyModel, State, Thrusters, World
from rigid_env.core.rotation import quat_norm, quat_normalize, quat_rotate

SETTINGS = settings(max_examples=50, deadline=None)
DT = 0.01
EPS = np.finfo(float).eps
# | |q| - 1 | after every step: the renormalisation q / |q| leaves <= 4 U (the sum of four
# squares, the sqrt and the division; U = 2^-53) and quat_norm's own evaluation 3 U more:
# 7 U = 7.8e-16 <= 1e-15.
UNIT_Q_ROUNDING = 1.0e-15
# Torque-free splitting: | |L| - |L0| | / |L0| and |L_world - L_world0| / |L0| after 50
# steps. Each step is 5 exact axis rotations, each a sin and a cos (4 ulps each at most) and ~4
# roundings (24 U), orthogonal so nothing is amplified: 50 * 5 * 24 U = 6.7e-13 <= 1e-12.
L_ROUNDING = 1.0e-12

second_moment = st.floats(min_value=1.0e-3, max_value=1.0e2)


@st.composite
def inertias(draw) -> np.ndarray:
    """Principal moments of a real mass distribution: I1 = Syy + Szz, I2 = Sxx + Szz,
    I3 = Sxx + Syy with second moments S >= 0, so the triangle inequality holds by
    construction; one in four bodies is flat (Szz = 0: I3 = I1 + I2 exactly)."""
    sx, sy, sz = draw(second_moment), draw(second_moment), draw(second_moment)
    if draw(st.integers(0, 3)) == 0:
        sz = 0.0
    return np.array([sy + sz, sx + sz, sx + sy])


def spins(limit: float) -> st.SearchStrategy:
    """Body rates with components in [-limit, limit] rad/s."""
    return st.lists(st.floats(min_value=-limit, max_value=limit), min_size=3, max_size=3).map(
        np.array
    )


@st.composite
def thrusters(draw) -> Thrusters:
    """1 to 4 thrusters at points in [-1, 1]^3 m with non-zero directions, 0 to 5 N each."""
    k = draw(st.integers(1, 4))
    coord = st.floats(min_value=-1.0, max_value=1.0)
    points = np.array([[draw(coord) for _ in range(3)] for _ in range(k)])
    dirs = []
    for _ in range(k):
        d = np.array([draw(coord) for _ in range(3)])
        dirs.append(d if np.linalg.norm(d) > 1e-3 else np.array([0.0, 0.0, 1.0]))
    fmax = np.array([draw(st.floats(min_value=0.0, max_value=5.0)) for _ in range(k)])
    return Thrusters(points=points, directions=np.array(dirs), max_force=fmax)


@SETTINGS
@given(
    inertia=inertias(),
    w0=spins(30.0),
    layout=thrusters(),
    data=st.data(),
    integrator=st.sampled_from(list(INTEGRATORS)),
)
def test_q_stays_unit_under_thrust(inertia, w0, layout, data, integrator):
    """Any integrator, random thrusters firing random commands: |q| = 1 to rounding and every
    state finite over 30 steps. The thrust is scaled by the smallest moment (an angular
    acceleration of at most sqrt(3) 5 rad/s^2, +2.6 rad/s in 0.3 s), so h|w| stays below 0.55
    where even the forward Eulers are stable; unscaled, 2 N at 1.4 m spins a thin rod
    (I1 = 1e-3) to h|w| = 6 within the 30 steps, and forward Euler rightly blows up."""
    cmd = np.array(
        data.draw(
            st.lists(
                st.floats(min_value=-1.0, max_value=1.0),
                min_size=layout.force_map.shape[0],
                max_size=layout.force_map.shape[0],
            )
        )
    )
    q_raw = np.array(data.draw(st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4)))
    q_raw[0] += 1.0e-3  # never the zero quaternion
    q0 = quat_normalize(q_raw)
    state = State.from_arrays(np.zeros(3), np.zeros(3), q0, w0)
    scaled = Thrusters(layout.points, layout.directions, layout.max_force * inertia.min())
    world = World(
        BodyModel.single(1.0, inertia), [scaled], integrator=integrator, dt=DT, state=state
    )
    for _ in range(30):
        world.step(cmd)
        assert abs(quat_norm(world.state.q)[0] - 1.0) <= UNIT_Q_ROUNDING
    for a in (world.state.x, world.state.v, world.state.w):
        assert np.isfinite(a).all()


@SETTINGS
@given(inertia=inertias(), w0=spins(100.0))
def test_torque_free_splitting_keeps_angular_momentum(inertia, w0):
    """Rates up to 100 rad/s per axis (h|w| up to 1.7): |L| and the world L vector kept."""
    world = torque_free_world(inertia, w0, "splitting", DT)
    l0 = quat_rotate(world.state.q, inertia * world.state.w)[0]
    n0 = np.linalg.norm(l0)
    if n0 == 0.0:
        return
    for _ in range(50):
        world.step()
    lw = quat_rotate(world.state.q, inertia * world.state.w)[0]
    assert abs(np.linalg.norm(inertia * world.state.w[0]) - n0) <= L_ROUNDING * n0
    assert np.linalg.norm(lw - l0) <= L_ROUNDING * n0


@SETTINGS
@given(inertia=inertias(), w0=spins(400.0))
def test_torque_free_implicit_gyro_never_gains_energy(inertia, w0):
    """Rates up to 400 rad/s per axis (h|w| up to 7): no step raises the energy beyond rounding
    (ENERGY_GAIN_RTOL = 1e-14 relative); one bare Newton step would, at large h|w|."""
    world = torque_free_world(inertia, w0, "implicit_gyro", DT)
    e = energy(inertia, world.state.w[0])
    for _ in range(30):
        world.step()
        e_next = energy(inertia, world.state.w[0])
        assert e_next <= e * (1.0 + ENERGY_GAIN_RTOL) + 1e-300
        e = e_next
