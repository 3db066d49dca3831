"""How the core's functions are compiled: the Numba decorators of a per-body function, of a
world step and of a world step over threads.

Every compiled function is written for one body and takes plain numbers and small tuples
(3-vectors ``(x, y, z)``, quaternions ``(w, x, y, z)``, the named tuples of
:mod:`rigid_env.core.layout`) that Numba keeps in registers. ``NUMBA_DISABLE_JIT=1`` runs them
all as plain Python.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from numba import njit
from numba.core.caching import FunctionCache
from numba.core.compiler import Compiler


def cached_where_possible(**options: Any) -> Callable[[Callable[..., Any]], Any]:
    """``njit(cache=True, **options)`` for a function that Numba can cache (one of a file, or
    of a notebook cell), and without the disk cache for one that has no file (typed into a
    REPL or ``python -c``: Numba would refuse with "no locator available"); such a function
    is compiled again in each process, without a word."""
    cached, uncached = njit(cache=True, **options), njit(**options)

    def decorate(func: Callable[..., Any]) -> Any:
        try:
            FunctionCache(func)  # the test Numba's cache=True makes, raising where it cannot
        except RuntimeError:
            return uncached(func)
        return cached(func)

    return decorate


kernel = cached_where_possible(nogil=True, error_model="numpy", forceinline=True)
"""The decorator of every compiled function: cached on disk, the GIL released, IEEE
arithmetic (a division by zero gives inf or NaN, for the world's guard, not an exception), and
inlined into its caller, so that a world step is one loop with no calls but the maths library's."""

pass_kernel = njit(cache=True, nogil=True, error_model="numpy", inline="always")
"""The decorator of a world's pass that takes a per-body function as an argument
(:func:`rigid_env.core.stepping.advance`): inlined at Numba's level, so that each integrator's
entry compiles it with its own per-body function."""


_FLOWS: set = set()


def flow_kernel(function):
    """The decorator of an explicit method's flow ``flow(body, act, m, c, drive, h)``: one step
    of ``body = (x, v, q, w, hw)``, a body and its reaction wheels' momenta
    (:mod:`rigid_env.core.integrators`). A :data:`kernel` that the world step's passes know as
    a flow (:func:`is_flow`): they step every world with it, the wheels' momenta riding through
    it where the bodies carry wheels."""
    _FLOWS.add(function)
    return kernel(function)


def is_flow(step) -> bool:
    """Whether the per-body function ``step`` (compiled or not) is a :func:`flow_kernel`."""
    return getattr(step, "py_func", step) in _FLOWS


class NoAliasCompiler(Compiler):
    """Numba's compiler with its ``noalias`` flag set: the arrays a function gets do not
    overlap (the flag Numba sets itself for the body of a ``prange`` loop). Without the
    promise LLVM cannot vectorise a loop that reads one array and writes another."""

    def define_pipelines(self):
        self.state.flags.noalias = True
        return super().define_pipelines()


world_kernel = njit(cache=True, nogil=True, error_model="numpy", pipeline_class=NoAliasCompiler)
"""The decorator of a world step (:func:`rigid_env.core.stepping.advance` of one
integrator): cached, the GIL released, and arrays that must not overlap."""
threads_kernel = njit(
    cache=True, nogil=True, error_model="numpy", parallel=True, pipeline_class=NoAliasCompiler
)
"""The same for a world step over Numba's threads (``prange``)."""
