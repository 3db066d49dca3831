"""The same free body in MuJoCo and in our world.

One free-joint body, mass 1, ``diaginertia`` (1, 2, 3) with its inertial frame at the body
origin and aligned with it (so MuJoCo's body frame is our principal frame), no gravity, no
damping, no contacts. Conventions, checked in :func:`test_mujoco_conventions`:

* ``qpos[3:7]`` is the body orientation ``(w, x, y, z)`` body -> world, as our ``q``;
* ``qvel[0:3]`` is the world-frame linear velocity of the body origin (= centre of mass here);
* ``qvel[3:6]`` is the angular velocity in the **body (local) frame** for a free joint, as our
  ``w`` (``mj_objectVelocity`` with ``flg_local=1`` returns exactly ``qvel[3:6]``).

Integrators compared:

* MuJoCo ``Euler`` vs ``symplectic_euler``. ``mj_Euler`` (with no damping it does no implicit
  damping step) sets ``qvel += h qacc`` with ``qacc = M^-1 (-qfrc_bias)`` evaluated at the start
  of the step, the bias being ``w x I w`` from the *previous* velocity, then ``mj_integratePos``
  moves ``q <- q (x) exp(h w_new / 2)`` with the *new* velocity. That is exactly our
  ``symplectic_euler``: the same formula, so they agree to round-off (MuJoCo computes the bias
  by recursive Newton-Euler in world-aligned com coordinates and rotates it back, we by
  components: ~1e-16 per step, 1.3e-14 measured over 200 steps).
* MuJoCo ``RK4`` vs ``rk4``. Both take the classical tableau on ``w' = -I^-1 (w x I w)``, which
  does not involve ``q``: the angular velocities agree to round-off. The orientation differs in
  its method: MuJoCo moves ``q`` on the group, ``q1 = q0 (x) exp(h/2 (k1 + 2k2 + 2k3 + k4)/6)``
  with the stages' body rates, ours integrates ``q' = 1/2 q (x) (0, w)`` as a vector in R^4 and
  renormalises. Both are fourth order with different error constants, so they differ by
  ``O(h^4)``: 6.3e-10 rad at dt = 0.01, 6.3e-14 at dt = 0.001 (16x per halving of dt, checked).
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray

from rigid_env.core import BodyModel, State, World
from rigid_env.core.rotation import quat_angle_between

from roundoff import FUNC_RTOL, U

mujoco = pytest.importorskip("mujoco")

FloatArray = NDArray[np.float64]

INERTIA = np.array([1.0, 2.0, 3.0])
W0 = np.array([1.0, 0.1, 2.0])  # body frame [rad/s]
V0 = np.array([0.3, -0.2, 0.5])  # world frame [m/s]
Q0 = np.array([0.9, 0.1, 0.3, 0.2]) / np.linalg.norm([0.9, 0.1, 0.3, 0.2])

SAME_FORMULA_TOL = 200 * 2 * (2 * FUNC_RTOL + 60 * U) * 5.0
"""[rad/s] and [rad]: two implementations of the same update over 200 steps (1.7e-11; measured
1.3e-14 in w, 3e-15 rad in q). Per step and side <= 60 roundings and 2 transcendental calls (4
ulps each) on numbers of the size of |w| = 2.2 (or of a unit quaternion); near its stable axis
the body's flow amplifies a perturbation by at most 1 + |w| t (the phase drifts with the
period's dependence on the energy) = 5 over the 2 s: 200 * 2 * (2 FUNC_RTOL + 60 U) * 5."""
CONVENTION_TOL = 16 * U * 2.5
"""Absolute error of one MuJoCo evaluation against the input it was given (|W0|, |V0| <= 2.5):
a rotation there and back, 3-term dot products of 2-term products (4 U per component each),
on both sides: 16 U per unit of the vector's length."""
RK4_ORIENTATION_TOL = 2.0e-9
"""[rad] MuJoCo's group RK4 vs our vector RK4 in q after 2 s at dt = 0.01: both O(h^4) accurate
with different constants, measured 6.3e-10."""


def mujoco_model(integrator: str, dt: float):
    xml = f"""
    <mujoco>
      <option gravity="0 0 0" timestep="{dt}" integrator="{integrator}"/>
      <worldbody>
        <body name="b">
          <freejoint/>
          <inertial pos="0 0 0" mass="1" diaginertia="{INERTIA[0]} {INERTIA[1]} {INERTIA[2]}"/>
        </body>
      </worldbody>
    </mujoco>"""
    return mujoco.MjModel.from_xml_string(xml)


