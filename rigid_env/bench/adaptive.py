"""The error-controlled integrator (``dop853``) beside its peers, for the accuracy benchmark.

For each tolerance of the sweep, on each scene:

* **Fixed steps.** The cost of the cheapest fixed-step setting of the sweep that reaches the
  same error; where none does, ``rk4`` extrapolated by its measured order from its most accurate
  point above round-off (``dt_needed = dt (target / err)^(1 / order)``, cost per simulated
  second ``~ 1 / dt``).
* **SciPy.** ``solve_ivp(method="DOP853")`` at the same ``rtol = atol`` on the same body
  (:mod:`rigid_env.bench.scipy_peer`), timed in turn with ``dop853`` in the same run: one body
  over the case's horizon (per body, N = 1; the world steps through its ``dt`` with the command
  held, SciPy integrates the horizon in one call), and a batch of ``N_TIMING`` bodies as one
  system over :data:`BATCH_SPAN` seconds.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from rigid_env.bench.scipy_peer import solve
from rigid_env.bench.timing import Case, measure
from rigid_env.core.world import World
from rigid_env.scene import Scene

FloatArray = NDArray[np.float64]

BATCH_SPAN = 1.0
"""Simulated seconds of SciPy's timed batch (its cost per simulated second is per second)."""
MUST_TARGET = 1.0e-10
"""The error at which the issue's must-holds compare costs."""
MUST_FIXED_RATIO = 5.0
"""dop853 costs at most 1/5 of the cheapest fixed-step method at :data:`MUST_TARGET`."""
MUST_SCIPY_RATIO = 50.0
"""dop853 per body at N = 1 is at least 50x faster than SciPy's DOP853 at the same tolerance."""


class PointLike(Protocol):
    """What this module reads of an accuracy point (:class:`rigid_env.bench.accuracy.Point`)."""

    integrator: str
    dt: float
    rtol: float
    err_state: float
    cost_s_per_sim_s: float
    substeps: float

    @property
    def ok(self) -> bool: ...


class SweepLike(Protocol):
    """What this module reads of the benchmark's settings
    (:class:`rigid_env.bench.accuracy.Sweep`)."""

    repeats: int
    clock: str


@dataclass
class PeerRow:
    """dop853 at one tolerance on one scene, beside its peers (costs in s per simulated s)."""

    scene: str
    rtol: float
    dt: float
    err_state: float
    substeps: float
    cost_batch: float
    fixed_label: str
    fixed_cost: float
    per_body: float = math.nan
    scipy_per_body: float = math.nan
    scipy_batch: float = math.nan


def fixed_step_cost(
    points: Sequence[PointLike], target: float, rk4_order: float
) -> tuple[str, float]:
    """``(label, cost)`` of the cheapest fixed-step point with ``err_state <= target``, else of
    ``rk4`` extrapolated to ``target`` by ``rk4_order`` from its most accurate point above
    1e-11 (``("", nan)`` without one)."""
    fixed = [p for p in points if p.ok and math.isnan(p.rtol)]
    good = [p for p in fixed if p.err_state <= target]
    if good:
        best = min(good, key=lambda p: p.cost_s_per_sim_s)
        return f"`{best.integrator}` dt {best.dt:g}", best.cost_s_per_sim_s
    rk4 = [p for p in fixed if p.integrator == "rk4" and p.err_state > 1.0e-11]
    if not rk4 or not rk4_order > 0.0:
        return "", math.nan
    p = min(rk4, key=lambda p: p.err_state)
    dt = p.dt * (target / p.err_state) ** (1.0 / rk4_order)
    return (
        f"`rk4` extrapolated to dt {dt:.2g} (order {rk4_order:.2f})",
        p.cost_s_per_sim_s * p.dt / dt,
    )


def peer_rows(scene_name: str, points: Sequence[PointLike], rk4_order: float) -> list[PeerRow]:
    """One row per tolerance: dop853's cheapest ``dt`` at it, and the fixed-step cost to the
    same error."""
    rows = []
    mine = [p for p in points if p.ok and not math.isnan(p.rtol)]
    for rtol in sorted({p.rtol for p in mine}, reverse=True):
        p = min((q for q in mine if q.rtol == rtol), key=lambda q: q.cost_s_per_sim_s)
        label, cost = fixed_step_cost(points, p.err_state, rk4_order)
        rows.append(
            PeerRow(scene_name, rtol, p.dt, p.err_state, p.substeps, p.cost_s_per_sim_s,
                    label, cost)
        )  # fmt: skip
    return rows


