"""The compiled batched draws (rigid_env.envs.streams): each env's row is the stream NumPy's own
methods draw from its generator, bit for bit, and the generator is left where NumPy would leave
it; an env whose generator is replaced draws from the new one, the others keep theirs."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from rigid_env.core.threads import THREAD_MIN_BODIES
from rigid_env.envs.params import Randomization
from rigid_env.envs.sampling import mass_property_draws, random_mass_properties, sensor_noise
from rigid_env.envs.streams import EnvStreams

N = 7


def generators(seed: int = 0) -> list[np.random.Generator]:
    return [np.random.default_rng(seed + i) for i in range(N)]


def followed(rngs: list[np.random.Generator]) -> EnvStreams:
    streams = EnvStreams(N)
    streams.follow(rngs)
    return streams


def test_rows_are_numpys_streams_and_leave_the_generators_where_numpy_would() -> None:
    """standard_normals and randoms equal standard_normal(w) and random(w) of each row's
    generator (the same numbers, not close ones), and the next draw of every generator is the
    one NumPy's generator makes after the same calls."""
    mine, ref = generators(), generators()
    streams = followed(mine)
    rows = np.array([4, 0, 6, 2])
    for draw, width, numpy_draw in (
        (streams.standard_normals, 5, lambda g, w: g.standard_normal(w)),
        (streams.randoms, 3, lambda g, w: g.random(w)),
        (streams.standard_normals, 1, lambda g, w: g.standard_normal(w)),
    ):
        got = draw(rows, width)
        want = np.stack([numpy_draw(ref[i], width) for i in rows])
        np.testing.assert_array_equal(got, want)
    for g, h in zip(mine, ref, strict=True):  # the untouched rows too
        assert g.random() == h.random()


def test_numpys_transformations_of_the_standard_draws_are_its_methods() -> None:
    """normal(0, sigma, 3) is 0 + sigma z (sensor_noise), uniform(lo, hi, k) is lo + (hi - lo) u,
    as NumPy's random_normal and random_uniform compute them: equal, not close."""
    mine, ref = generators(3), generators(3)
    streams = followed(mine)
    for sigma in (0.01, 0.7, 3e-6):
        want = np.stack([g.normal(0.0, sigma, 3) for g in ref])
        np.testing.assert_array_equal(sensor_noise(streams, sigma), want)
    lo, hi = 1.0 - 0.3, 1.0 + 0.3
    want = np.stack([g.uniform(lo, hi, size=4) for g in ref])
    np.testing.assert_array_equal(lo + (hi - lo) * streams.randoms(None, 4), want)


def test_sensor_noise_of_some_rows_draws_nothing_for_the_others() -> None:
    """With rows and n, the other rows are zero and their generators untouched."""
    mine, ref = generators(), generators()
    streams = followed(mine)
    rows = np.array([1, 5])
    noise = sensor_noise(streams, 0.1, rows, N)
    assert noise.shape == (N, 3)
    np.testing.assert_array_equal(np.delete(noise, rows, axis=0), 0.0)
    np.testing.assert_array_equal(noise[rows], np.stack([ref[i].normal(0.0, 0.1, 3) for i in rows]))
    for g, h in zip(mine, ref, strict=True):
        assert g.random() == h.random()


def test_a_new_generator_for_some_envs_is_followed_and_the_others_kept() -> None:
    """follow(rngs, rows) replaces the generators of those envs only; following the same list
    again changes nothing (the streams go on)."""
    mine = generators()
    streams = followed(mine)
    streams.standard_normals(None, 2)
    fresh = [np.random.default_rng(100), np.random.default_rng(101)]
    streams.follow(fresh, np.array([2, 5]))
    streams.follow([*mine[:2], fresh[0], *mine[3:5], fresh[1], *mine[6:]])  # as it now is
    got = streams.standard_normals(None, 3)
    ref = generators()
    for g in ref:
        g.standard_normal(2)
    ref[2], ref[5] = np.random.default_rng(100), np.random.default_rng(101)
    np.testing.assert_array_equal(got, np.stack([g.standard_normal(3) for g in ref]))


