"""Guards in the core: a non-finite state is an error, never a silent NaN; one diverging body
in a batch leaves the others bit for bit as they were; the optional angular-speed clamp; bad
numbers in (command, state, scene) are clear errors; the triangle inequality of a scene."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import yaml

from rigid_env.bench.stability_cases import HARD_BODIES, torque_free_world
from rigid_env.core import (
    INTEGRATORS,
    BodyModel,
    Gravity,
    Guard,
    NumericalInstabilityError,
    State,
    SubstepLimitError,
    Thrusters,
    World,
)
from rigid_env.scene import SceneError, load_scene

FAST_SPIN_INERTIA, FAST_SPIN_W = HARD_BODIES["fast_spin"]

# A body whose rates square to inf at the first step (|w|^2 ~ 1e400): every integrator that
# forms w x I w overflows at once. splitting never forms it (it turns L by angles h L_k / I_k)
# and stays finite: there the body is merely wild.
WILD_W = (1.0e200, -2.0e200, 1.5e200)
FREEZE = Guard(on_error="freeze")
"""A failed body frozen and flagged, the others going on."""


BATCH_INERTIA = np.array([[1.0, 2.0, 3.0], [0.5, 0.7, 1.1], [2.0, 2.5, 4.0], [1.0, 1.5, 2.4]])


def _thruster_world(
    integrator: str, w0: np.ndarray, bodies=(0, 1, 2, 3), on_error: str = "freeze"
) -> World:
    """Bodies ``bodies`` of a batch of four with asymmetric inertias, gravity and two thrusters
    (per-body commands); body k starts at rates ``w0[k]`` moving along x at k m/s."""
    idx = list(bodies)
    n = len(idx)
    effects = [
        Gravity(),
        Thrusters(
            points=np.array([[0.3, 0.0, 0.0], [0.0, 0.0, -0.2]]),
            directions=np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]),
            max_force=np.array([2.0, 1.0]),
        ),
    ]
    state = State.zeros(n)
    state.w[:] = w0[idx]
    state.v[:, 0] = idx
    return World(
        BodyModel(np.ones(n), BATCH_INERTIA[idx]),
        effects,
        integrator=integrator,
        dt=0.01,
        state=state,
        guard=Guard(on_error=on_error),
    )  # type: ignore[arg-type]


def _commands(steps: int, n: int) -> np.ndarray:
    return np.random.default_rng(3).uniform(-1.0, 1.0, size=(steps, n, 2))


# --------------------------------------------------------------------------------------------
# The error
# --------------------------------------------------------------------------------------------


def test_error_names_body_step_integrator_and_advice():
    """Three bodies, the middle one spinning at |w| dt = 2 under forward Euler (the others
    calm): step 12 raises its energy over 100x what a step can (EXPLOSION_FACTOR; before the
    guard, the overflow of step 19 did), naming body 1, the step, the integrator and the fix;
    the world keeps its last finite state."""
    w0 = np.array([[0.1, 0.2, 0.3], FAST_SPIN_W, [0.3, -0.1, 0.2]])
    inertia = np.array([FAST_SPIN_INERTIA] * 3)
    world = torque_free_world(inertia, w0, "explicit_euler", 0.01)
    with pytest.raises(NumericalInstabilityError) as info:
        for _ in range(100):
            world.step()
    err = info.value
    assert isinstance(err, FloatingPointError)
    assert (err.bodies, err.step, err.integrator, err.dt) == ([1], 12, "explicit_euler", 0.01)
    msg = str(err)
    for part in (
        "body 1",
        "step 12",
        "'explicit_euler'",
        "smaller dt",
        "'implicit_gyro'",
        "'splitting'",
    ):
        assert part in msg
    assert world.step_count == 11
    for a in (world.state.x, world.state.v, world.state.q, world.state.w):
        assert np.isfinite(a).all()


@pytest.mark.parametrize("integrator", list(INTEGRATORS))
def test_no_integrator_hands_back_a_nan(integrator):
    """A wild body (|w| = 2.7e200): after every step the state is finite, or the step raised."""
    world = torque_free_world(FAST_SPIN_INERTIA, WILD_W, integrator, 0.01)
    try:
        for _ in range(5):
            world.step()
            for a in (world.state.x, world.state.v, world.state.q, world.state.w):
                assert np.isfinite(a).all()
    except NumericalInstabilityError as err:
        assert err.bodies == [0] and err.step == world.step_count + 1


# --------------------------------------------------------------------------------------------
# One diverging body does not take the others down
# --------------------------------------------------------------------------------------------

STEPS = 30


@pytest.mark.parametrize("integrator", list(INTEGRATORS))
def test_diverging_body_leaves_the_others_bit_identical(integrator):
    """Four bodies with thrusters and gravity, body 1 wild. The other three end bit for bit
    where they end (a) when body 1 is calm instead and (b) in a world without body 1. The
    world flags body 1 (except under splitting, which keeps even the wild body finite) and
    holds it at its last finite state."""
    calm = np.array([[0.3, 1.0, -0.5], [0.2, 0.1, 0.4], [-1.0, 0.5, 2.0], [0.7, -0.3, 0.1]])
    wild = calm.copy()
    wild[1] = WILD_W
    cmd = _commands(STEPS, 4)
    worlds = {"wild": _thruster_world(integrator, wild), "calm": _thruster_world(integrator, calm)}
    for k in range(STEPS):
        for w in worlds.values():
            w.step(cmd[k])
    others = [0, 2, 3]
    alone = _thruster_world(integrator, calm, bodies=others)
    for k in range(STEPS):
        alone.step(cmd[k][others])
    for name in ("x", "v", "q", "w"):
        got = getattr(worlds["wild"].state, name)[others]
        assert np.array_equal(got, getattr(worlds["calm"].state, name)[others]), name
        assert np.array_equal(got, getattr(alone.state, name)), name
    failed = worlds["wild"].failed
    assert not failed[others].any()
    if failed[1]:
        start = _thruster_world(integrator, wild).state
        assert np.array_equal(worlds["wild"].state.w[1], start.w[1])  # held, finite
    else:
        assert integrator not in ("explicit_euler", "rk4", "implicit_euler", "implicit_gyro")
    assert np.isfinite(worlds["wild"].state.w).all()


def test_step_reports_the_failed_mask_and_reset_clears_it():
    w0 = np.array([[0.1, 0.2, 0.3], WILD_W])
    world = torque_free_world([FAST_SPIN_INERTIA] * 2, w0, "rk4", 0.01, FREEZE)
    bad = world.step()
    assert bad.tolist() == [False, True] and world.failed.tolist() == [False, True]
    world.step()
    assert world.failed.tolist() == [False, True]  # stays flagged
    calm = world.state.copy()
    calm.w[1] = (0.1, 0.0, 0.0)
    world.reset(calm)
    assert not world.failed.any()
    assert not world.step().any()


# --------------------------------------------------------------------------------------------
# max_angular_speed: PhysX's clamp, off by default
# --------------------------------------------------------------------------------------------

# |w| after the clamp may exceed the limit by rounding: the clamp's |w| (2.5 U), the factor
# limit / |w| and the scaling (2 U), the test's own |w| (2.5 U): 7 U, so 8 U = 4 ulps of 1.
CLAMP_RTOL = 4.0 * np.finfo(float).eps


def test_clamp_is_off_by_default():
    world = torque_free_world(FAST_SPIN_INERTIA, FAST_SPIN_W, "splitting", 0.01)
    assert world.max_angular_speed is None
    world.step()
    assert np.linalg.norm(world.state.w) > 199.0


def test_clamp_scales_w_down_to_the_limit_keeping_its_direction():
    """An isotropic body (w constant): the first step starts from the clamped w, as PhysX
    clamps the velocity that then moves the pose, so the body turns by h * 10 rad/s."""
    w0 = np.array([3.0, -4.0, 120.0])
    world = torque_free_world((1.0, 1.0, 1.0), w0, "splitting", 0.01, Guard(10.0))
    world.step()
    w = world.state.w[0]
    assert np.linalg.norm(w) == pytest.approx(10.0, rel=CLAMP_RTOL)
    # Both directions are a normalisation (3.5 U each) of w0 and w0 * s (one more rounding).
    np.testing.assert_allclose(w / np.linalg.norm(w), w0 / np.linalg.norm(w0), rtol=0, atol=1e-15)
    turned = 2.0 * np.arctan2(np.linalg.norm(world.state.q[0, 1:]), world.state.q[0, 0])
    assert turned == pytest.approx(0.1, rel=1e-12)


@pytest.mark.parametrize("integrator", list(INTEGRATORS))
def test_clamp_holds_after_every_step_and_tames_the_fast_spin(integrator):
    """Fast spin (200 rad/s, dt 0.01) under a 50 rad/s clamp: |w| <= 50 after every step, and
    even forward Euler stays finite (the clamp bounds the energy it can pump in)."""
    world = torque_free_world(FAST_SPIN_INERTIA, FAST_SPIN_W, integrator, 0.01, Guard(50.0))
    for _ in range(300):
        world.step()
        assert np.linalg.norm(world.state.w[0]) <= 50.0 * (1.0 + CLAMP_RTOL)
    assert np.isfinite(world.state.q).all() and np.isfinite(world.state.w).all()


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_clamp_rejects_bad_limits(bad):
    with pytest.raises(ValueError, match=r"^Guard\.max_angular_speed: must be a finite number > 0"):
        Guard(max_angular_speed=bad)


def _scene(**top) -> dict:
    scene = {"name": "t", "body": {"mass": 1.0, "shape": {"box": [0.3, 0.2, 0.1]}}}
    scene.update(top)
    return scene


def test_scene_sets_the_clamp():
    assert load_scene(_scene(max_angular_speed=50.0)).build_world().max_angular_speed == 50.0
    assert load_scene(_scene()).build_world().max_angular_speed is None


# --------------------------------------------------------------------------------------------
# Bad numbers in
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf")])
def test_non_finite_command_is_an_error(bad):
    world = _thruster_world("rk4", np.zeros((4, 3)), bodies=(0, 1), on_error="raise")
    with pytest.raises(ValueError, match="NaN or inf"):
        world.step(np.array([[0.5, bad], [0.0, 0.0]]))
    assert world.step_count == 0


@pytest.mark.parametrize(
    ("field", "body", "value"),
    [
        ("x", 1, float("nan")),
        ("v", 0, float("inf")),
        ("q", 2, float("nan")),
        ("w", 1, -float("inf")),
    ],
)
def test_non_finite_state_is_an_error(field, body, value):
    state = State.zeros(3)
    getattr(state, field)[body, 0] = value
    model = BodyModel.single(1.0, FAST_SPIN_INERTIA)
    with pytest.raises(ValueError, match=rf"state\.{field}: body {body} .*non-finite"):
        World(model, state=state)
    world = World(model, n=3)
    with pytest.raises(ValueError, match=rf"state\.{field}: body {body}"):
        world.reset(state)


def test_zero_quaternion_in_a_state_is_an_error():
    state = State.zeros(2)
    state.q[1] = 0.0
    with pytest.raises(ValueError, match=r"state\.q: body 1 is the zero quaternion"):
        World(BodyModel.single(1.0, FAST_SPIN_INERTIA), state=state)


@pytest.mark.parametrize(
    ("top", "field"),
    [
        ({"dt": float("nan")}, "dt"),
        ({"max_angular_speed": float("inf")}, "max_angular_speed"),
        ({"body": {"mass": float("nan"), "shape": {"box": [0.3, 0.2, 0.1]}}}, "body.mass"),
        (
            {
                "body": {
                    "mass": 1.0,
                    "shape": {"box": [0.3, 0.2, 0.1]},
                    "inertia": [1.0, float("inf"), 2.0],
                }
            },
            "body.inertia",
        ),
        ({"initial": {"angular_velocity": [0.0, float("nan"), 0.0]}}, "initial.angular_velocity"),
        (
            {
                "actuators": {
                    "thrusters": [
                        {
                            "point": [float("nan"), 0.0, 0.0],
                            "direction": [0.0, 1.0, 0.0],
                            "max_force": 1.0,
                        }
                    ]
                }
            },
            "actuators.thrusters",
        ),
    ],
)
def test_non_finite_scene_number_is_an_error(top, field):
    with pytest.raises(SceneError, match=field.replace(".", r"\.")):
        load_scene(_scene(**top))


def test_non_finite_core_parameters_are_errors():
    with pytest.raises(ValueError, match="inertia"):
        BodyModel.single(1.0, [1.0, float("nan"), 2.0])
    with pytest.raises(ValueError, match="gravity"):
        Gravity(np.array([0.0, 0.0, float("inf")]))
    with pytest.raises(ValueError, match="thrusters"):
        Thrusters(
            points=np.zeros((1, 3)),
            directions=np.array([[0.0, 1.0, 0.0]]),
            max_force=np.array([float("nan")]),
        )
    with pytest.raises(ValueError, match="dt"):
        World(BodyModel.single(1.0, FAST_SPIN_INERTIA), dt=float("nan"))


# --------------------------------------------------------------------------------------------
# The triangle inequality: a flat plate sits on it and passes, a broken one fails
# --------------------------------------------------------------------------------------------


def _inertia_scene(inertia) -> dict:
    return _scene(
        body={
            "mass": 1.0,
            "shape": {"box": [0.3, 0.2, 0.1]},
            "inertia": [float(i) for i in inertia],
        }
    )


@pytest.mark.parametrize(
    "inertia",
    [
        (1.0, 2.0, 3.0),  # I3 = I1 + I2: a flat plate, exactly
        (0.25, 1.0, 1.25),  # a 1 m x 0.5 m plate of zero thickness, m = 12 kg
        (0.1, 0.2, 0.1 + 0.2),  # 0.1 + 0.2 = 0.30000000000000004 in binary
        (1.0, 2.0, 3.0 * (1.0 + 1.0e-12)),  # 3e-12 over: within the tolerance (1e-9 of the sum)
        (1.0e-6, 1.0, 1.0),  # a thin rod, I1 / I3 = 1e-6
    ],
)
def test_scene_accepts_a_flat_plate_on_the_triangle_inequality(inertia):
    world = load_scene(_inertia_scene(inertia)).build_world()
    np.testing.assert_array_equal(world.model.inertia[0], inertia)


@pytest.mark.parametrize(
    "inertia",
    [
        (1.0, 2.0, 3.1),
        (1.0, 2.0, 3.0 * (1.0 + 1.0e-6)),  # 3e-6 over: far beyond rounding
        (5.0, 1.0, 2.0),
    ],
)
def test_scene_rejects_inertia_that_breaks_the_triangle_inequality(inertia):
    with pytest.raises(SceneError, match="triangle inequality"):
        load_scene(_inertia_scene(inertia))


# --------------------------------------------------------------------------------------------
# A state that explodes in one step is a failure, like a non-finite one (EXPLOSION_FACTOR)
# --------------------------------------------------------------------------------------------

NEEDLE = (1.0e-100, 1.0, 1.0)  # the thinnest moment a scene accepts: a real (symmetric) body
# Moments a scene accepts (its triangle tolerance is 1e-9 of the sum) that no real body has:
# I_z - I_y = 1e-9 is 1e91 times I_x, so Euler's equations turn w_x 1e91 times faster than
# |w|^2 and every integrator but exact_free errs without bound in one step of 0.05 s.
UNREAL = (1.0e-100, 1.0, 1.0 + 1.0e-9)


def test_explosion_factor_covers_forward_eulers_legitimate_steps():
    """The derivation of EXPLOSION_FACTOR: torque-free, forward Euler's one-step energy factor
    1 + h^2 f.I f / (2 E) is at most 1 + 3 (h|w|)^2 for any real body (moments within the
    triangle inequality), checked on 10,000 random bodies and rates; at h|w| = 2 (the widest
    stated stable range) that is 13 < EXPLOSION_FACTOR^2 = 100."""
    from rigid_env.core.integrators import SPLITTING_STABLE
    from rigid_env.core.stepping import EXPLOSION_FACTOR

    rng = np.random.default_rng(0)
    # Real bodies: I1 <= I2, I2 <= I3 <= I1 + I2 (every moment within the sum of the others),
    # thin ones included, the axes shuffled.
    i1 = 10.0 ** rng.uniform(-12, 0, 10_000)
    i2 = i1 + rng.uniform(0.0, 1.0, 10_000)
    inertia = np.stack([i1, i2, i2 + i1 * rng.uniform(0.0, 1.0, 10_000)], axis=1)
    inertia = rng.permuted(inertia, axis=1)
    w = rng.normal(size=(10_000, 3)) * 10.0 ** rng.uniform(-3, 3, (10_000, 1))
    i0, i1, i2 = inertia.T
    f = np.stack(
        [(i1 - i2) * w[:, 1] * w[:, 2] / i0, (i2 - i0) * w[:, 2] * w[:, 0] / i1,
         (i0 - i1) * w[:, 0] * w[:, 1] / i2], axis=1,
    )  # fmt: skip
    energy = 0.5 * np.sum(inertia * w * w, axis=1)
    speed2 = np.sum(w * w, axis=1)
    # E1 - E0 = h^2/2 f.I f <= 3 h^2 |w|^2 E0, i.e. f.I f <= 6 |w|^2 E (up to rounding).
    assert np.all(np.sum(inertia * f * f, axis=1) <= 6.0 * speed2 * energy * (1 + 1e-12))
    assert 1.0 + 3.0 * SPLITTING_STABLE**2 < EXPLOSION_FACTOR**2


@pytest.mark.parametrize("integrator", list(INTEGRATORS))
def test_thinnest_needle_keeps_its_spin_in_a_world(integrator):
    """The issue's body: a needle of moment 1e-100, w = (0.3, 2, 0.1), one step of 0.05 s.
    Torque-free it must keep w_x and |w| (the three-axis splitting took |w| from 2.0 to 1e95);
    under a torque of 0.03 N m about its axis, w_x gains 0.03 * 0.05 / 1e-100 = 1.5e97 rad/s:
    physics, within the forces' reach, so no integrator's guard may call it a failure (one
    that cannot follow it, such as rk4 at h|w| = 1e95, fails the body instead: never a wrong
    state handed back)."""
    w0 = np.array([0.3, 2.0, 0.1])
    world = torque_free_world(NEEDLE, w0, integrator, 0.05, FREEZE)
    world.step()
    assert not world.failed[0]
    w1 = world.state.w[0]
    # w_x' = (I_y - I_z) / I_x w_y w_z = 0 exactly; (w_y, w_z) turn at |f| = w_x |w_yz| = 0.6
    # rad/s^2, and one step moves |w| by at most forward Euler's h^2 |f|^2 / (2 |w|) = 2.2e-4
    # (1.1e-4 relative), by round-off for the methods exact on a symmetric body.
    assert w1[0] == pytest.approx(0.3, abs=1e-12)
    exact = integrator in ("splitting", "yoshida4", "exact_free")
    assert np.linalg.norm(w1) == pytest.approx(np.linalg.norm(w0), rel=1e-12 if exact else 1.2e-4)
    model = BodyModel(np.ones(1), np.array([NEEDLE]))
    couple = Thrusters(  # two 0.1 N thrusters 0.15 m off the axis: 0.03 N m about body x
        points=np.array([[0.0, 0.15, 0.0], [0.0, -0.15, 0.0]]),
        directions=np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]),
        max_force=np.array([0.1, 0.1]),
    )
    state = State.zeros(1)
    state.w[:] = w0
    world = World(model, [couple], integrator, 0.05, state=state, guard=FREEZE)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # beyond the stable h|w|
        world.step(np.ones(2))
    if integrator in ("splitting", "yoshida4", "exact_free"):  # exact for a symmetric body
        assert not world.failed[0]
        assert world.state.w[0, 0] == pytest.approx(0.3 + 0.03 * 0.05 / 1.0e-100, rel=1e-12)
    if not world.failed[0]:
        assert np.isfinite(world.state.w).all()


@pytest.mark.parametrize("integrator", list(INTEGRATORS))
def test_world_fails_a_state_that_explodes_in_one_step(integrator):
    """UNREAL, torque-free: energy is conserved, so no state may hold 100x the energy it began
    with. Every integrator either keeps the body within that (exact_free, exactly: its w_x
    reaches 1e45 rad/s as the energy moves onto the thin axis, the true motion) or the world
    raises, naming body and step, the state left as it was; building the world warns that the
    moments break the triangle inequality, naming exact_free."""
    w0 = np.array([0.3, 2.0, 0.1])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        world = torque_free_world(UNREAL, w0, integrator, 0.05)
    moments = [w for w in caught if "triangle inequality" in str(w.message)]
    assert len(moments) == (0 if integrator == "exact_free" else 1)
    if moments:
        assert f"'{integrator}'" in str(moments[0].message)
        assert "'exact_free'" in str(moments[0].message)
    e0 = float(world.kinetic_energy()[0])
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            for _ in range(5):
                world.step()
                assert float(world.kinetic_energy()[0]) <= 100.0 * e0
    except NumericalInstabilityError as err:
        # dop853 shrinks its substeps to follow the true motion and stops at its limit first
        limit = isinstance(err, SubstepLimitError) and "needed more than max_substeps" in str(err)
        assert err.bodies == [0] and ("blew up" in str(err) or limit)
        assert np.isfinite(world.state.w).all()
        assert float(world.kinetic_energy()[0]) <= 100.0 * e0
    if integrator == "splitting":  # the default: it cannot follow this body
        assert world.step_count < 5


def test_detumble_env_reports_an_explosion_and_truncates():
    """The issue's env case: Detumble with body UNREAL under its default integrator
    (splitting). One step with no thrust cannot raise the energy, so the explosion is reported:
    info["numerical_error"] and truncated, the state left finite. With the real needle of
    moment 1e-100 the same step keeps |w| (the three-axis splitting took it from 2.4 to 5e95
    with no report); with full thrust the needle's w_x jumps by 1.5e97 rad/s, the physics of a
    0.03 N m torque on I_x = 1e-100, and nothing is reported."""
    import gymnasium as gym

    import rigid_env  # noqa: F401  (registers the envs)
    from rigid_env.resources import scene_path

    with open(scene_path("detumble"), encoding="utf-8") as f:
        scene = yaml.safe_load(f)
    outcomes = {}
    for name, inertia in (("needle", NEEDLE), ("unreal", UNREAL)):
        scene["body"] = {"mass": 2.0, "inertia": list(inertia)}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            env = gym.make("RigidEnv/Detumble-v0", scene=scene)
            for thrust in (0.0, 1.0):
                env.reset(seed=0)
                w0 = env.unwrapped.task.world.state.w[0].copy()
                _, _, _, truncated, info = env.step(np.full(6, thrust, np.float32))
                w1 = env.unwrapped.task.world.state.w[0].copy()
                outcomes[name, thrust] = (bool(info["numerical_error"]), truncated, w0, w1)
    error, truncated, w0, w1 = outcomes["unreal", 0.0]
    assert error and truncated and np.isfinite(w1).all()
    error, truncated, w0, w1 = outcomes["needle", 0.0]
    assert not error and not truncated
    assert np.linalg.norm(w1) == pytest.approx(np.linalg.norm(w0), rel=1e-12)
    error, truncated, w0, w1 = outcomes["needle", 1.0]
    assert not error and not truncated
    # Couple x of the scene: two 0.1 N thrusters 0.15 m off the axis; dt = 0.05 s.
    assert w1[0] - w0[0] == pytest.approx(2 * 0.1 * 0.15 * 0.05 / 1.0e-100, rel=1e-9)


def test_guard_without_a_square_root_is_the_same_inequality():
    """The guard's test ``sqrt(E1) <= 10 (sqrt(E0) + s)`` is evaluated squared, without a
    square root (``within_reach``): on 20,000 random energies and reaches over 1e-30 .. 1e100 J
    it agrees with the square-root form wherever the two sides differ by more than rounding
    (a relative 1e-12: both forms round a few times in 1e-16), and a NaN energy is never
    within."""
    from rigid_env.core.stepping import EXPLOSION_FACTOR, within_reach

    rng = np.random.default_rng(5)
    n = 20_000
    e0 = 10.0 ** rng.uniform(-30, 100, n)
    span = np.sqrt(e0) * 10.0 ** rng.uniform(-8, 4, n) * (rng.uniform(size=n) > 0.1)
    # E1 around the bound, from 1e-3 to 1e3 times it
    bound = (EXPLOSION_FACTOR * (np.sqrt(e0) + span)) ** 2
    e1 = bound * 10.0 ** rng.uniform(-3, 3, n)
    rooted = np.sqrt(e1) <= EXPLOSION_FACTOR * (np.sqrt(e0) + span)
    squared = np.array([within_reach(a, (b, c)) for a, b, c in zip(e1, e0, span, strict=True)])
    clear = np.abs(e1 / bound - 1.0) > 1e-12
    assert np.array_equal(squared[clear], rooted[clear])
    assert rooted.any() and not rooted.all()
    assert not within_reach(float("nan"), (1.0, 1.0))
    assert within_reach(0.0, (0.0, 0.0)) and not within_reach(1.0, (0.0, 0.0))
