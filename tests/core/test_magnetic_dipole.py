"""The magnetic dipole torque ``tau_b = m_b x (R^T B)``: the formula at random orientations
(NumPy's cross product of its own rotation), the small-angle oscillation period of a body
whose dipole lies along an axis, energy conservation with ``U = -m . B``, and the scene's
section."""

from __future__ import annotations

import numpy as np
import pytest

from rigid_env.core import BodyModel, MagneticDipole, State, World
from rigid_env.scene import SceneError, load_scene

from roundoff import U

INERTIA = np.array([2.0, 2.0, 1.0])
"""A symmetric body (a rod-like cylinder: the axis z the least moment)."""


def matrix(q: np.ndarray) -> np.ndarray:
    """(N, 3, 3) ``R(q)``, built here from the components (not the core's rotation code)."""
    w, x, y, z = q.T
    return np.stack(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    ).transpose(2, 0, 1)


def test_torque_is_the_cross_product_at_random_orientations() -> None:
    """Bodies at rest (no gyroscopic term) at random orientations: ``I alpha = m_b x R^T B``,
    no force. Tolerance: a rotation and a cross product of numbers of size ``|m| |B|``, a few
    tens of roundings of it."""
    gen = np.random.default_rng(7)
    n = 64
    q = gen.standard_normal((n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    dipole, field = np.array([0.3, -1.2, 0.8]), np.array([2.0e-5, -1.0e-5, 4.0e-5])
    inertia = gen.uniform(1.0, 2.0, (n, 3))  # |I_j - I_k| < 1 < I_i: real bodies
    s = State(gen.standard_normal((n, 3)), np.zeros((n, 3)), q, np.zeros((n, 3)))
    world = World(
        BodyModel(np.ones(n), inertia), [MagneticDipole(dipole, field)], "rk4", 0.1, state=s
    )
    a, alpha = world.accelerations(s.x, s.v, s.q, s.w)
    field_body = np.einsum("nji,j->ni", matrix(q), field)
    expected = np.cross(dipole, field_body)
    scale = np.linalg.norm(dipole) * np.linalg.norm(field)
    np.testing.assert_array_equal(a, 0.0)
    np.testing.assert_allclose(inertia * alpha, expected, rtol=0, atol=64 * U * scale)


@pytest.mark.parametrize("method", ["rk4", "splitting", "dop853"])
def test_small_angle_oscillation_has_the_compass_period(method: str) -> None:
    """The dipole along the body's z, the field along world z, the body tilted by ``theta0``
    about x: ``I_x theta'' = -|m| |B| sin(theta)``, a pendulum of period ``T = 2 pi sqrt(I_x /
    (|m| |B|))`` for small angles (Griffiths Sec. 6.1.2 for the torque). With ``theta0 = 1e-3``
    the period is longer by ``theta0^2 / 16 = 6e-8`` of it; after one period the tilt is back
    to ``theta0`` within that, plus the method's phase error (rk4 at 200 steps a period:
    ``(2 pi / 200)^4 / 120 ~ 1e-8`` a radian of phase a period): ``1e-3 * 1e-5`` covers both."""
    moment, b = 2.0, 0.5
    period = 2.0 * np.pi * np.sqrt(INERTIA[0] / (moment * b))
    theta0 = 1.0e-3
    q = np.array([[np.cos(theta0 / 2), np.sin(theta0 / 2), 0.0, 0.0]])
    s = State(np.zeros((1, 3)), np.zeros((1, 3)), q, np.zeros((1, 3)))
    spec = MagneticDipole(np.array([0.0, 0.0, moment]), np.array([0.0, 0.0, b]))
    world = World(BodyModel(np.ones(1), INERTIA[None]), [spec], method, period / 200, state=s)
    tilts = []
    for _ in range(200):
        world.step()
        qw, qx = world.state.q[0, :2]
        tilts.append(2.0 * np.arctan2(qx, qw))
    assert tilts[99] == pytest.approx(-theta0, abs=theta0 * 1e-4)  # half a period: the other side
    assert tilts[-1] == pytest.approx(theta0, abs=theta0 * 1e-5)


def test_energy_with_the_dipole_potential_is_conserved() -> None:
    """A tumbling asymmetric body: ``E = 1/2 w.I w - m . B`` is conserved; rk4 at ``h |w| =
    0.01`` errs ``O(h^4)`` a unit time, 1e-10 of ``E`` over 10 s is well above it."""
    q = np.array([[0.9, 0.3, 0.3, np.sqrt(0.01)]])
    s = State(np.zeros((1, 3)), np.zeros((1, 3)), q, np.array([[0.7, -0.4, 0.5]]))
    spec = MagneticDipole(np.array([0.2, 0.5, 1.0]), np.array([0.3, 0.0, 0.4]))
    world = World(BodyModel(np.ones(1), np.array([[1.0, 2.0, 3.0]])), [spec], "rk4", 0.01, state=s)
    e0 = world.energy()[0]
    for _ in range(1000):
        world.step()
    assert abs(world.energy()[0] - e0) < 1e-10 * abs(e0)


SCENE = {
    "dt": 0.01,
    "body": {"mass": 1.0, "inertia": [1.0, 2.0, 3.0]},
    "effects": {"magnetic_dipole": {"dipole": [0.0, 0.0, 1.0], "field": [0.0, 2.0e-5, 4.0e-5]}},
}


def test_scene_section_builds_the_effect() -> None:
    world = load_scene(SCENE).build_world()
    assert world.parameters.magnetic_dipole == 1.0
    assert world.parameters.magnetic_field_z == 4.0e-5
    assert (
        load_scene({k: v for k, v in SCENE.items() if k != "effects"})
        .build_world()
        .parameters.magnetic_dipole
        == 0.0
    )


@pytest.mark.parametrize(
    ("section", "field"),
    [
        ({"dipole": [0, 0, 1]}, "effects.magnetic_dipole.field"),
        ({"dipole": [0, 0], "field": [0, 0, 1]}, "effects.magnetic_dipole.dipole"),
        ({"dipole": [0, 0, "x"], "field": [0, 0, 1]}, "effects.magnetic_dipole.dipole"),
        ({"dipole": [0, 0, 1], "field": [0, 0, float("nan")]}, "effects.magnetic_dipole.field"),
        ({"dipole": [0, 0, 1], "field": [0, 0, 1], "strength": 2}, "effects.magnetic_dipole"),
    ],
)
def test_scene_section_refuses_bad_values(section: dict, field: str) -> None:
    with pytest.raises(SceneError, match=field.replace(".", r"\.")):
        load_scene(SCENE | {"effects": {"magnetic_dipole": section}})
