"""Helpers shared by the benchmarks: where the scenes are, what machine ran them, and a
median-of-repeats timer."""

from __future__ import annotations

import os
import platform
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from rigid_env.resources import SCENE_DIR  # noqa: F401  (the benchmarks' scenes)


def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo`` on Linux, else ``platform.processor()``)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown CPU"


def machine_description() -> str:
    """One line: CPU model, core count, OS, Python and NumPy versions."""
    cores = os.cpu_count() or 0
    return (
        f"{cpu_model()}, {cores} core{'s' if cores != 1 else ''}, "
        f"{platform.system()} {platform.machine()}, Python {platform.python_version()}, "
        f"NumPy {np.__version__}"
    )


def refuse_overwrite(paths: Sequence[Path], force: bool) -> None:
    """Stop before a benchmark runs if it would overwrite earlier results without ``--force``.

    Raises:
        ValueError: one line naming the files and the fix.
    """
    there = [p for p in paths if p.exists()]
    if there and not force:
        names = ", ".join(p.name for p in there)
        raise ValueError(
            f"--out: {there[0].parent} holds earlier results ({names}); pass --force to "
            "overwrite them, or choose another --out"
        )


def interleaved_medians(
    jobs: Sequence[Callable[[], int]], repeats: int
) -> list[tuple[float, float]]:
    """Median wall and CPU seconds per unit of work for each job, the jobs run in turn
    ``repeats`` times.

    Each job does some work and returns how many units it did (e.g. steps). Running every job
    once per round, rather than all repeats of one job back to back, spreads slow phases of a
    noisy machine over all of them; the median discards the outliers. The process CPU time is
    kept beside the wall time: on an idle machine the two agree for single-threaded NumPy, and
    their ratio says how much other processes competed for the CPU.

    Args:
        jobs: callables doing one timed run each and returning its number of work units.
        repeats: rounds (>= 1).

    Returns:
        For each job, ``(wall, cpu)``: the medians over rounds of seconds per unit.
    """
    wall: list[list[float]] = [[] for _ in jobs]
    cpu: list[list[float]] = [[] for _ in jobs]
    for _ in range(repeats):
        for k, job in enumerate(jobs):
            c0 = time.process_time()
            t0 = time.perf_counter()
            units = max(job(), 1)
            wall[k].append((time.perf_counter() - t0) / units)
            cpu[k].append((time.process_time() - c0) / units)
    return [(float(np.median(w)), float(np.median(c))) for w, c in zip(wall, cpu, strict=True)]
