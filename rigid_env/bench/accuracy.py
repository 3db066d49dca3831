"""Work-precision benchmark: what accuracy costs in time, for every registered integrator.

    rigid-env bench accuracy [--out DIR] [--quick] [--force]
    python -m rigid_env.bench.accuracy [--out DIR] [--quick] [--force]

For each benchmark scene (``configs/scenes/bench_*.yaml``) and each integrator in
:data:`rigid_env.core.integrators.INTEGRATORS`, a sweep over the step ``dt``:

* **Error.** One body is stepped over the horizon and compared with the reference of
  :mod:`rigid_env.bench.reference` at checkpoints every :data:`SAMPLE_INTERVAL` seconds. Every
  error is the **maximum over the run** (an end value can pass through zero by chance):

  - ``err_w``: body angular velocity, max abs component [rad/s] (``err_w_end``: the same at
    the end of the horizon only);
  - ``err_q``: orientation, angle of the rotation between the two (``quat_angle_between``) [rad];
  - ``err_x``: centre-of-mass position, max abs component [m];
  - ``err_energy``: ``|E - E_ref| / max |E_ref|``, total mechanical energy (drift when the
    scene conserves it) [-];
  - ``err_momentum``: ``|L - L_ref| / max |L_ref|``, world-frame angular momentum about the
    centre of mass [-];
  - ``err_state = max(err_w, err_q, err_x)``: the headline, used in the figure and the
    "cheapest setting" table (the scenes are scaled so that 1 rad/s, 1 rad and 1 m are all of
    order one).

  An error-controlled integrator (``dop853``) is swept over its tolerance ``rtol = atol``
  (:data:`DOP853_RTOLS`) at the world steps :data:`DOP853_DTS` instead.

* **Cost.** The same integrator and ``dt`` step a batch of :data:`N_TIMING` bodies (so the
  batch, not Python overhead, decides), a few steps at a time, all (integrator, dt) pairs of a
  scene in turn, repeated (:mod:`rigid_env.bench.timing`); the median wall time per step
  divided by ``dt`` is the cost: wall time per simulated second for the whole batch. The
  process CPU time per step is kept beside it (``step_cpu_s``).

* **dop853 against its peers** (:mod:`rigid_env.bench.adaptive`): at each tolerance, its cost
  beside the cheapest fixed-step method reaching the same error, and beside SciPy's
  ``solve_ivp(method="DOP853")`` on the same body and tolerance, timed in the same run, per
  body at N = 1 and for the batch.

Writes ``work_precision.png`` (log-log error against cost, one line per integrator, a point
per ``dt``, one panel per scene), ``accuracy.csv`` (every point) and ``accuracy.md`` (the
cheapest setting for each target error, the cost of each integrator for each target, the
observed orders, dop853 against its peers and the reference's own error), through
:mod:`rigid_env.bench.report`.
"""

from __future__ import annotations

import argparse
import datetime
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from rigid_env.bench import report
from rigid_env.bench.adaptive import PeerRow, must_hold, peer_rows, time_peers
from rigid_env.bench.reference import (
    REF_ATOL,
    REF_RTOL,
    Trajectory,
    angular_momentum_world,
    ivp_reference,
    reference_trajectory,
)
from rigid_env.bench.report import Panel, Section, Series, Table
from rigid_env.bench.timing import CLOCKS, Case, measure
from rigid_env.core.effects import ForceEffect
from rigid_env.core.integrators import INTEGRATORS
from rigid_env.core.rotation import quat_angle_between
from rigid_env.core.state import BodyModel, State
from rigid_env.core.world import NumericalInstabilityError, World, kinetic_energy
from rigid_env.resources import SCENE_DIR
from rigid_env.scene import Scene, load_scene

FloatArray = NDArray[np.float64]

