"""Stability: every hard case of :mod:`rigid_env.bench.stability_cases`, measured against its
bound, at the lengths the issue asks for.

    rigid-env bench stability [--out DIR] [--quick] [--force]

prints, and with ``--out`` writes as ``stability.md`` and ``stability.csv``, a table (case,
figure reached, bound, pass) and the separatrix report (which integrators cross the
separatrix, at which step rate). ``--quick`` runs the test-suite's lengths
(:data:`CI_LENGTHS`). It reports numbers, not timings; the exit status is 1 if a bound is
missed.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigid_env.bench import report
from rigid_env.bench.report import Section, Table
from rigid_env.bench.stability_cases import (
    ENERGY_GAIN_RTOL,
    EXP_MAP_TOL,
    EXPLICIT_EULER_GROWTH,
    FLIP_TIME_RTOL,
    FORWARD_EULER_W,
    HARD_DT,
    L_NORM_RTOL,
    LINEAR_LAG_RTOL,
    SCALE_RTOL,
    SECULAR_DRIFT_FACTOR,
    SEPARATRIX_W_TOL,
    SPLITTING_ENERGY_BELOW_LIMIT,
    THIN_BODIES,
    THIN_KINDS,
    THIN_RATIOS,
    UNIT_Q_TOL,
    SeparatrixResult,
    ThinRun,
    dzhanibekov,
    energy,
    explicit_euler_growth,
    hard_batch,
    long_horizon,
    max_step_gain,
    orientation_lag,
    record,
    scale_invariance,
    separatrix,
    thin_bodies,
    torque_free_world,
)
from rigid_env.core.integrators import INTEGRATORS

OUTPUTS = ("stability.md", "stability.csv")
EXACT_ON_SYMMETRIC = ("splitting", "yoshida4", "exact_free")
"""Integrators whose step is the exact flow of a symmetric body (a needle)."""

FULL_LENGTHS = {
    "dzhanibekov_s": 60.0,
    "hard_steps": 20_000,
    "thin_steps": 10_000,
    "thin_ratio_steps": 2_000,
    "long_steps": 100_000,
    "scale_steps": 300,
}
"""The lengths the issue asks for."""
CI_LENGTHS = {
    "dzhanibekov_s": 6.5,
    "hard_steps": 1_000,
    "thin_steps": 1_000,
    "thin_ratio_steps": 200,
    "long_steps": 10_000,
    "scale_steps": 50,
}
"""The lengths the test-suite runs: the same physics, shorter (the Dzhanibekov horizon keeps
the first flip, at 5.6 s; the fast spin's trouble, where it comes, comes within 20 steps)."""
SEPARATRIX_RATES = (30.0, 60.0, 120.0, 240.0, 480.0)
"""Step rates [Hz] of the separatrix report."""


@dataclass(frozen=True)
class Row:
    """One line of the table: ``figure <= bound`` (or ``==`` / ``>=`` per ``relation``)."""

    case: str
    figure: float | str
    bound: float | str
    relation: str = "<="

    @property
    def passed(self) -> bool:
        """The figure meets the bound (always true for a reported figure)."""
        if self.relation == "report":
            return True
        if self.relation == "==":
            return self.figure == self.bound
        if self.relation == "finite":
            return self.figure == "finite" or str(self.figure).startswith("error at step")
        f, b = float(self.figure), float(self.bound)  # type: ignore[arg-type]
        return f <= b if self.relation == "<=" else f >= b


def _fmt(x: float | str) -> str:
    if isinstance(x, str):
        return x
    if x == 0.0 or not np.isfinite(x):
        return f"{x:g}"
    return f"{x:.3g}" if 1e-3 <= abs(x) < 1e4 else f"{x:.2e}"


def stability_rows(
    lengths: dict[str, float],
    log: Callable[[str], None] = print,
    thin_runs: list[ThinRun] | None = None,
) -> list[Row]:
    """Run every case at ``lengths`` (:data:`FULL_LENGTHS` or :data:`CI_LENGTHS`); the needle
    and plate runs are also appended to ``thin_runs`` if given (for :func:`thin_table`)."""
    rows: list[Row] = []
    t_end = float(lengths["dzhanibekov_s"])
    for name in ("rk4", "splitting"):
        log(f"dzhanibekov {name} {t_end:g} s")
        r = dzhanibekov(name, t_end)
        rows.append(
            Row(
                f"Dzhanibekov {name}, dt 1e-3, {t_end:g} s: flips (exact {r.exact_flips})",
                r.flips,
                r.exact_flips,
                "==",
            )
        )
        rows.append(
            Row(
                f"Dzhanibekov {name}: last flip time, relative error",
                r.last_flip_rel_error,
                FLIP_TIME_RTOL,
            )
        )
    hard_steps, thin_steps = int(lengths["hard_steps"]), int(lengths["thin_steps"])
    for name in INTEGRATORS:
        log(f"hard batch {name} {max(hard_steps, thin_steps)} steps")
        hr = hard_batch(name, max(hard_steps, thin_steps))
        failed_at = int(hr.run.first_failure[hr.index("fast_spin")])
        held = failed_at < 0 or failed_at > hard_steps
        status = "finite" if held else f"error at step {failed_at}"
        rows.append(
            Row(
                f"Fast spin {name}, h|w| = 2, {hard_steps} steps: outcome",
                status,
                "finite or clear error",
                "finite",
            )
        )
        if name == "splitting":
            rows.append(
                Row(
                    "Fast spin splitting: | |L| - |L0| | / |L0|",
                    hr.l_norm_drift("fast_spin", hard_steps),
                    L_NORM_RTOL,
                )
            )
            e = hr.energy("fast_spin", hard_steps)
            rows.append(
                Row(
                    "Fast spin splitting: max |E - E0| / E0 (reported: h|w| = 2, inside "
                    "splitting's linear stability limit about this major axis, 2.195)",
                    float(np.max(np.abs(e - e[0])) / e[0]),
                    "-",
                    "report",
                )
            )
            below = torque_free_world((1.0, 2.0, 3.0), (0.5, 0.5, 150.0), "splitting", HARD_DT)
            e = energy(np.array([1.0, 2.0, 3.0]), record(below, hard_steps).w[:, 0])
            rows.append(
                Row(
                    f"Spin at h|w| = 1.5, splitting, {hard_steps} steps: max |E - E0| / E0",
                    float(np.max(np.abs(e - e[0])) / e[0]),
                    SPLITTING_ENERGY_BELOW_LIMIT,
                )
            )
        if name in ("implicit_gyro", "implicit_euler"):
            rows.append(
                Row(
                    f"Fast spin {name}: largest one-step energy gain, relative",
                    float(max_step_gain(hr.energy("fast_spin", hard_steps)[:, None])[0]),
                    ENERGY_GAIN_RTOL,
                )
            )
        if name not in FORWARD_EULER_W:
            ok = all(hr.finite(b, thin_steps) for b in THIN_BODIES)
            rows.append(
                Row(
                    f"Thin rods 1e-4/1e-6, plates 1e-4/1e-6/flat, {name}, {thin_steps} "
                    "steps: all finite",
                    "finite" if ok else "NaN",
                    "finite",
                    "==",
                )
            )
        if name == "splitting":
            rows.append(
                Row(
                    "Thin rods and plates, splitting: | |L| - |L0| | / |L0|",
                    max(hr.l_norm_drift(b, thin_steps) for b in THIN_BODIES),
                    L_NORM_RTOL,
                )
            )
        log(f"needles and plates {name} {int(lengths['thin_ratio_steps'])} steps")
        thin = thin_bodies(name, int(lengths["thin_ratio_steps"]))
        rows.extend(thin_rows(thin))
        if thin_runs is not None:
            thin_runs.append(thin)
    log("explicit euler growth")
    g = explicit_euler_growth()
    rows.append(
        Row(
            "explicit_euler, unstable spin: energy growth E_last / E0 before the error",
            g.growth,
            EXPLICIT_EULER_GROWTH,
            ">=",
        )
    )
    rows.append(
        Row("explicit_euler: smallest E[k+1] / E[k] (never decreases)", g.min_step_ratio, 1.0, ">=")
    )
    rows.append(
        Row(
            "explicit_euler: ends in NumericalInstabilityError, last state finite",
            "yes" if g.error and g.last_state_finite else "no",
            "yes",
            "==",
        )
    )
    log("separatrix")
    sep = separatrix("rk4", 1.0 / 60.0)
    rows.append(
        Row(
            "Separatrix (10, 20, 26), rk4 60 Hz, 10 s: max |w - w_exact| [rad/s]",
            sep.max_w_error,
            SEPARATRIX_W_TOL,
        )
    )
    lag = orientation_lag()
    rows.append(
        Row(
            "Orientation 50 rad/s at 60 Hz: exp map error after 1 s [rad]",
            lag.exp_error,
            EXP_MAP_TOL,
        )
    )
    rows.append(
        Row(
            "Orientation: linear update lag per step / ((h|w|)^3/12) - 1",
            abs(lag.lag_per_step / lag.predicted_lag - 1.0),
            LINEAR_LAG_RTOL,
        )
    )
    rows.append(
        Row(
            "Orientation: linear update error after 1 s [rad] (reported)",
            lag.linear_error,
            "-",
            "report",
        )
    )
    long_steps = int(lengths["long_steps"])
    log(f"long horizon {long_steps} steps")
    lr = long_horizon(long_steps)
    rows.append(
        Row(
            f"Long horizon splitting, {long_steps} steps: max | |q| - 1 |",
            lr.max_unit_q_error,
            UNIT_Q_TOL,
        )
    )
    rows.append(
        Row(
            "Long horizon splitting: energy error last 10 % / first 10 %",
            lr.drift_ratio,
            SECULAR_DRIFT_FACTOR,
        )
    )
    scale_steps = int(lengths["scale_steps"])
    worst = 0.0
    for name in INTEGRATORS:
        log(f"scale invariance {name}")
        worst = max(worst, scale_invariance(name, scale_steps).worst)
    rows.append(
        Row(
            f"Scale invariance, mass x1e+-6, length x1e+-3, all integrators, "
            f"{scale_steps} steps: relative difference",
            worst,
            SCALE_RTOL,
        )
    )
    return rows


def thin_rows(run: ThinRun) -> list[Row]:
    """The needles' and plates' rows of one integrator: the worst ``|w - w_exact|`` over the
    ratios against twice that at ratio 1e-2 (:data:`THIN_GROWTH`), and for the methods exact on
    a symmetric body the needles' error against round-off."""
    ratios = f"{THIN_RATIOS[0]:.0e} .. 1e-12 and 1e-100"
    rows = []
    for kind in THIN_KINDS:
        rows.append(
            Row(
                f"{kind.capitalize()}s {ratios}, {run.integrator}: worst max |w - w_exact| "
                "[rad/s] (bound: 2 x ratio 1e-2's + round-off)",
                float(np.max(run.errors(kind))),
                run.growth_bound(kind),
            )
        )
    if run.integrator in EXACT_ON_SYMMETRIC:
        rows.append(
            Row(
                f"Needles, {run.integrator}: exact for a symmetric body, max |w - w_exact| [rad/s]",
                float(np.max(run.errors("needle"))),
                run.roundoff,
            )
        )
    return rows


def thin_table(runs: Sequence[ThinRun], steps: int) -> Section:
    """Every integrator's ``max |w - w_exact|`` [rad/s] on the needle / plate of each ratio."""
    shown = (1.0e-2, 1.0e-4, 1.0e-6, 1.0e-8, 1.0e-10, 1.0e-12, 1.0e-100)
    rows, drift = [], []
    for run in runs:
        cells, needle = [run.integrator], [run.integrator]
        for r in shown:
            k = THIN_RATIOS.index(r)
            cells.append(f"{_fmt(run.errors('needle')[k])} / {_fmt(run.errors('plate')[k])}")
            b = run.bodies.index(("needle", r))
            needle.append(f"{_fmt(run.wx_drift[b])} / {_fmt(run.speed_drift[b])}")
        rows.append(cells)
        drift.append(needle)
    head = ["integrator", *(f"{r:.0e}" for r in shown)]
    return Section(
        "Needles and plates",
        [
            f"Torque-free needles (r, 1, 1) / plates (r, 1, 1 + r), w0 = (0.3, 2, 0.1) body, "
            f"dt 0.01, {steps} steps: largest |w - w_exact| [rad/s] (body frame; exact: "
            "Jacobi elliptic functions) for each ratio r; then the needles' largest "
            "|w_x - w_x0| / | |w| - |w0| | [rad/s], both 0 for the exact motion."
        ],
        [Table(head, rows, "l" * len(head)), Table(head, drift, "l" * len(head))],
    )


def separatrix_report(
    rates: Sequence[float] = SEPARATRIX_RATES, log: Callable[[str], None] = print
) -> list[SeparatrixResult]:
    """:func:`separatrix` for every integrator at every rate of ``rates``."""
    out = []
    for name in INTEGRATORS:
        log(f"separatrix report {name}")
        for rate in rates:
            out.append(separatrix(name, 1.0 / rate))
    return out


def tables(
    rows: Sequence[Row], separatrix_results: Sequence[SeparatrixResult], quick: bool
) -> list[Section]:
    """The two sections: the cases against their bounds, and the separatrix crossings."""
    cases = []
    for r in rows:
        mark = "-" if r.relation == "report" else ("yes" if r.passed else "**NO**")
        bound = r.bound if r.relation in ("report", "finite") else f"{r.relation} {_fmt(r.bound)}"
        cases.append([r.case, _fmt(r.figure), str(bound), mark])
    rates = sorted({round(1.0 / r.dt) for r in separatrix_results})
    crossings = []
    for name in dict.fromkeys(r.integrator for r in separatrix_results):
        cells = [name]
        for rate in rates:
            r = next(
                x for x in separatrix_results if x.integrator == name and round(1.0 / x.dt) == rate
            )
            if r.error is not None:
                cells.append(f"error at step {r.steps + 1}")
                continue
            cell = _fmt(r.max_rel_energy_error)
            cell += " **crosses**" if r.crosses else ""
            cell += " + side flipped" if r.invariant_flipped else ""
            cells.append(cell)
        crossings.append(cells)
    margin = separatrix_results[0].margin
    hz = [f"{r:g} Hz" for r in rates]
    return [
        Section(
            f"Stability ({'quick' if quick else 'full'} lengths)",
            tables=[Table(["case", "figure reached", "bound", "pass"], cases, "llll")],
        ),
        Section(
            "Separatrix crossings",
            [
                f"Separatrix margin (M^2 - 2 E I2) / M^2 = {margin:.3g}; each cell: largest "
                "relative energy error over 10 s; **crosses** where it exceeds the margin "
                "(+ side flipped: the sign of M^2 - 2 E I2 changed)."
            ],
            [Table(["integrator", *hz], crossings, "l" * len(["integrator", *hz]))],
        ),
    ]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``rigid-env bench stability``."""
    parser.add_argument(
        "--quick",
        action="store_true",
        help="run the test-suite's shorter lengths instead of the full ones",
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=None,
        metavar="DIR",
        help="also write stability.md and stability.csv into this folder",
    )
    parser.add_argument("--force", action="store_true", help="overwrite earlier results in --out")


def run(args: argparse.Namespace) -> int:
    """Run the cases and print the tables (and write them to ``--out``); exit status 1 if a
    bound is missed."""
    out = None if args.out is None else report.prepare_out(args.out, OUTPUTS, args.force)
    start = time.perf_counter()

    def log(msg: str) -> None:
        print(f"[{time.perf_counter() - start:7.1f} s] {msg}", file=sys.stderr, flush=True)

    lengths = CI_LENGTHS if args.quick else FULL_LENGTHS
    thin: list[ThinRun] = []
    rows = stability_rows(lengths, log, thin)
    sections = tables(rows, separatrix_report(log=log), args.quick)
    sections.append(thin_table(thin, int(lengths["thin_ratio_steps"])))
    text = report.markdown(
        "Stability benchmark", [f"Machine: {report.machine()}, {report.versions()}."], sections
    )
    print(text)
    if out is not None:
        (out / "stability.md").write_text(text, encoding="utf-8")
        report.write_csv(
            out / "stability.csv", rows, ["case", "figure", "bound", "relation", "passed"]
        )
        log(f"wrote {out / 'stability.md'}, {out / 'stability.csv'}")
    log("done")
    return 0 if all(r.passed for r in rows if r.relation != "report") else 1


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m rigid_env.bench.stability``: the same as ``rigid-env bench stability``."""
    from rigid_env.cli import main as cli_main

    return cli_main(["bench", "stability", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    raise SystemExit(main())