def time_peers(
    rows: Sequence[PeerRow],
    scene: Scene,
    action: Callable[[int], FloatArray | None],
    integrator: str,
    horizon: float,
    n_batch: int,
    sweep: SweepLike,
) -> None:
    """Fill ``per_body``, ``scipy_per_body`` and ``scipy_batch`` of ``rows``: every case timed in
    turn, ``sweep.repeats`` rounds on ``sweep.clock`` (:func:`rigid_env.bench.timing.measure`),
    the median per simulated second. ``action(n)``: the constant command of ``n`` bodies."""
    cases, fill = [], []
    for row in rows:
        tol = {"rtol": row.rtol, "atol": row.rtol}
        one = scene.build_world(1, integrator=integrator, dt=row.dt, **tol)
        steps = round(horizon / row.dt)
        cases.append(Case(f"dop853 {row.rtol:g}", _run(one, steps, action(1)), horizon, calls=1))
        fill.append((row, "per_body", horizon))
        peer = scene.build_world(1)
        cases.append(
            Case(f"scipy {row.rtol:g}", lambda w=peer, r=row.rtol: solve(w, action(1), horizon,
                                                                         r, r),
                 horizon, calls=1)
        )  # fmt: skip
        fill.append((row, "scipy_per_body", horizon))
        batch = scene.build_world(n_batch)
        span = min(horizon, BATCH_SPAN)
        cases.append(
            Case(f"scipy batch {row.rtol:g}",
                 lambda w=batch, r=row.rtol, s=span: solve(w, action(n_batch), s, r, r),
                 span, calls=1)
        )  # fmt: skip
        fill.append((row, "scipy_batch", span))
    with np.errstate(all="ignore"):
        timings = measure(cases, min_time=0.0, repeats=sweep.repeats, clock=sweep.clock)
    for case, (row, field, _) in zip(cases, fill, strict=True):
        setattr(row, field, timings[case.name].per_unit)


def _run(world: World, steps: int, action: FloatArray | None) -> Callable[[], None]:
    """``steps`` steps of ``world`` from its initial state (restored first, untimed work of a
    copy)."""
    start = world.columns.copy()

    def run() -> None:
        world.columns[:] = start
        world.step_count = 0
        for _ in range(steps):
            world.step(action)

    return run


def must_hold(
    rows: Sequence[PeerRow], points: Sequence[PointLike], rk4_order: float, forced: bool = True
) -> list[str]:
    """The issue's two must-holds on one scene, as sentences with the numbers. The bound
    against the fixed steps is the forced scene's (``forced``); on a torque-free scene the
    ratio is given without a verdict (there ``exact_free`` is exact, its cost a fixed price)."""
    mine = [p for p in points if p.ok and not math.isnan(p.rtol) and p.err_state <= MUST_TARGET]
    if not mine:
        return [f"dop853 reached no error <= {MUST_TARGET:g} in the sweep."]
    best = min(mine, key=lambda p: p.cost_s_per_sim_s)
    label, cost = fixed_step_cost(points, MUST_TARGET, rk4_order)
    ratio = cost / best.cost_s_per_sim_s
    out = [
        f"At {MUST_TARGET:g}: `dop853` (rtol {best.rtol:.0e}, dt {best.dt:g}) costs "
        f"{best.cost_s_per_sim_s:.3g} s per simulated s, {label} {cost:.3g}: "
        f"{ratio:.1f}x cheaper "
        + (
            f"(must be >= {MUST_FIXED_RATIO:g}x: "
            f"{'holds' if ratio >= MUST_FIXED_RATIO else 'FAILS'})."
            if forced
            else f"(the issue's {MUST_FIXED_RATIO:g}x is for the scene with forces)."
        )
    ]
    same = [r for r in rows if r.rtol == best.rtol]
    if same and math.isfinite(same[0].per_body):
        r = same[0]
        speedup = r.scipy_per_body / r.per_body
        out.append(
            f"Per body at N = 1, rtol {r.rtol:.0e}: `dop853` {r.per_body * 1e6:.3g} us per "
            f"simulated s, SciPy's DOP853 {r.scipy_per_body * 1e6:.4g} us: {speedup:.0f}x faster "
            f"(must be >= {MUST_SCIPY_RATIO:g}x: "
            f"{'holds' if speedup >= MUST_SCIPY_RATIO else 'FAILS'})."
        )
    return out