TARGETS = (1.0e-2, 1.0e-4, 1.0e-6, 1.0e-8, 1.0e-10, 1.0e-12)
"""Target errors of the "cheapest setting" table (``err_state``)."""
SAMPLE_INTERVAL = 0.1
"""Seconds between error checkpoints; every ``dt`` of a sweep divides it."""
N_TIMING = 1024
"""Bodies in the timed batch."""
FLOOR_STALL = 1.0e-9
"""Below this error a sweep stops refining ``dt`` once the error no longer halves: it has met
round-off or the reference's own error, and smaller steps would only cost time."""
DOP853_RTOLS = (1.0e-4, 1.0e-6, 1.0e-8, 1.0e-10, 1.0e-11, 2.0e-12, 1.0e-12)
"""Tolerances ``rtol = atol`` of the error-controlled integrator's sweep (full run): decades,
and 2e-12, where the scene with forces crosses an error of 1e-10 (rtol 1e-11 reaches about
5e-10 there, 1e-12 about 3e-11), so that the cheapest setting for 1e-10 is measured rather
than rounded to the next decade."""
DOP853_DTS = (0.1, 0.05)
"""World steps [s] of the error-controlled integrator's sweep: it substeps inside each."""
NEW_INTEGRATORS = ("yoshida4", "exact_free", "dop853")
"""Drawn with heavier lines in the figure."""
OUTPUTS = ("work_precision.png", "accuracy.csv", "accuracy.md")


@dataclass(frozen=True)
class BenchCase:
    """One scene of the benchmark.

    Attributes:
        file: scene file name in ``configs/scenes``.
        title: panel title.
        horizon: simulated time of the full sweep [s].
        action: constant thruster command (one number per thruster), or None.
    """

    file: str
    title: str
    horizon: float
    action: tuple[float, ...] | None = None


CASES = (
    BenchCase("bench_torque_free.yaml", "torque-free, I = (1, 2, 3), w0 = (1, 0.1, 2)", 10.0),
    BenchCase("bench_dzhanibekov.yaml", "Dzhanibekov: 10 rad/s about the middle axis", 10.0),
    BenchCase(
        "bench_thrust_gravity_drag.yaml", "thrust + gravity + drag (offset CoP)", 10.0, (1.0, 1.0)
    ),
)


@dataclass(frozen=True)
class Sweep:
    """Settings of one run of the benchmark.

    Attributes:
        name: "full" or "quick".
        steps_per_sample: the ``dt`` values, as steps per :data:`SAMPLE_INTERVAL`.
        horizon: simulated time [s] (None: each case's own).
        repeats: timing rounds.
        timing_steps: steps per timed run.
        check_reference: also solve the force scenes at 10x tighter tolerances to estimate
            the reference's error.
        rtols: the error-controlled integrator's tolerances.
        clock: what a cost is measured in (:data:`rigid_env.bench.timing.CLOCKS`): wall time,
            or the process's CPU time (steadier on a shared machine; run it on one core,
            ``taskset -c 0``, so that no pass is split over threads that wait for a core).
    """

    name: str
    steps_per_sample: tuple[int, ...]
    horizon: float | None
    repeats: int
    timing_steps: int
    check_reference: bool
    rtols: tuple[float, ...] = DOP853_RTOLS
    clock: str = "wall"


FULL = Sweep("full", (1, 2, 5, 10, 20, 50), None, 15, 10, True)
QUICK = Sweep("quick", (2, 10, 50), 1.0, 5, 6, False, (1.0e-6, 1.0e-10))