def test_pickled_streams_follow_again_and_refuse_to_draw_before() -> None:
    """A pickled EnvStreams keeps no generators (a typed list does not pickle): drawing before a
    follow is a one-line error, after it the streams are the generators'."""
    streams = pickle.loads(pickle.dumps(followed(generators())))
    with pytest.raises(RuntimeError, match=r"follow\(rngs\) first"):
        streams.randoms(None, 1)
    rngs, ref = generators(9), generators(9)
    streams.follow(rngs)
    np.testing.assert_array_equal(streams.randoms(None, 2), np.stack([g.random(2) for g in ref]))


def test_following_the_wrong_number_of_generators_is_refused() -> None:
    with pytest.raises(ValueError, match=f"rngs: expected {N} generators, got 3"):
        EnvStreams(N).follow(generators()[:3])


def test_a_sweep_split_over_threads_draws_each_envs_own_stream() -> None:
    """Thousands of envs (past THREAD_MIN_BODIES: the sweep is cut over Numba's threads):
    every row is its own generator's stream, for all the envs and for most of them, and each
    generator is left where NumPy would leave it."""
    n = 2 * THREAD_MIN_BODIES + 3
    mine = [np.random.default_rng(50 + i) for i in range(n)]
    ref = [np.random.default_rng(50 + i) for i in range(n)]
    streams = EnvStreams(n)
    streams.follow(mine)
    np.testing.assert_array_equal(
        streams.standard_normals(None, 3), np.stack([g.standard_normal(3) for g in ref])
    )
    rows = np.delete(np.arange(n), [0, 7, n // 2, n - 1])
    np.testing.assert_array_equal(
        streams.randoms(rows, 4), np.stack([ref[i].random(4) for i in rows])
    )
    for g, h in zip(mine, ref, strict=True):
        assert g.random() == h.random()


def numpy_mass_properties(u, spread_mass, spread_inertia, mass, inertia):
    """The draws of random_mass_properties written in NumPy over the whole batch (a second
    computation): U(a, b) = a + (b - a) u, the largest moment (the first of equal ones, as
    argmax) clipped to the sum of the others, that sum (I_0 + I_1) + I_2."""
    k, col = u.shape[0], 0
    drawn = np.full(k, mass)
    if spread_mass > 0:
        lo, hi = 1.0 - spread_mass, 1.0 + spread_mass
        drawn = mass * (lo + (hi - lo) * u[:, 0])
        col = 1
    moments = np.tile(inertia, (k, 1))
    if spread_inertia > 0:
        lo, hi = 1.0 - spread_inertia, 1.0 + spread_inertia
        moments = inertia * (lo + (hi - lo) * u[:, col : col + 3])
    rows, largest = np.arange(k), np.argmax(moments, axis=1)
    top = moments[rows, largest]
    total = (moments[:, 0] + moments[:, 1]) + moments[:, 2]
    moments[rows, largest] = np.minimum(top, total - top)
    return drawn, moments


@pytest.mark.parametrize(("spread_mass", "spread_inertia"), [(0.0, 0.5), (0.2, 0.0), (0.3, 0.99)])
@pytest.mark.parametrize("inertia", [[1.0, 2.0, 3.0], [2.0, 2.0, 2.0], [0.01, 5.0, 0.02]])
def test_drawn_mass_properties_are_numpys_formula_bit_for_bit(spread_mass, spread_inertia, inertia):
    """The compiled draw equals the NumPy formula bit for bit; an isotropic body at 0.99 clips
    often (a moment past the sum of the others)."""
    r = Randomization(mass=spread_mass, inertia=spread_inertia)
    u = np.random.default_rng(2).random((300, mass_property_draws(r)))
    got = random_mass_properties(u, r, 1.7, np.array(inertia))
    want = numpy_mass_properties(u, spread_mass, spread_inertia, 1.7, np.array(inertia))
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])
    # A physical body: the largest moment is at most the sum of the others, up to rounding: the
    # clip's (I_0 + I_1) + I_2 - top is two roundings of at most the drawn sum, 3 I_max (1 + s),
    # and the test's own sum of the others one more: 4 u 3 I_max (1 + s) leaves a margin.
    slack = 4 * 2.0**-53 * 3 * max(inertia) * (1.0 + spread_inertia)
    largest = got[1].max(axis=1)
    assert np.all(largest <= got[1].sum(axis=1) - largest + slack)
