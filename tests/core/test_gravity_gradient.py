"""The gravity-gradient torque: the formula at random orientations (a NumPy computation of
its own), the small-angle libration frequency, energy conservation with its potential, and the
scene's checks of its section."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray

from rigid_env.core import BodyModel, State, World
from rigid_env.core.effects import GravityGradient
from rigid_env.scene import load_scene

from roundoff import U

FloatArray = NDArray[np.float64]

MU = 3.986004418e14
"""Earth's gravitational parameter G M [m^3/s^2]."""
R_ORBIT = 7.0e6
"""Distance of the body from the centre [m] (a low Earth orbit's radius)."""
N_MU = MU / R_ORBIT**3
"""``mu / |r|^3`` [1/s^2] (1.16e-6: libration periods of an hour or two)."""
INERTIA = np.array([1.0, 2.0, 3.0])


def torque_numpy(mu: float, center: FloatArray, inertia: FloatArray, s: State) -> FloatArray:
    """(N, 3) ``tau_b = 3 mu / |r|^5 (r_b x I r_b)``, ``r_b = R(q)^T (x - center)``: the matrix
    of ``q`` built here from its components, independently of the core's rotation code."""
    w, x, y, z = s.q.T
    rot = np.stack(  # R(q), rows: body axes in world coordinates as columns of R
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    ).transpose(2, 0, 1)
    rb = np.einsum("nji,nj->ni", rot, s.x - center)
    r = np.linalg.norm(s.x - center, axis=1)
    return 3.0 * mu / r[:, None] ** 5 * np.cross(rb, inertia * rb)