@dataclass
class Point:
    """One (scene, integrator, dt) of the sweep: its errors and its cost (one CSV row)."""

    scene: str
    integrator: str
    order: int
    dt: float
    steps: int
    horizon_s: float
    status: str
    err_state: float = math.nan
    err_w: float = math.nan
    err_w_end: float = math.nan
    err_q: float = math.nan
    err_x: float = math.nan
    err_energy: float = math.nan
    err_momentum: float = math.nan
    step_time_s: float = math.nan
    step_cpu_s: float = math.nan
    cost_s_per_sim_s: float = math.nan
    n_bodies: int = N_TIMING
    rtol: float = math.nan
    """``rtol = atol`` of an error-controlled integrator (NaN: a fixed-step one)."""
    substeps: float = math.nan
    """Mean substeps per world step of an error-controlled integrator over the error run."""

    def settings(self) -> dict[str, float]:
        """The scene's overrides besides ``integrator`` and ``dt``: its ``rtol = atol``
        (:meth:`rigid_env.scene.Scene.build_world` makes them the world's Tolerances)."""
        return {} if math.isnan(self.rtol) else {"rtol": self.rtol, "atol": self.rtol}

    @property
    def label(self) -> str:
        """``dt`` and, for an error-controlled integrator, its tolerance."""
        return f"{self.dt:g}" + ("" if math.isnan(self.rtol) else f", rtol {self.rtol:.0e}")

    @property
    def ok(self) -> bool:
        """Finite result with a measured cost."""
        return (
            self.status == "ok"
            and math.isfinite(self.err_state)
            and math.isfinite(self.cost_s_per_sim_s)
        )


# --------------------------------------------------------------------------------------------
# Errors
# --------------------------------------------------------------------------------------------


def mechanical_energy(model: BodyModel, effects: Sequence[ForceEffect], s: State) -> FloatArray:
    """(N,) kinetic energy plus the potential of the conservative effects [J]."""
    e = kinetic_energy(model, s)
    for eff in effects:
        u = eff.potential_energy(model, s)
        if u is not None:
            e = e + u
    return e


def measure_errors(
    world: World, ref: Trajectory, steps_per_sample: int, action: FloatArray | None = None
) -> dict[str, float]:
    """Step body 0 of ``world`` to every time of ``ref`` and return the maximum errors.

    Args:
        world: a world in the reference's initial state (``ref.t[0] = 0``); it is advanced.
        ref: reference trajectory at ``0, t1, t2, ...`` with ``t_k = k steps_per_sample dt``.
        steps_per_sample: world steps between checkpoints.
        action: constant command, or None.

    Returns:
        ``err_w, err_w_end, err_q, err_x, err_energy, err_momentum, err_state`` (see the
        module docstring).

    Raises:
        NumericalInstabilityError: if the state turns non-finite.
    """
    model, forces = world.model, world.force_effects
    e_ref = mechanical_energy(model, forces, ref.state())
    l_ref = angular_momentum_world(model, ref)
    e_scale = max(float(np.max(np.abs(e_ref))), 1e-300)
    l_scale = max(float(np.max(np.linalg.norm(l_ref, axis=1))), 1e-300)
    err = dict.fromkeys(("err_w", "err_q", "err_x", "err_energy", "err_momentum"), 0.0)
    for k in range(1, ref.t.size):
        for _ in range(steps_per_sample):
            world.step(action)
        s = world.state
        now = {
            "err_w": float(np.max(np.abs(s.w[0] - ref.w[k]))),
            "err_q": float(quat_angle_between(s.q[0], ref.q[k])),
            "err_x": float(np.max(np.abs(s.x[0] - ref.x[k]))),
            "err_energy": abs(float(world.energy()[0]) - float(e_ref[k])) / e_scale,
            "err_momentum": float(np.linalg.norm(world.angular_momentum_world()[0] - l_ref[k]))
            / l_scale,
        }
        for key, val in now.items():
            err[key] = max(err[key], val) if math.isfinite(val) else math.inf
        err["err_w_end"] = now["err_w"]
    err["err_state"] = max(err["err_w"], err["err_q"], err["err_x"])
    return err


def mean_substeps(world: World, steps: int, action: FloatArray | None) -> float:
    """Mean substeps body 0 of ``world`` takes per step over ``steps`` steps."""
    total = 0
    for _ in range(steps):
        world.step(action)
        total += int(world.substeps_taken[0])
    return total / steps


