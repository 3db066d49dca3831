"""The threading policy: when a compiled pass over bodies (or envs) is split over the cores,
and how a pass over Numba's threads cuts its range. Every body is computed alone, so a split
changes no number: a batch on several threads equals one thread's, bit for bit."""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from typing import Any

import numba
import numpy as np

from rigid_env.core.jit import kernel

THREADS = max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1)
"""Cores this process may use."""
THREAD_MIN_BODIES = 1024
"""Smallest batch split over Numba's threads (below it one thread beats the hand-over)."""
_threads_lock = threading.Lock()  # one threaded pass at a time (not every Numba layer nests)


def threaded(n: int) -> bool:
    """Whether a compiled pass over ``n`` bodies or envs is split over the cores."""
    return n >= THREAD_MIN_BODIES and THREADS > 1


def call_threaded(call: Callable[[int], Any]) -> Any:
    """``call(threads)``, a compiled pass over Numba's threads, one at a time in this process."""
    with _threads_lock:
        return call(numba.get_num_threads())


@kernel
def split_range(start, stop, t, threads):
    """Range ``t`` (an unsigned ``prange`` index) of ``start <= i < stop`` cut in ``threads``,
    as int64 bounds (so that a range entry reuses its compiled code)."""
    n, k = stop - start, np.int64(t)
    return start + n * k // threads, start + n * (k + 1) // threads