def run_mujoco(integrator: str, dt: float, steps: int) -> dict[str, FloatArray]:
    m = mujoco_model(integrator, dt)
    d = mujoco.MjData(m)
    d.qpos[3:7] = Q0
    d.qvel[0:3] = V0
    d.qvel[3:6] = W0
    out: dict[str, list[FloatArray]] = {"x": [], "q": [], "w": []}
    for _ in range(steps + 1):
        out["x"].append(d.qpos[0:3].copy())
        out["q"].append(d.qpos[3:7].copy())
        out["w"].append(d.qvel[3:6].copy())
        mujoco.mj_step(m, d)
    return {k: np.array(v) for k, v in out.items()}


def run_ours(integrator: str, dt: float, steps: int) -> dict[str, FloatArray]:
    state = State.from_arrays(np.zeros(3), V0, Q0, W0)
    world = World(BodyModel.single(1.0, INERTIA), (), integrator, dt, state=state)
    out: dict[str, list[FloatArray]] = {"x": [], "q": [], "w": []}
    for _ in range(steps + 1):
        out["x"].append(world.state.x[0].copy())
        out["q"].append(world.state.q[0].copy())
        out["w"].append(world.state.w[0].copy())
        world.step()
    return {k: np.array(v) for k, v in out.items()}


def test_mujoco_conventions() -> None:
    """qvel[3:6] of a free joint is the body-frame angular velocity; qvel[0:3] world-frame."""
    m = mujoco_model("Euler", 0.01)
    d = mujoco.MjData(m)
    d.qpos[3:7] = Q0
    d.qvel[0:3] = V0
    d.qvel[3:6] = W0
    mujoco.mj_forward(m, d)
    local, world = np.zeros(6), np.zeros(6)  # (angular, linear)
    mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, 1, local, 1)
    mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, 1, world, 0)
    r = d.xmat[1].reshape(3, 3)  # body -> world
    assert np.abs(local[:3] - W0).max() < CONVENTION_TOL
    assert np.abs(world[:3] - r @ W0).max() < CONVENTION_TOL
    assert np.abs(world[3:] - V0).max() < CONVENTION_TOL
    assert np.abs(d.xquat[1] - Q0).max() < CONVENTION_TOL
    assert np.array_equal(m.body_iquat[1], [1.0, 0.0, 0.0, 0.0])  # principal frame = body frame
    assert np.array_equal(m.body_inertia[1], INERTIA)


def test_mujoco_euler_equals_symplectic_euler() -> None:
    dt, steps = 0.01, 200  # 2 s
    mj = run_mujoco("Euler", dt, steps)
    ours = run_ours("symplectic_euler", dt, steps)
    w_err = np.abs(mj["w"] - ours["w"]).max()
    q_err = quat_angle_between(mj["q"], ours["q"]).max()
    x_err = np.abs(mj["x"] - ours["x"]).max()
    assert w_err < SAME_FORMULA_TOL, w_err
    assert q_err < SAME_FORMULA_TOL, q_err
    assert x_err < SAME_FORMULA_TOL, x_err
    # Not a vacuous match: the body does tumble (w changes by O(1) over the 2 s).
    assert np.abs(ours["w"][-1] - W0).max() > 0.5


def test_mujoco_rk4_equals_rk4() -> None:
    dt, steps = 0.01, 200
    mj = run_mujoco("RK4", dt, steps)
    ours = run_ours("rk4", dt, steps)
    w_err = np.abs(mj["w"] - ours["w"]).max()
    q_err = quat_angle_between(mj["q"], ours["q"]).max()
    assert w_err < SAME_FORMULA_TOL, w_err
    assert q_err < RK4_ORIENTATION_TOL, q_err
    # The orientation difference is the O(h^4) of two fourth-order methods: halving dt
    # divides it by ~16 (log2 ratio within 0.5 of 4).
    mj_half = run_mujoco("RK4", dt / 2, 2 * steps)
    ours_half = run_ours("rk4", dt / 2, 2 * steps)
    q_err_half = quat_angle_between(mj_half["q"][-1], ours_half["q"][-1])
    ratio = np.log2(quat_angle_between(mj["q"][-1], ours["q"][-1]) / q_err_half)
    assert abs(ratio - 4.0) < 0.5, ratio


def test_mujoco_implicit_equals_implicit_gyro() -> None:
    """MuJoCo's ``implicit`` takes one Newton step on the velocity-dependent bias (its full
    derivative, here d(w x I w)/dw), as our ``implicit_gyro`` (Bullet's scheme). Our energy
    projection acts only where the Newton step would gain energy, which it does not at
    h |w| = 0.02, so the two agree to round-off."""
    dt, steps = 0.01, 200
    mj = run_mujoco("implicit", dt, steps)
    ours = run_ours("implicit_gyro", dt, steps)
    assert np.abs(mj["w"] - ours["w"]).max() < SAME_FORMULA_TOL
    assert quat_angle_between(mj["q"], ours["q"]).max() < SAME_FORMULA_TOL
