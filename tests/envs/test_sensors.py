"""Sensor models: the noise statistics each model promises, the delay line's exact history, a
noiseless sensor equal to the truth bit for bit without touching the generator, and the
configs' one-line errors.

Statistical checks use a fixed seed and a tolerance of SIGMAS standard errors of the estimator,
the standard error derived from the number of samples (never read off a run)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid_env.core.rotation import quat_angle_between, quat_norm, quat_normalize
from rigid_env.envs.sensors import Delay, Gyro, Magnetometer, StarTracker

SIGMAS = 5.0
"""Tolerance in standard errors: a normal estimator falls outside it with probability 5.7e-7."""
EPS = np.finfo(np.float64).eps


def _sample_std_matches(samples: np.ndarray, sigma: float) -> None:
    """The sample std of zero-mean normal ``samples`` is ``sigma`` within SIGMAS standard
    errors; the std of a sample std of n normal draws is ``sigma / sqrt(2 (n - 1))``."""
    n = samples.size
    assert abs(np.std(samples, ddof=1) - sigma) < SIGMAS * sigma / math.sqrt(2.0 * (n - 1))


# ---- gyro ------------------------------------------------------------------------------------
def test_gyro_white_noise_std_is_arw_over_sqrt_dt() -> None:
    rng = np.random.default_rng(11)
    gyro = Gyro(arw=1.0e-3, rrw=0.0, dt=0.05)
    n_envs, n_steps = 1000, 100  # 3e5 samples: the tolerance is 5 / sqrt(6e5) = 0.65 %
    bias = gyro.reset(np.zeros((n_envs, 3)), rng)
    noise = []
    for _ in range(n_steps):
        w = rng.uniform(-1.0, 1.0, (n_envs, 3))
        w_meas, bias = gyro.measure(w, bias, rng)
        noise.append(w_meas - w)
    _sample_std_matches(np.array(noise), gyro.arw / math.sqrt(gyro.dt))


@pytest.mark.parametrize("bias0", [0.0, 2.0e-3])
def test_gyro_bias_variance_after_n_steps(bias0: float) -> None:
    """``b_n = b_0 + rrw sqrt(dt) (xi_1 + ... + xi_n)``: variance ``n rrw^2 dt + bias0^2``. The
    variance of a sample variance of m normal draws is ``2 sigma^4 / (m - 1)``."""
    rng = np.random.default_rng(12)
    gyro = Gyro(arw=1.0e-4, rrw=1.0e-3, dt=0.1, bias0=bias0)
    n_envs, n_steps = 20_000, 25
    bias = gyro.reset(np.zeros((n_envs, 3)), rng)
    w = np.zeros((n_envs, 3))
    for _ in range(n_steps):
        _, bias = gyro.measure(w, bias, rng)
    expected = n_steps * gyro.rrw**2 * gyro.dt + bias0**2
    m = bias.size  # the three axes are independent: 6e4 draws, tolerance 2.9 %
    assert abs(np.var(bias, ddof=1) - expected) < SIGMAS * expected * math.sqrt(2.0 / (m - 1))


@pytest.mark.parametrize(
    "envs", [np.array([True, False, True, False, False, True]), np.array([4, 1])]
)
def test_gyro_partial_reset_keeps_other_biases(envs: np.ndarray) -> None:
    rng = np.random.default_rng(13)
    gyro = Gyro(arw=1.0e-3, rrw=1.0e-3, dt=0.1, bias0=1.0e-2)
    bias = gyro.reset(np.zeros((6, 3)), rng)
    for _ in range(3):
        _, bias = gyro.measure(np.zeros((6, 3)), bias, rng)
    new = gyro.reset(bias, rng, envs)
    chosen = np.zeros(6, dtype=bool)
    chosen[envs] = True
    assert np.array_equal(new[~chosen], bias[~chosen])
    assert np.all(new[chosen] != bias[chosen])  # redrawn (equal with probability 0)


def test_gyro_same_seed_same_measurements() -> None:
    gyro = Gyro(arw=1.0e-3, rrw=1.0e-3, dt=0.1, bias0=1.0e-2)
    w = np.full((4, 3), 0.3)
    runs = []
    for _ in range(2):
        rng = np.random.default_rng(14)
        bias = gyro.reset(np.zeros((4, 3)), rng)
        runs.append([gyro.measure(w, bias, rng)[0] for _ in range(3)])
    assert np.array_equal(runs[0], runs[1])


# ---- magnetometer and star tracker -----------------------------------------------------------
def test_magnetometer_noise_std_is_sigma() -> None:
    rng = np.random.default_rng(21)
    mag = Magnetometer(sigma=50.0e-9)
    b = rng.uniform(-3.0e-5, 3.0e-5, (100_000, 3))  # a LEO field's size [T]
    _sample_std_matches(mag.measure(b, rng) - b, mag.sigma)


def test_star_tracker_error_angle_unit_norm_and_sign() -> None:
    """The angle between true and measured attitude is ``|dtheta|`` exactly (the exponential
    map, while below pi; here |dtheta| ~ 1e-3), so ``E[angle^2] = 3 sigma^2`` (a chi-square
    with 3 degrees of freedom times sigma^2, variance ``6 sigma^4``: standard error of the
    mean of n ``sigma^2 sqrt(6 / n)``)."""
    rng = np.random.default_rng(22)
    tracker = StarTracker(sigma=1.0e-3)
    n = 200_000
    q = quat_normalize(rng.standard_normal((n, 4)))  # half of them with w < 0
    q_meas = tracker.measure(q, rng)
    angle2 = quat_angle_between(q, q_meas) ** 2
    sigma2 = tracker.sigma**2
    assert abs(angle2.mean() - 3.0 * sigma2) < SIGMAS * sigma2 * math.sqrt(6.0 / n)
    # q / |q| rounds each component by eps/2 and |q| by about eps, so |q_meas| - 1 is a couple
    # of eps (1.5 eps at most seen over 1e6 draws); quat_norm adds about one more: 4 eps.
    assert np.max(np.abs(quat_norm(q_meas) - 1.0)) <= 4.0 * EPS
    assert np.all(q_meas[:, 0] >= 0.0)


# ---- delay -----------------------------------------------------------------------------------
def test_delay_returns_the_value_k_steps_earlier() -> None:
    rng = np.random.default_rng(31)
    k, n_steps = 3, 20
    values = rng.standard_normal((n_steps + 1, 5, 2))
    delay = Delay(k)
    delay.reset(values[0])
    for t in range(1, n_steps + 1):
        assert np.array_equal(delay.push(values[t]), values[max(t - k, 0)])


@pytest.mark.parametrize("envs", [np.array([False, True, False, True, True]), np.array([3, 1])])
def test_delay_partial_reset_fills_only_those_envs(envs: np.ndarray) -> None:
    """After a reset of some envs they return their value at the reset for k pushes, then what
    was pushed after it; the other envs keep their history through the reset."""
    rng = np.random.default_rng(32)
    k = 3
    values = rng.standard_normal((17, 5, 2))
    chosen = np.zeros(5, dtype=bool)
    chosen[envs] = True
    delay = Delay(k)
    delay.reset(values[0])
    for t in range(1, 11):
        delay.push(values[t])
    current = rng.standard_normal((5, 2))
    delay.reset(current, envs)
    for t in range(11, 17):
        out = delay.push(values[t])
        assert np.array_equal(out[~chosen], values[t - k][~chosen])
        expected = current if t - k <= 10 else values[t - k]
        assert np.array_equal(out[chosen], expected[chosen])


def test_delay_zero_is_an_equal_copy() -> None:
    value = np.random.default_rng(33).standard_normal((4, 3))
    delay = Delay(0)
    delay.reset(value)
    out = delay.push(value)
    assert np.array_equal(out, value)
    assert out is not value


def test_delay_push_before_reset_says_what_to_do() -> None:
    with pytest.raises(RuntimeError, match="call reset"):
        Delay(2).push(np.zeros((1, 3)))


# ---- noiseless sensors -----------------------------------------------------------------------
def test_noiseless_sensors_return_truth_bit_for_bit_and_draw_nothing() -> None:
    rng = np.random.default_rng(41)
    w = np.array([[0.1, -0.0, 3.0], [-2.0, 0.0, -1e-300]])  # -0.0 would turn +0.0 if added to 0
    b = np.array([[2.0e-5, -0.0, -4.0e-5], [1.0e-7, 3.0e-5, 0.0]])
    q = np.array([[-0.5, 0.5, -0.5, 0.5], [0.0, -0.6, 0.0, 0.8]])  # w <= 0 kept as given
    before = rng.bit_generator.state
    gyro = Gyro(arw=0.0, rrw=0.0, dt=0.1)
    bias = gyro.reset(np.ones((2, 3)), rng)
    w_meas, bias_next = gyro.measure(w, bias, rng)
    outputs = [
        (w_meas, w),
        (bias_next, np.zeros((2, 3))),
        (Magnetometer(0.0).measure(b, rng), b),
        (StarTracker(0.0).measure(q, rng), q),
    ]
    for out, truth in outputs:
        assert out.tobytes() == truth.tobytes()
    assert rng.bit_generator.state == before


# ---- configs ---------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("make", "field"),
    [
        (lambda: Gyro(arw=-1.0e-3, rrw=0.0, dt=0.1), "arw"),
        (lambda: Gyro(arw=0.0, rrw=math.nan, dt=0.1), "rrw"),
        (lambda: Gyro(arw=0.0, rrw=0.0, dt=0.0), "dt"),
        (lambda: Gyro(arw=0.0, rrw=0.0, dt=math.inf), "dt"),
        (lambda: Gyro(arw=0.0, rrw=0.0, dt=0.1, bias0=-1.0), "bias0"),
        (lambda: Magnetometer(sigma=math.inf), "sigma"),
        (lambda: Magnetometer(sigma="1e-9"), "sigma"),
        (lambda: StarTracker(sigma=-1.0e-5), "sigma"),
        (lambda: Delay(-1), "k"),
        (lambda: Delay(1001), "k"),
        (lambda: Delay(2.0), "k"),
        (lambda: Delay(True), "k"),
    ],
)
def test_bad_config_names_the_field(make, field: str) -> None:
    with pytest.raises(ValueError, match=rf"^{field}: ") as info:
        make()
    assert "\n" not in str(info.value)
