"""The compiled batched draws (rigid_env.envs.streams): each env's row is the stream NumPy's own
methods draw from its generator, bit for bit, and the generator is left where NumPy would leave
it; an env whose generator is replaced draws from the new one, the others keep theirs."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from rigid_env.envs.sampling import sensor_noise
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
