"""Batched draws from the envs' own generators: row ``k`` of a batch drawn from env ``k``'s
generator, for all the rows in one compiled pass instead of one Python call per env.

Numba compiles NumPy's ``Generator`` methods to the same algorithms on the generator's own bit
generator (its state is shared, not copied), so a compiled ``g.standard_normal()`` or
``g.random()`` is the number NumPy's method would have drawn next, and leaves the generator where
NumPy's would: an env draws the same stream whether it is stepped alone or in a batch, and its
generator stays the one the caller holds. A method with parameters is its standard draw
transformed as NumPy's C code transforms it, which the caller writes in NumPy on the batch:
``normal(loc, scale) = loc + scale * standard_normal()`` and ``uniform(low, high) = low +
(high - low) * random()`` (NumPy's ``random_normal`` and ``random_uniform``).

:class:`EnvStreams` keeps the envs' generators in a Numba typed list (what a compiled pass can
take), following the generators it is handed: an env's entry is replaced when a new generator
(a new seed) comes for it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numba import njit, prange
from numba.typed import List
from numpy.typing import NDArray

from rigid_env.core import threads as threading_policy
from rigid_env.core.threads import split_range

FloatArray = NDArray[np.float64]

_draws = njit(cache=True, nogil=True)


@_draws
def _draw(g, normal):
    """The next standard normal of generator ``g`` (``normal``), else its next double in
    [0, 1)."""
    return g.standard_normal() if normal else g.random()


@_draws
def _draw_picked(gens, rows, out, normal):
    """``out[k, j]``: the ``j``-th next draw of generator ``rows[k]``, picked by index (a few
    rows of many)."""
    for k in range(rows.size):
        g = gens[rows[k]]
        for j in range(out.shape[1]):
            out[k, j] = _draw(g, normal)


@_draws
def _draw_sweep(gens, rows, out, normal):
    """:func:`_draw_picked` for increasing ``rows``, walking the generators in order (a walk
    costs a fifth of picking by index per generator)."""
    _sweep_range(gens, rows, out, normal, 0, rows.size)


@_draws
def _sweep_range(gens, rows, out, normal, lo, hi):
    """:func:`_draw_sweep` of the rows ``rows[lo:hi]`` alone (``out[lo:hi]``): the walk passes
    the generators before ``rows[lo]`` without drawing (about a nanosecond each)."""
    k = lo
    i = 0
    for g in gens:
        if k == hi:
            break
        if rows[k] == i:
            for j in range(out.shape[1]):
                out[k, j] = _draw(g, normal)
            k += 1
        i += 1


@njit(cache=True, nogil=True, parallel=True)
def _draw_sweep_threads(gens, rows, out, normal, threads):
    """:func:`_draw_sweep` with the rows cut in ``threads`` contiguous ranges, each drawn on
    one of Numba's threads. Each env draws from its own generator only, so the split changes
    no number and no generator's stream."""
    for t in prange(threads):
        lo, hi = split_range(0, rows.size, t, threads)
        _sweep_range(gens, rows, out, normal, lo, hi)


class EnvStreams:
    """The generators of ``n`` envs, env ``i`` drawing from its own, for compiled draws over
    many envs at once (:meth:`standard_normals`, :meth:`randoms`).

    Before drawing, the caller says which generator each env draws from (:meth:`follow`); an
    entry is replaced only when its generator changed (a new seed), so following the same
    generators step after step costs a comparison of two lists.

    Args:
        n: the number of envs.
    """

    def __init__(self, n: int) -> None:
        self.n = n
        self._gens: list[Any] = [None] * n
        """Env ``i``'s generator (None before it is followed)."""
        self._typed: Any = None
        """The same generators in a Numba typed list (made at the first :meth:`follow`)."""
        self._all = np.arange(n)

    def __getstate__(self) -> dict[str, Any]:
        """Pickled without the generators (a typed list does not pickle): the next
        :meth:`follow` takes them again."""
        return {"n": self.n}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(state["n"])

    def follow(
        self, rngs: Sequence[np.random.Generator], rows: NDArray[np.int64] | None = None
    ) -> None:
        """Env ``rows[k]`` draws from ``rngs[k]`` from now on (``rows`` None: env ``i`` from
        ``rngs[i]``, all ``n``)."""
        if rows is None:
            if not isinstance(rngs, list):
                rngs = list(rngs)
            if rngs == self._gens:  # the same generators: one comparison in C (by identity)
                return
            if len(rngs) != self.n:
                raise ValueError(f"rngs: expected {self.n} generators, got {len(rngs)}")
            rows = self._all
        if self._typed is None:
            self._typed = List([rngs[0]] * self.n)  # placeholders, replaced below
        gens, typed = self._gens, self._typed
        for k, i in enumerate(rows.tolist()):
            g = rngs[k]
            if gens[i] is not g:
                gens[i] = typed[i] = g

    def standard_normals(self, rows: NDArray[np.int64] | None, width: int) -> FloatArray:
        """(K, width) standard normals, row ``k`` the next ``width`` of env ``rows[k]``'s
        generator (``rows`` None: every env's, K = n), as ``standard_normal(width)`` draws
        them."""
        return self._draws(rows, width, normal=True)

    def randoms(self, rows: NDArray[np.int64] | None, width: int) -> FloatArray:
        """(K, width) doubles in [0, 1), row ``k`` the next ``width`` of env ``rows[k]``'s
        generator (``rows`` None: every env's), as ``random(width)`` draws them."""
        return self._draws(rows, width, normal=False)

    def _draws(self, rows: NDArray[np.int64] | None, width: int, normal: bool) -> FloatArray:
        """The draws of :meth:`standard_normals` or :meth:`randoms`: a walk over the generators
        for many increasing rows (split over the cores for a batch as large as the world's
        threaded passes), else picked by index."""
        many = rows is None or (4 * rows.size >= self.n and bool(np.all(rows[1:] > rows[:-1])))
        rows = self._all if rows is None else rows
        out = np.empty((rows.size, width))
        if not (width and rows.size):
            return out
        gens = self._followed()
        if not many:
            _draw_picked(gens, rows, out, normal)
        elif threading_policy.threaded(rows.size):
            threading_policy.call_threaded(
                lambda t: _draw_sweep_threads(gens, rows, out, normal, t)
            )
        else:
            _draw_sweep(gens, rows, out, normal)
        return out

    def generators(self) -> Any:
        """The typed list of the generators followed (env ``i``'s at ``i``), for a compiled
        pass that draws from each env's own (one-line error before any :meth:`follow`)."""
        return self._followed()

    def _followed(self) -> Any:
        """The typed list of the generators followed, or a one-line error before any."""
        if self._typed is None:
            raise RuntimeError("EnvStreams: no generators to draw from; call follow(rngs) first")
        return self._typed