def observed_order(points: Sequence[Point], low: float = 1.0e-11, high: float = 1.0e-1) -> float:
    """Least-squares slope of ``log err_state`` against ``log dt`` over the points with
    ``low < err < high`` (the asymptotic range, above round-off); NaN with fewer than two."""
    sel = [(p.dt, p.err_state) for p in points if p.status == "ok" and low < p.err_state < high]
    if len(sel) < 2:
        return math.nan
    x, y = np.log([d for d, _ in sel]), np.log([e for _, e in sel])
    return float(np.polyfit(x, y, 1)[0])


# --------------------------------------------------------------------------------------------
# The sweep
# --------------------------------------------------------------------------------------------


def _action_array(case: BenchCase, n: int, action_dim: int) -> FloatArray | None:
    if action_dim == 0:
        return None
    if case.action is None or len(case.action) != action_dim:
        raise ValueError(
            f"{case.file}: the benchmark needs a command of {action_dim} numbers "
            f"for its thrusters, got {case.action}"
        )
    return np.tile(np.asarray(case.action, dtype=np.float64), (n, 1))


def run_case(
    case: BenchCase, sweep: Sweep, scene_dir: Path = SCENE_DIR, log: Callable[[str], None] = print
) -> tuple[list[Point], dict[str, float | str], list[PeerRow]]:
    """Errors and costs of every integrator at every ``dt`` on one scene, and the
    error-controlled integrator beside its peers (:mod:`rigid_env.bench.adaptive`).

    Returns:
        The points, facts about the reference (``kind``, ``error_estimate``, ``seconds``) and
        the peer rows.
    """
    scene: Scene = load_scene(scene_dir / case.file)
    horizon = sweep.horizon if sweep.horizon is not None else case.horizon
    n_samples = round(horizon / SAMPLE_INTERVAL)
    t = SAMPLE_INTERVAL * np.arange(n_samples + 1)
    effects = scene.effects()
    forces = [e for e in effects if isinstance(e, ForceEffect)]
    model = scene.body_model(1)
    s0 = scene.initial_state(1)
    act1 = _action_array(case, 1, scene.action_dim)
    t0 = time.perf_counter()
    ref = reference_trajectory(model, effects, s0, t, None if act1 is None else act1[0])
    ref_info: dict[str, float | str] = {
        "kind": "exact (elliptic functions)"
        if not forces
        else f"solve_ivp DOP853, rtol = {REF_RTOL:g}, atol = {REF_ATOL:g}",
        "seconds": time.perf_counter() - t0,
        "error_estimate": math.nan,
    }
    if forces and sweep.check_reference:
        tight = ivp_reference(
            World(model, forces),
            s0,
            t,
            act1[0] if act1 is not None else None,
            rtol=0.1 * REF_RTOL,
            atol=0.1 * REF_ATOL,
        )
        ref_info["error_estimate"] = max(
            float(np.max(np.abs(tight.w - ref.w))),
            float(np.max(quat_angle_between(tight.q, ref.q))),
            float(np.max(np.abs(tight.x - ref.x))),
        )
    name = scene.name
    log(f"[{name}] reference: {ref_info['kind']} ({ref_info['seconds']:.1f} s)")

    points: list[Point] = []
    for integ, info in INTEGRATORS.items():
        line = []
        prev = math.inf
        settings = (
            [(round(SAMPLE_INTERVAL / dt), r) for dt in DOP853_DTS for r in sweep.rtols]
            if info.error_control
            else [(k, math.nan) for k in sweep.steps_per_sample]
        )
        for k, rtol in settings:
            dt = SAMPLE_INTERVAL / k
            p = Point(name, integ, info.order, dt, n_samples * k, horizon, "ok", rtol=rtol)
            world = scene.build_world(1, integrator=integ, dt=dt, **p.settings())
            try:
                with np.errstate(all="ignore"):
                    for key, val in measure_errors(world, ref, k, act1).items():
                        setattr(p, key, val)
            except NumericalInstabilityError:
                p.status = "diverged"
            if p.status == "ok" and not (p.err_state < 1.0e3):
                p.status = "diverged"  # finite but meaningless (blown up)
            if info.error_control and p.status == "ok":
                p.substeps = mean_substeps(
                    scene.build_world(1, integrator=integ, dt=dt, **p.settings()), p.steps, act1
                )
            points.append(p)
            line.append(f"{p.label}:{p.err_state:.1e}" if p.status == "ok" else f"{p.label}:div")
            n_done = sum(1 for q in points if q.integrator == integ and q.status == "ok")
            if (
                not info.error_control
                and p.status == "ok"
                and p.err_state < FLOOR_STALL
                and p.err_state > 0.5 * prev
                and n_done >= 3
            ):
                break  # the error has stalled at round-off / the reference's error
            prev = p.err_state if p.status == "ok" else math.inf
        log(f"[{name}] {integ:<16} " + "  ".join(line))

    # Cost: all (integrator, dt) pairs of this scene at N_TIMING, in turn, repeated.
    timed = [p for p in points if p.status == "ok"]
    act_n = _action_array(case, N_TIMING, scene.action_dim)
    worlds = [
        scene.build_world(
            N_TIMING, integrator=p.integrator, dt=p.dt, on_error="freeze", **p.settings()
        )
        for p in timed
    ]
    for w in worlds:
        w.step(act_n)  # warm up (first-call allocations, imports)

    def steps(world: World) -> Callable[[], None]:
        def run() -> None:
            for _ in range(sweep.timing_steps):
                world.step(act_n)

        return run

    cases = [
        Case(f"{p.integrator} dt={p.label}", steps(w), sweep.timing_steps, calls=1)
        for p, w in zip(timed, worlds, strict=True)
    ]
    with np.errstate(all="ignore"):
        timings = measure(
            cases, min_time=0.0, repeats=sweep.repeats, warmup=False, clock=sweep.clock
        )
    for p, case in zip(timed, cases, strict=True):
        t = timings[case.name]
        p.step_time_s = t.per_unit
        p.step_cpu_s = float(np.median(t.cpu_per_call)) / t.work
        p.cost_s_per_sim_s = t.per_unit / p.dt
    log(f"[{name}] timed {len(timed)} settings at N = {N_TIMING}")

    rk4_order = observed_order([p for p in points if p.integrator == "rk4"])
    rows: list[PeerRow] = []
    for integ in (i for i, info in INTEGRATORS.items() if info.error_control):
        mine = peer_rows(name, [p for p in points if p.integrator == integ or math.isnan(p.rtol)],
                         rk4_order)  # fmt: skip
        commands = {1: act1, N_TIMING: act_n}
        time_peers(mine, scene, commands.__getitem__, integ, horizon, N_TIMING, sweep)
        rows += mine
    log(f"[{name}] timed dop853 beside SciPy's DOP853 at {len(rows)} tolerances")
    return points, ref_info, rows


