"""The benchmarks' one timing harness: peers timed in turn, round by round, medians.

    timings = measure([Case("rk4", world.step, work=n), ...], min_time=0.02, repeats=5)
    timings["rk4"].rate   # units of work per second (from the median repeat)

How it times (DESIGN.md, "Measuring"). Every measurement is ``time.perf_counter`` around a
block of calls, with the garbage collector off (as ``timeit``); the CPU time of the process
(``time.process_time``, all its threads) is kept beside it. A case is first warmed up, which
also tells how many calls make one repeat last at least ``min_time``; then the cases of a
group (the peers that a table compares) run one repeat each in turn, ``repeats`` rounds, the
order rotating from round to round, so that slow phases of a shared machine fall on all of
them alike. Tables report the median over the repeats and ratios between peers of one group.
"""

from __future__ import annotations

import gc
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

CLOCKS = ("wall", "cpu")
"""``wall``: ``time.perf_counter``; ``cpu``: CPU time of the process (``time.process_time``)."""


@dataclass
class Case:
    """One thing to time.

    Attributes:
        name: label in the tables.
        fn: one call of the measured work.
        work: units of work per call (body-steps, env-steps).
        reset: run before each repeat, outside the timing (e.g. restore the initial state).
        calls: calls per repeat; None = chosen from the warm-up.
        close: releases what the case holds (an environment), after the measurement.
    """

    name: str
    fn: Callable[[], object]
    work: float
    reset: Callable[[], None] | None = None
    calls: int | None = None
    close: Callable[[], None] | None = None


@dataclass(frozen=True)
class Timing:
    """Seconds per call of one case, one number per repeat.

    Attributes:
        work: units of work per call.
        calls: calls per repeat.
        per_call: (repeats,) wall seconds per call (``perf_counter``).
        cpu_per_call: (repeats,) CPU seconds of the process per call (``process_time``):
            steadier than wall time on a shared machine, above it when the work runs on
            several threads, blind to work done in other processes (``SubprocVecEnv``'s).
        clock: which of the two :attr:`median`, :attr:`rate` and :attr:`per_unit` use.
    """

    work: float
    calls: int
    per_call: tuple[float, ...]
    cpu_per_call: tuple[float, ...] = ()
    clock: str = "wall"

    @property
    def seconds(self) -> tuple[float, ...]:
        """(repeats,) seconds per call on :attr:`clock`."""
        return self.cpu_per_call if self.clock == "cpu" else self.per_call

    @property
    def cpu_share(self) -> float:
        """CPU time of the process over wall time, over all repeats."""
        return sum(self.cpu_per_call) / sum(self.per_call) if self.cpu_per_call else math.nan

    @property
    def median(self) -> float:
        """Median seconds per call on :attr:`clock`."""
        return float(np.median(self.seconds))

    @property
    def rate(self) -> float:
        """Units of work per second (from the median)."""
        return self.work / self.median

    @property
    def per_unit(self) -> float:
        """Median seconds per unit of work."""
        return self.median / self.work


def timed(fn: Callable[[], object], calls: int) -> tuple[float, float]:
    """Wall seconds and CPU seconds of the process for ``calls`` calls of ``fn``, garbage
    collector off."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        c0, t0 = time.process_time(), time.perf_counter()
        for _ in range(calls):
            fn()
        return time.perf_counter() - t0, time.process_time() - c0
    finally:
        if enabled:
            gc.enable()


def measure(
    cases: Sequence[Case],
    *,
    min_time: float,
    repeats: int,
    warmup: bool = True,
    clock: str = "wall",
) -> dict[str, Timing]:
    """Time a group of peers, interleaved: each round runs one repeat of every case in turn.

    Warm-up: each case is called once untimed (one-time costs: compiling a step, filling
    caches), then until ``min_time / 2`` has passed (at least once), which sets its calls per
    repeat to ``ceil(min_time / seconds per call)`` (at least 1). A case with ``calls`` set is
    called once untimed (if ``warmup``). The order of the cases rotates from round to round.

    Returns:
        A :class:`Timing` per case name, reporting on ``clock`` (both clocks are kept).
    """
    if clock not in CLOCKS:
        raise ValueError(f"clock: must be one of {CLOCKS}, got {clock!r}")
    calls: dict[str, int] = {}
    for c in cases:
        if c.reset is not None and (warmup or c.calls is None):
            c.reset()
        if warmup:
            c.fn()  # not timed: a first call's one-time costs would inflate the estimate
        if c.calls is not None:
            calls[c.name] = c.calls
            continue
        n, elapsed = 0, 0.0
        while n == 0 or (warmup and elapsed < 0.5 * min_time):
            elapsed += timed(c.fn, 1)[0]
            n += 1
        calls[c.name] = max(1, math.ceil(min_time / (elapsed / n)))
    wall: dict[str, list[float]] = {c.name: [] for c in cases}
    cpu: dict[str, list[float]] = {c.name: [] for c in cases}
    for r in range(repeats):
        k = r % len(cases)
        for c in [*cases[k:], *cases[:k]]:
            if c.reset is not None:
                c.reset()
            seconds, used = timed(c.fn, calls[c.name])
            wall[c.name].append(seconds / calls[c.name])
            cpu[c.name].append(used / calls[c.name])
    for c in cases:
        if c.close is not None:
            c.close()
    return {
        c.name: Timing(c.work, calls[c.name], tuple(wall[c.name]), tuple(cpu[c.name]), clock)
        for c in cases
    }