def test_torque_matches_the_formula_at_random_orientations() -> None:
    """Bodies at rest (no gyroscopic term) at random orientations and positions around an
    off-origin centre: ``I alpha`` is the formula's torque, and no force acts."""
    gen = np.random.default_rng(3)
    n = 64
    center = np.array([1.0e5, -2.0e5, 3.0e5])
    q = gen.standard_normal((n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    direction = gen.standard_normal((n, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    x = center + direction * gen.uniform(6.5e6, 4.0e7, (n, 1))
    s = State(x, np.zeros((n, 3)), q, np.zeros((n, 3)))
    inertia = gen.uniform(0.5, 3.0, (n, 3))
    model = BodyModel(gen.uniform(1.0, 5.0, n), inertia)
    world = World(model, [GravityGradient(MU, center)], "rk4", 1.0, state=s)
    a, alpha = world.accelerations(s.x, s.v, s.q, s.w)
    expected = torque_numpy(MU, center, inertia, s)
    # Scale of the torque's terms: 3 mu / |r|^5 |r_b| |I r_b| <= 3 mu / |r|^3 max(I). Each side
    # rounds r_b (a rotation of |r|, ~8 operations per component, and R(q) from |q| = 1 up to
    # 4 U: ~12 U of |r|), the products and differences of the cross product (3 U), the factor
    # 3 mu / |r|^5 (~6 U) and the core's division by I and the test's product by it (2 U): under
    # 25 U of the scale each, 50 U for the difference; 100 U leaves room for any BLAS/CPU.
    r = np.linalg.norm(s.x - center, axis=1)
    scale = 3.0 * MU / r**3 * inertia.max(axis=1)
    assert np.all(np.abs(inertia * alpha - expected) <= 100 * U * scale[:, None])
    assert np.abs(expected).max() > 1e-3 * scale.min()  # the torques are not all ~0
    assert np.array_equal(a, np.zeros_like(a))  # torque only: no force on the centre of mass


def libration(axis_along_r: int, axis_turned: int, name: str, theta0: float, steps: int):
    """A body at rest at ``R_ORBIT`` on the world x axis, its body axis ``axis_along_r`` along
    ``r`` after a turn by ``theta0`` about body axis ``axis_turned``: the angle about that axis
    at each step (the motion stays a rotation about it: the torque is normal to ``r`` and to
    ``I r_b``, both in the plane of the other two axes). Returns ``(t, theta, omega)`` with
    ``omega`` the small-angle frequency of the formula."""
    inertia = INERTIA
    c = axis_turned
    b = 3 - axis_along_r - c
    omega2 = 3.0 * N_MU * (inertia[b] - inertia[axis_along_r]) / inertia[c]
    # Body axis a along world x: a rotation taking e_a to e_x, then the turn about body c.
    base = {0: [1.0, 0.0, 0.0, 0.0], 1: [np.sqrt(0.5), 0.0, 0.0, -np.sqrt(0.5)],
            2: [np.sqrt(0.5), 0.0, np.sqrt(0.5), 0.0]}[axis_along_r]  # fmt: skip
    turn = np.zeros(4)
    turn[0], turn[1 + c] = np.cos(theta0 / 2), np.sin(theta0 / 2)
    from rigid_env.core.rotation import quat_mul

    q0 = quat_mul(np.array(base), turn)
    period = 2 * np.pi / np.sqrt(abs(omega2))
    h = period / 200
    s = State.from_arrays([R_ORBIT, 0.0, 0.0], [0.0, 0.0, 0.0], q0, [0.0, 0.0, 0.0])
    world = World(BodyModel.single(10.0, inertia), [GravityGradient(MU, np.zeros(3))], name, h,
                  state=s)  # fmt: skip
    theta = [theta0]
    for _ in range(steps):
        world.step()
        rel = quat_mul(np.array(base) * [1, -1, -1, -1], world.state.q[0])  # the turn alone
        theta.append(2 * np.arctan2(rel[1 + c], rel[0]))
        assert np.array_equal(world.state.x[0], [R_ORBIT, 0.0, 0.0])  # no force: x stays
    return h * np.arange(steps + 1), np.array(theta), np.sqrt(abs(omega2))


@pytest.mark.parametrize(
    ("name", "rtol"),
    [
        # Relative error of the measured period, summed: the formula is the small-angle limit
        # (the potential goes as sin^2 theta: a pendulum in 2 theta, period x (1 + theta0^2 /
        # 4) = 2.5e-7 at theta0 = 1e-3); linear interpolation of a zero crossing, h = T / 200:
        # <= omega^2 h^3 / 8 per crossing, 6e-7 of T, averaged over 6 crossings; the method's
        # frequency error, (omega h)^4 / 120 = 8e-9 for rk4 and (omega h)^2 / 24 = 4.1e-5 for
        # the second-order splitting (both for the harmonic oscillator). Bounds: 10x the sum.
        ("rk4", 1.0e-5),
        ("splitting", 4.5e-4),
    ],
)
@pytest.mark.parametrize(("axis_along_r", "axis_turned"), [(0, 2), (0, 1)])
def test_small_libration_period(name: str, rtol: float, axis_along_r: int, axis_turned: int):
    """Minimum-inertia axis along ``r``, turned by 1 mrad about a normal axis ``c``: it swings
    back with ``omega^2 = 3 (mu / |r|^3) (I_b - I_a) / I_c`` (``a`` along ``r``, ``b`` the third
    axis), the period measured from the zero crossings of the angle."""
    t, theta, omega = libration(axis_along_r, axis_turned, name, 1.0e-3, 700)
    k = np.flatnonzero(np.sign(theta[1:]) != np.sign(theta[:-1]))
    crossings = t[k] - theta[k] * (t[k + 1] - t[k]) / (theta[k + 1] - theta[k])
    assert len(crossings) >= 6
    measured = 2.0 * np.mean(np.diff(crossings))
    assert abs(measured * omega / (2 * np.pi) - 1.0) < rtol
    assert np.abs(theta).max() < 1.0e-3 * (1 + 1e-6)  # a libration, bounded by its amplitude


def test_maximum_inertia_axis_along_r_is_unstable() -> None:
    """With the largest moment along ``r`` (``I_b - I_a < 0``, ``omega^2 < 0``) the same
    1 mrad turn grows as ``cosh(|omega| t)``, past 0.5 rad by ``|omega| t = acosh(500) = 6.9``;
    the run lasts ``|omega| t = 300 / 200 * 2 pi = 9.4``."""
    _, theta, _ = libration(2, 1, "rk4", 1.0e-3, 300)
    assert np.abs(theta).max() > 0.5


def tumble_energy(name: str, h: float, steps: int) -> tuple[float, float]:
    """Max relative change of the total energy (kinetic plus the gravity gradient's potential)
    and of the kinetic energy alone over a large tumble, relative to the energy that moves
    between them: ``KE0 + (3 mu / (2 |r|^3)) (I_max - I_min)`` (the potential's full swing)."""
    gen = np.random.default_rng(8)
    q = gen.standard_normal(4)
    w = gen.standard_normal(3) * 2.0 * np.sqrt(N_MU)
    s = State.from_arrays([0.0, R_ORBIT, 0.0], [0.0, 0.0, 0.0], q / np.linalg.norm(q), w)
    world = World(BodyModel.single(10.0, INERTIA), [GravityGradient(MU, np.zeros(3))], name, h,
                  state=s)  # fmt: skip
    e0, ke0 = world.energy()[0], world.kinetic_energy()[0]
    scale = ke0 + 1.5 * N_MU * (INERTIA.max() - INERTIA.min())
    de = dke = 0.0
    for _ in range(steps):
        world.step()
        de = max(de, abs(world.energy()[0] - e0))
        dke = max(dke, abs(world.kinetic_energy()[0] - ke0))
    return de / scale, dke / scale


@pytest.mark.parametrize("name", ["rk4", "splitting"])
def test_energy_with_the_potential_is_conserved(name: str) -> None:
    """Over ~3 libration times of a large tumble the kinetic energy swaps with the potential
    ``V = mu / (2 |r|^3) (3 r_b . I r_b / |r|^2 - tr I)`` (MacCullagh's formula) by a good part
    of the scale, while their sum changes only by the method's error, which falls with ``h``
    at the method's order (halving ``h``: 1/4 for splitting, symplectic, whose error stays
    bounded; 1/16 for rk4; asserted with room: below 1/3 and 1/10)."""
    omega = 3.0 * np.sqrt(N_MU)  # the fastest rate here: |w| ~ 2 sqrt(N_MU), the libration's
    h = 0.02 / omega
    steps = 6000
    de, dke = tumble_energy(name, h, steps)
    de_half, _ = tumble_energy(name, h / 2, 2 * steps)
    assert dke > 0.05  # energy does move between the spin and the potential
    # Error bounds, omega h = 0.02 over omega T = 6000 * 0.02 = 120: a method of order p keeps
    # E to C (omega h)^p for a symplectic one (its modified energy; splitting: 4e-4 with C = 1),
    # and to C omega T (omega h)^p for one whose error adds up step by step (rk4: 1.9e-5). C is
    # 1/24 and 1/120 for a harmonic oscillator; a tumble's higher derivatives are larger, so
    # C = 1 here, and the order itself is asserted by halving h.
    bound = {"splitting": 0.02**2, "rk4": 120 * 0.02**4}[name]
    assert de < bound
    assert de_half < de * {"splitting": 1 / 3, "rk4": 1 / 10}[name]


@pytest.mark.parametrize(
    ("section", "match"),
    [
        ({"mu": 0.0, "center": [0, 0, 0]}, r"effects.gravity_gradient.mu"),
        ({"mu": -3.986e14, "center": [0, 0, 0]}, r"effects.gravity_gradient.mu"),
        ({"mu": "3.986e14", "center": [0, 0, 0]}, r"effects.gravity_gradient.mu"),
        ({"mu": 3.986e14, "center": [0, 0]}, r"effects.gravity_gradient.center"),
        ({"mu": 3.986e14}, r"effects.gravity_gradient.center"),
        ({"mu": 3.986e14, "center": [1.0, 2.0, 3.0]}, r"effects.gravity_gradient.center"),
        ({"mu": 3.986e14, "center": [1.05, 2.0, 3.0]}, r"effects.gravity_gradient.center"),
    ],
)
def test_scene_section_is_checked(section: dict, match: str) -> None:
    """A bad mu (zero, negative, text), a malformed or missing centre, and a centre at the body
    (its initial position [1, 2, 3] m, or within its radius of gyration, 0.13 m here) are
    refused with the field named."""
    scene = {
        "name": "gg",
        "body": {"mass": 1.0, "shape": {"box": [0.3, 0.2, 0.1]}},
        "initial": {"position": [1.0, 2.0, 3.0]},
        "effects": {"gravity_gradient": section},
    }
    with pytest.raises(ValueError, match=match):
        load_scene(scene)


def test_scene_section_builds_the_effect() -> None:
    scene = load_scene(
        {
            "name": "gg",
            "body": {"mass": 1.0, "shape": {"box": [0.3, 0.2, 0.1]}},
            "initial": {"position": [R_ORBIT, 0.0, 0.0]},
            "effects": {"gravity_gradient": {"mu": 3.986e14, "center": [0, 0, 0]}},
        }
    )
    (effect,) = scene.effects()
    assert isinstance(effect, GravityGradient)
    assert effect.mu == 3.986e14 and np.array_equal(effect.center, [0.0, 0.0, 0.0])