# --------------------------------------------------------------------------------------------
# Tables
# --------------------------------------------------------------------------------------------


def cheapest(points: Sequence[Point], target: float) -> Point | None:
    """The measured point of least cost whose ``err_state`` is at most ``target``."""
    good = [p for p in points if p.ok and p.err_state <= target]
    return min(good, key=lambda p: p.cost_s_per_sim_s) if good else None


def _cost(c: float) -> str:
    return f"{c:.3g}"


def peer_section(points: Sequence[Point], rows: Sequence[PeerRow]) -> Section:
    """dop853 at each tolerance beside the cheapest fixed step to the same error and SciPy's
    DOP853 at the same tolerance, and the issue's must-holds."""
    header = ["rtol = atol", "dt [s]", "substeps per step", "error reached",
              f"cost, N = {N_TIMING}", "fixed step to the same error", "its cost", "ratio",
              "per body, N = 1 [us]", "SciPy per body [us]", "ratio",
              f"SciPy, N = {N_TIMING}", "ratio"]  # fmt: skip
    tables, notes = [], []
    for sc in dict.fromkeys(r.scene for r in rows):
        mine = [r for r in rows if r.scene == sc]
        body = [
            [f"{r.rtol:.0e}", f"{r.dt:g}", f"{r.substeps:.2f}", f"{r.err_state:.1e}",
             _cost(r.cost_batch), r.fixed_label or "-", _cost(r.fixed_cost),
             f"{r.fixed_cost / r.cost_batch:.1f}", f"{r.per_body * 1e6:.3g}",
             f"{r.scipy_per_body * 1e6:.4g}", f"{r.scipy_per_body / r.per_body:.0f}",
             _cost(r.scipy_batch), f"{r.scipy_batch / r.cost_batch:.0f}"]
            for r in mine
        ]  # fmt: skip
        tables.append(Table(header, body, "rrrrrlrrrrrrr", caption=f"**{sc}**"))
        pts = [p for p in points if p.scene == sc]
        rk4 = observed_order([p for p in pts if p.integrator == "rk4"])
        forced = any(Path(c.file).stem == sc and c.action is not None for c in CASES)
        notes.append(f"- {sc}: " + " ".join(must_hold(mine, pts, rk4, forced)))
    return Section(
        "dop853 beside fixed steps and SciPy",
        [
            "Costs in seconds per simulated second (`per body` columns in microseconds). "
            "`dop853` at each tolerance at its cheaper world step; beside it the cheapest "
            "fixed-step setting of the sweep that reaches the same error (or `rk4` extrapolated "
            'by its measured order when none does) and SciPy\'s `solve_ivp(method="DOP853")` '
            "at the same tolerance on the same body, its right-hand side the world's compiled "
            f"dynamics: one body over the horizon, and {N_TIMING} bodies as one system over "
            "1 s, timed in turn with `dop853` in the same run. Ratios: how many times cheaper "
            "`dop853` is.",
        ],
        tables,
        after=["\n".join(notes)],
    )


