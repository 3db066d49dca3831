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

* **Cost.** The same integrator and ``dt`` step a batch of :data:`N_TIMING` bodies (so NumPy,
  not Python overhead, decides), a few steps at a time, all (integrator, dt) pairs of a scene in
  turn, repeated; the median wall time per step divided by ``dt`` is the cost: wall time per
  simulated second for the whole batch. The process CPU time is recorded beside it
  (``step_cpu_s``); their ratio tells whether other processes were competing for the CPU.

Writes ``work_precision.png`` (log-log error against cost, one line per integrator, a point
per ``dt``, one panel per scene), ``accuracy.csv`` (every point) and ``accuracy.md`` (the
cheapest setting for each target error, the cost of each integrator for each target, the
observed orders and the reference's own error).
"""

from __future__ import annotations

import argparse
import csv
import datetime
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from rigid_env.bench._common import (
    SCENE_DIR,
    interleaved_medians,
    machine_description,
    refuse_overwrite,
)
from rigid_env.bench.reference import (
    REF_ATOL,
    REF_RTOL,
    Trajectory,
    angular_momentum_world,
    ivp_reference,
    reference_trajectory,
)
from rigid_env.core.effects import ForceEffect
from rigid_env.core.integrators import INTEGRATORS
from rigid_env.core.rotation import quat_angle_between
from rigid_env.core.state import BodyModel, State
from rigid_env.core.world import NumericalInstabilityError, World, kinetic_energy
from rigid_env.scene import Scene, load_scene

FloatArray = NDArray[np.float64]

TARGETS = (1.0e-2, 1.0e-4, 1.0e-6, 1.0e-8, 1.0e-10)
"""Target errors of the "cheapest setting" table (``err_state``)."""
SAMPLE_INTERVAL = 0.1
"""Seconds between error checkpoints; every ``dt`` of a sweep divides it."""
N_TIMING = 1024
"""Bodies in the timed batch."""
FLOOR_STALL = 1.0e-9
"""Below this error a sweep stops refining ``dt`` once the error no longer halves: it has met
round-off or the reference's own error, and smaller steps would only cost time."""
NEW_INTEGRATORS = ("yoshida4", "exact_free")
"""Drawn with heavier lines in the figure."""


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
    """

    name: str
    steps_per_sample: tuple[int, ...]
    horizon: float | None
    repeats: int
    timing_steps: int
    check_reference: bool


FULL = Sweep("full", (1, 2, 5, 10, 20, 50), None, 15, 10, True)
QUICK = Sweep("quick", (2, 10, 50), 1.0, 5, 6, False)


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
        u = eff.potential_energy(model, s.x)
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
) -> tuple[list[Point], dict[str, float | str]]:
    """Errors and costs of every integrator at every ``dt`` on one scene.

    Returns:
        The points, and facts about the reference (``kind``, ``error_estimate``, ``seconds``).
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
        for k in sweep.steps_per_sample:
            dt = SAMPLE_INTERVAL / k
            p = Point(name, integ, info.order, dt, n_samples * k, horizon, "ok")
            world = scene.build_world(1, integrator=integ, dt=dt)
            try:
                with np.errstate(all="ignore"):
                    for key, val in measure_errors(world, ref, k, act1).items():
                        setattr(p, key, val)
            except NumericalInstabilityError:
                p.status = "diverged"
            if p.status == "ok" and not (p.err_state < 1.0e3):
                p.status = "diverged"  # finite but meaningless (blown up)
            points.append(p)
            line.append(f"{dt:g}:{p.err_state:.1e}" if p.status == "ok" else f"{dt:g}:div")
            n_done = sum(1 for q in points if q.integrator == integ and q.status == "ok")
            if (
                p.status == "ok"
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
        scene.build_world(N_TIMING, integrator=p.integrator, dt=p.dt, on_error="freeze")
        for p in timed
    ]
    for w in worlds:
        w.step(act_n)  # warm up (first-call allocations, imports)

    def job(world: World):
        def run() -> int:
            for _ in range(sweep.timing_steps):
                world.step(act_n)
            return sweep.timing_steps

        return run

    with np.errstate(all="ignore"):
        per_step = interleaved_medians([job(w) for w in worlds], sweep.repeats)
    for p, (sec, cpu) in zip(timed, per_step, strict=True):
        p.step_time_s = sec
        p.step_cpu_s = cpu
        p.cost_s_per_sim_s = sec / p.dt
    log(f"[{name}] timed {len(timed)} settings at N = {N_TIMING}")
    return points, ref_info


# --------------------------------------------------------------------------------------------
# Tables
# --------------------------------------------------------------------------------------------


def cheapest(points: Sequence[Point], target: float) -> Point | None:
    """The measured point of least cost whose ``err_state`` is at most ``target``."""
    good = [p for p in points if p.ok and p.err_state <= target]
    return min(good, key=lambda p: p.cost_s_per_sim_s) if good else None


def write_csv(points: Sequence[Point], path: Path) -> None:
    """One row per point, columns as :class:`Point`'s fields."""
    names = [f.name for f in fields(Point)]
    with open(path, "w", newline="", encoding="utf-8") as fh:
        wr = csv.writer(fh)
        wr.writerow(names)
        for p in points:
            wr.writerow(
                [f"{v:.6g}" if isinstance(v, float) else v for v in (getattr(p, n) for n in names)]
            )


def _fmt_cost(c: float) -> str:
    return f"{c:.3g}"


def markdown(
    points: Sequence[Point],
    ref_info: dict[str, dict[str, float | str]],
    titles: dict[str, str],
    sweep: Sweep,
    machine: str,
    elapsed: float,
) -> str:
    """The Markdown report (see the module docstring)."""
    scenes = list(dict.fromkeys(p.scene for p in points))
    integs = list(dict.fromkeys(p.integrator for p in points))
    out = ["# Accuracy benchmark: what accuracy costs in time", ""]
    out += [
        f"Generated by `rigid-env bench accuracy{' --quick' if sweep.name == 'quick' else ''}`"
        f" ({sweep.name} sweep) on {datetime.date.today().isoformat()} in {elapsed:.0f} s.",
        f"Machine: {machine}.",
        "",
        f"**Cost** = wall time per simulated second for a batch of N = {N_TIMING} bodies "
        f"(median of {sweep.repeats} timed runs of {sweep.timing_steps} steps, all settings "
        "of a scene timed in turn in the same run). **Error** = `err_state`, the maximum "
        "over the run (checkpoints every "
        f"{SAMPLE_INTERVAL:g} s) of the largest of: body angular velocity error (max abs "
        "component, rad/s), orientation error (rotation angle, rad) and position error (max "
        "abs component, m). Energy and angular-momentum errors are in `accuracy.csv`.",
        "",
    ]
    ratios = [p.step_time_s / p.step_cpu_s for p in points if p.ok and p.step_cpu_s > 0.0]
    if ratios:
        load = float(np.median(ratios))
        out += [
            f"Load while timing: median wall / CPU time per step = {load:.2f} (1.0 on an "
            "idle machine"
            + (
                "; other processes competed for the CPU, so single costs may be off by tens "
                "of per cent"
                if load > 1.2
                else ""
            )
            + ").",
            "",
        ]
    check = [
        p
        for p in points
        if p.scene == "bench_torque_free"
        and p.integrator == "rk4"
        and p.status == "ok"
        and math.isclose(p.dt, 0.01)
    ]
    if check:
        c = check[0]
        out += [
            f"Check: `rk4` at dt = 0.01 s on bench_torque_free over {c.horizon_s:g} s: body "
            f"angular velocity error {c.err_w_end:.3g} rad/s at the end, {c.err_w:.3g} "
            "rad/s at most over the run.",
            "",
        ]
    out += ["## Cheapest setting for a target error", ""]
    for sc in scenes:
        pts = [p for p in points if p.scene == sc]
        out += [
            f"**{sc}** ({titles.get(sc, '')}, {pts[0].horizon_s:g} s)",
            "",
            "| target | integrator | dt [s] | cost [s per simulated s] | error reached |",
            "|---:|---|---:|---:|---:|",
        ]
        for tgt in TARGETS:
            c = cheapest(pts, tgt)
            if c is None:
                out.append(f"| {tgt:.0e} | not reached in the sweep | | | |")
            else:
                out.append(
                    f"| {tgt:.0e} | `{c.integrator}` | {c.dt:g} | "
                    f"{_fmt_cost(c.cost_s_per_sim_s)} | {c.err_state:.1e} |"
                )
        out.append("")
    out += [
        "## Cost of each integrator to reach each target",
        "",
        "Least cost [s per simulated s, N = 1024] over the swept dt; `-` where no dt "
        "reached the target.",
        "",
    ]
    for sc in scenes:
        pts = [p for p in points if p.scene == sc]
        out += [
            f"**{sc}**",
            "",
            "| integrator (order) | " + " | ".join(f"{t:.0e}" for t in TARGETS) + " |",
            "|---|" + "---:|" * len(TARGETS),
        ]
        for ig in integs:
            mine = [p for p in pts if p.integrator == ig]
            cells = []
            for tgt in TARGETS:
                c = cheapest(mine, tgt)
                cells.append("-" if c is None else _fmt_cost(c.cost_s_per_sim_s))
            out.append(f"| `{ig}` ({INTEGRATORS[ig].order}) | " + " | ".join(cells) + " |")
        out.append("")
    out += [
        "## Observed order",
        "",
        "Slope of log `err_state` against log dt over the points with 1e-11 < error < "
        "0.1 (nan: fewer than two such points, e.g. an exact method, or a method that "
        "never gets below 0.1 on the scene).",
        "",
        "| integrator | documented | " + " | ".join(scenes) + " |",
        "|---|---:|" + "---:|" * len(scenes),
    ]
    for i in integs:
        cells = [
            f"{observed_order([p for p in points if p.scene == sc and p.integrator == i]):.2f}"
            for sc in scenes
        ]
        out.append(f"| `{i}` | {INTEGRATORS[i].order} | " + " | ".join(cells) + " |")
    out += ["", "## References", ""]
    for sc in scenes:
        info = ref_info[sc]
        est = info.get("error_estimate", math.nan)
        est_s = (
            f"; its error, estimated against a solve at 10x tighter tolerances: {est:.1e}"
            if isinstance(est, float) and math.isfinite(est)
            else ""
        )
        out.append(f"- {sc}: {info['kind']}{est_s}.")
    out += [
        "",
        "Diverged settings (state non-finite or error > 1e3) are left out of the "
        "tables and the figure; `accuracy.csv` lists them with `status = diverged`.",
        "",
    ]
    return "\n".join(out)


# --------------------------------------------------------------------------------------------
# Figure
# --------------------------------------------------------------------------------------------


def plot(
    points: Sequence[Point], titles: dict[str, str], path: Path, machine: str, sweep: Sweep
) -> None:
    """Log-log error against cost, one panel per scene, one line per integrator."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenes = list(dict.fromkeys(p.scene for p in points))
    integs = list(INTEGRATORS)
    cmap = plt.get_cmap("tab10")
    markers = "os^vD<>pXh*"
    fig, axes = plt.subplots(
        1, len(scenes), figsize=(6.0 * len(scenes), 5.6), sharey=True, squeeze=False
    )
    good = [p for p in points if p.ok]
    ymin = max(min((p.err_state for p in good), default=1e-16) / 3.0, 1e-16)
    for ax, sc in zip(axes[0], scenes, strict=True):
        for tgt in TARGETS:
            ax.axhline(tgt, color="0.85", lw=0.8, zorder=0)
        for i, ig in enumerate(integs):
            pts = sorted(
                (p for p in good if p.scene == sc and p.integrator == ig),
                key=lambda p: p.cost_s_per_sim_s,
            )
            if not pts:
                continue
            new = ig in NEW_INTEGRATORS
            ax.loglog(
                [p.cost_s_per_sim_s for p in pts],
                [p.err_state for p in pts],
                marker=markers[i % len(markers)],
                color=cmap(i % 10),
                lw=2.4 if new else 1.3,
                ms=6 if new else 4.5,
                label=f"{ig} (order {INTEGRATORS[ig].order})",
            )
        pts_sc = [p for p in points if p.scene == sc]
        ax.set_title(f"{sc}\n{titles.get(sc, '')}, {pts_sc[0].horizon_s:g} s", fontsize=10)
        ax.set_xlabel(f"wall time per simulated second, N = {N_TIMING} bodies [s]")
        ax.grid(True, which="major", alpha=0.3)
        ax.set_ylim(ymin, 1e1)
    axes[0][0].set_ylabel("max error over the run: |dw| [rad/s], angle [rad], |dx| [m]")
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(
        handles, labels, loc="lower center", ncol=min(len(labels), 5), fontsize=9, frameon=False
    )
    dts = ", ".join(f"{SAMPLE_INTERVAL / k:g}" for k in sweep.steps_per_sample)
    fig.suptitle(
        f"Work-precision ({sweep.name} sweep): error against cost, one point per "
        f"dt in {{{dts}}} s (smaller dt = further right)\n{machine}",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    fig.savefig(path, dpi=130)
    plt.close(fig)


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
    parser.add_argument("--force", action="store_true", help="overwrite earlier results in --out")


def run(args: argparse.Namespace) -> int:
    """Run the benchmark and write its figure and tables to ``args.out``; returns 0.

    Raises:
        OSError: if the output directory cannot be created or written.
    """
    sweep = QUICK if args.quick else FULL
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise OSError(f"--out: {out} is a file; give a directory")
    refuse_overwrite(
        [out / "work_precision.png", out / "accuracy.csv", out / "accuracy.md"], args.force
    )
    out.mkdir(parents=True, exist_ok=True)
    machine = machine_description()
    print(f"accuracy benchmark ({sweep.name} sweep) on {machine}", flush=True)
    t0 = time.perf_counter()
    points: list[Point] = []
    ref_info: dict[str, dict[str, float | str]] = {}
    titles: dict[str, str] = {}
    for case in CASES:
        pts, info = run_case(case, sweep, log=lambda s: print(s, flush=True))
        points += pts
        ref_info[pts[0].scene] = info
        titles[pts[0].scene] = case.title
    elapsed = time.perf_counter() - t0
    write_csv(points, out / "accuracy.csv")
    report = markdown(points, ref_info, titles, sweep, machine, elapsed)
    (out / "accuracy.md").write_text(report, encoding="utf-8")
    plot(points, titles, out / "work_precision.png", machine, sweep)
    print(
        f"wrote {out / 'work_precision.png'}, {out / 'accuracy.csv'}, {out / 'accuracy.md'} "
        f"({elapsed:.0f} s)"
    )
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m rigid_env.bench.accuracy``: one-line errors, no traceback."""
    parser = argparse.ArgumentParser(
        prog="python -m rigid_env.bench.accuracy", description=__doc__.splitlines()[0]
    )
    add_arguments(parser)
    args = parser.parse_args(argv)
    try:
        return run(args)
    except (OSError, ValueError) as exc:
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