def sections(
    points: Sequence[Point],
    ref_info: dict[str, dict[str, float | str]],
    titles: dict[str, str],
    peers: Sequence[PeerRow] = (),
) -> list[Section]:
    """What ``accuracy.md`` shows: the cheapest setting for each target, the cost of each
    integrator for each target, the observed orders, dop853 beside its peers and the
    references."""
    scenes = list(dict.fromkeys(p.scene for p in points))
    integs = list(dict.fromkeys(p.integrator for p in points))
    targets = [f"{t:.0e}" for t in TARGETS]
    cheapest_tables, cost_tables = [], []
    for sc in scenes:
        pts = [p for p in points if p.scene == sc]
        rows = []
        for tgt in TARGETS:
            c = cheapest(pts, tgt)
            rows.append(
                [f"{tgt:.0e}", "not reached in the sweep", "", "", ""]
                if c is None
                else [f"{tgt:.0e}", f"`{c.integrator}`", c.label,
                      _cost(c.cost_s_per_sim_s), f"{c.err_state:.1e}"]
            )  # fmt: skip
        header = ["target", "integrator", "dt [s]", "cost [s per simulated s]", "error reached"]
        caption = f"**{sc}** ({titles.get(sc, '')}, {pts[0].horizon_s:g} s)"
        cheapest_tables.append(Table(header, rows, "rlrrr", caption=caption))
        rows = []
        for ig in integs:
            mine = [p for p in pts if p.integrator == ig]
            cells = [cheapest(mine, tgt) for tgt in TARGETS]
            rows.append(
                [f"`{ig}` ({INTEGRATORS[ig].order})"]
                + ["-" if c is None else _cost(c.cost_s_per_sim_s) for c in cells]
            )
        cost_tables.append(Table(["integrator (order)", *targets], rows, caption=f"**{sc}**"))
    orders = [
        [f"`{i}`", str(INTEGRATORS[i].order)]
        + [
            "-"  # its error follows rtol, not dt (its order: tests/core/test_dop853.py)
            if INTEGRATORS[i].error_control
            else f"{observed_order([p for p in points if p.scene == sc and p.integrator == i]):.2f}"
            for sc in scenes
        ]
        for i in integs
    ]
    references = []
    for sc in scenes:
        info = ref_info[sc]
        est = info.get("error_estimate", math.nan)
        est_s = (
            f"; its error, estimated against a solve at 10x tighter tolerances: {est:.1e}"
            if isinstance(est, float) and math.isfinite(est)
            else ""
        )
        references.append(f"- {sc}: {info['kind']}{est_s}.")
    adaptive = [peer_section(points, peers)] if peers else []
    return [
        Section("Cheapest setting for a target error", tables=cheapest_tables),
        Section(
            "Cost of each integrator to reach each target",
            [
                f"Least cost [s per simulated s, N = {N_TIMING}] over the swept dt; `-` where "
                "no dt reached the target."
            ],
            cost_tables,
        ),
        Section(
            "Observed order",
            [
                "Slope of log `err_state` against log dt over the points with 1e-11 < error < "
                "0.1 (nan: fewer than two such points, e.g. an exact method, or a method that "
                "never gets below 0.1 on the scene; `-`: an error-controlled method, whose "
                "error follows its tolerance, not dt)."
            ],
            [Table(["integrator", "documented", *scenes], orders)],
        ),
        *adaptive,
        Section(
            "References",
            ["\n".join(references)],
            after=[
                "Diverged settings (state non-finite or error > 1e3) are left out of the "
                "tables and the figure; `accuracy.csv` lists them with `status = diverged`."
            ],
        ),
    ]


def header(points: Sequence[Point], sweep: Sweep, machine: str, elapsed: float) -> list[str]:
    """The paragraphs above the sections: the run, the machine, the definitions, the check."""
    out = [
        f"Generated by `rigid-env bench accuracy{' --quick' if sweep.name == 'quick' else ''}`"
        f" ({sweep.name} sweep) on {datetime.date.today().isoformat()} in {elapsed:.0f} s.",
        f"Machine: {machine}.",
        "",
        f"**Cost** = {'wall' if sweep.clock == 'wall' else 'CPU'} time per simulated second "
        f"for a batch of N = {N_TIMING} bodies "
        f"(median of {sweep.repeats} timed runs of {sweep.timing_steps} steps, all settings "
        "of a scene timed in turn in the same run). **Error** = `err_state`, the maximum "
        f"over the run (checkpoints every {SAMPLE_INTERVAL:g} s) of the largest of: body "
        "angular velocity error (max abs component, rad/s), orientation error (rotation "
        "angle, rad) and position error (max abs component, m). Energy and angular-momentum "
        "errors are in `accuracy.csv`.",
    ]
    check = [
        p
        for p in points
        if (p.scene, p.integrator, p.status) == ("bench_torque_free", "rk4", "ok")
        and math.isclose(p.dt, 0.01)
    ]
    if check:
        c = check[0]
        out += [
            "",
            f"Check: `rk4` at dt = 0.01 s on bench_torque_free over {c.horizon_s:g} s: body "
            f"angular velocity error {c.err_w_end:.3g} rad/s at the end, {c.err_w:.3g} "
            "rad/s at most over the run.",
        ]
    return out


def panels(points: Sequence[Point], titles: dict[str, str]) -> list[Panel]:
    """Log-log error against cost, one panel per scene, one line per integrator."""
    good = [p for p in points if p.ok]
    ymin = max(min((p.err_state for p in good), default=1e-16) / 3.0, 1e-16)
    markers = "os^vD<>pXh*"
    out = []
    for sc in dict.fromkeys(p.scene for p in points):
        series = []
        for i, ig in enumerate(INTEGRATORS):
            pts = sorted(
                (p for p in good if p.scene == sc and p.integrator == ig),
                key=lambda p: p.cost_s_per_sim_s,
            )
            if pts:
                new = ig in NEW_INTEGRATORS
                series.append(
                    Series(f"{ig} (order {INTEGRATORS[ig].order})",
                           [p.cost_s_per_sim_s for p in pts], [p.err_state for p in pts],
                           style=f"{markers[i % len(markers)]}-", color=f"C{i % 10}",
                           width=2.4 if new else 1.3, size=6 if new else 4.5)
                )  # fmt: skip
        horizon = next(p.horizon_s for p in points if p.scene == sc)
        out.append(
            Panel(
                "lines",
                f"{sc}\n{titles.get(sc, '')}, {horizon:g} s",
                f"wall time per simulated second, N = {N_TIMING} bodies [s]",
                "max error over the run: |dw| [rad/s], angle [rad], |dx| [m]",
                series,
                guides=TARGETS,
                ylim=(ymin, 1e1),
            )
        )
    return out


# --------------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------------


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--out DIR``, ``--quick`` and ``--force`` to ``parser``."""
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("results/accuracy"),
        metavar="DIR",
        help="directory for work_precision.png, accuracy.csv and accuracy.md "
        "(default: results/accuracy)",
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help="reduced sweep (3 step sizes, 1 s horizon) that finishes within a minute",
    )
    parser.add_argument(
        "--clock",
        choices=CLOCKS,
        default="wall",
        help="wall: time.perf_counter (default); cpu: CPU time of the process, steadier on a "
        "busy machine (run it on one core: taskset -c 0)",
    )
    parser.add_argument("--force", action="store_true", help="overwrite earlier results in --out")


def run(args: argparse.Namespace) -> int:
    """Run the benchmark and write its figure and tables to ``args.out``; returns 0."""
    sweep = replace(QUICK if args.quick else FULL, clock=args.clock)
    out = report.prepare_out(args.out, OUTPUTS, args.force)
    machine = f"{report.machine()}, {report.versions()}"
    print(f"accuracy benchmark ({sweep.name} sweep) on {machine}", flush=True)
    t0 = time.perf_counter()
    points: list[Point] = []
    ref_info: dict[str, dict[str, float | str]] = {}
    titles: dict[str, str] = {}
    rows: list[PeerRow] = []
    for case in CASES:
        pts, info, peers = run_case(case, sweep, log=lambda s: print(s, flush=True))
        points += pts
        rows += peers
        ref_info[pts[0].scene] = info
        titles[pts[0].scene] = case.title
    elapsed = time.perf_counter() - t0
    report.write_csv(out / "accuracy.csv", points)
    text = report.markdown(
        "Accuracy benchmark: what accuracy costs in time",
        header(points, sweep, machine, elapsed),
        sections(points, ref_info, titles, rows),
    )
    (out / "accuracy.md").write_text(text, encoding="utf-8")
    dts = ", ".join(f"{SAMPLE_INTERVAL / k:g}" for k in sweep.steps_per_sample)
    report.write_figure(
        out / "work_precision.png",
        panels(points, titles),
        f"Work-precision ({sweep.name} sweep): error against cost, one point per dt in "
        f"{{{dts}}} s (smaller dt = further right)\n{machine}",
        ncols=len(CASES),
        panel_size=(6.0, 5.6),
        shared_legend=True,
        dpi=130,
    )
    print(
        f"wrote {out / 'work_precision.png'}, {out / 'accuracy.csv'}, {out / 'accuracy.md'} "
        f"({elapsed:.0f} s)"
    )
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m rigid_env.bench.accuracy [flags]``: the same as ``rigid-env bench accuracy``."""
    from rigid_env.cli import main as cli_main

    return cli_main(["bench", "accuracy", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    raise SystemExit(main())
