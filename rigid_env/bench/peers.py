"""Peers: the same models evaluated here and in Basilisk (``bsk``), side by side in one run.

    rigid-env bench peers [--out DIR] [--force] [--cases N]

needs the ``[peers]`` extra (``pip install -e '.[peers]'``: Basilisk 2.12, offline). For each
quantity it draws ``--cases`` random states (seeded), evaluates the quantity with this package's
public functions and with Basilisk's module of the same model, and reports the largest
difference relative to the quantity's size, and its cause: rounding where the two compute the same
model with the same constants, else the constant or the model that differs, with the difference
left once that constant is matched. It prints, and with ``--out`` writes as ``peers.md`` and
``peers.csv``, the agreement table, and (``peers_speed.csv``) a speed table of the wheel run:
control steps per second here at N = 1, 64, 1024, 4096 (the world, and WheelPointing-v2 as an
env) against Basilisk's one spacecraft, timed in turn (:mod:`rigid_env.bench.timing`).

Covered: the body rate and wheel speeds of WheelPointing's CubeSat under a wheel-torque
profile (``World.step``, Basilisk's ``reactionWheelStateEffector``); the field of the tasks' centred
dipole and of IGRF-14 (degree 1, and degree 13 as a model difference) against
``magneticFieldCenteredDipole``; the coils' torque (``World.accelerations``, ``MtbEffector``),
in the dipole at drawn points and through a world on its orbit in IGRF-14's degree 1 where the
body is (Basilisk's centred dipole there, the Earth turned alike); the body rate of a tumbling
CubeSat with its coils under a command profile over one orbit, both sides propagating the orbit
and the attitude (Basilisk's hub on a point-mass Earth, ``magneticFieldCenteredDipole`` and
``MtbEffector``), once as Basilisk samples the field and once sampled as ours is;
the gravity-gradient torque
on the same CubeSat (``World.accelerations``, ``GravityGradientEffector``), at drawn states and
over one orbit propagated on both sides; the torques of solar
radiation pressure and of drag on flat plates through a world listing the effect on its orbit
(``World.accelerations`` where the body is: the Sun's place, the Earth's shadow and the air
from the world's orbit and clock, handed to ``facetSRPDynamicEffector`` and
``facetDragDynamicEffector`` as their messages), sunlit, in the penumbra and in the umbra; and
both on the plates over one orbit propagated on both sides, as Basilisk samples its inputs
and sampled as ours are.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rigid_env.bench import report
from rigid_env.bench.report import Section, Table

OUTPUTS = ("peers.md", "peers.csv", "peers_speed.csv")


def markdown(rows: Sequence[Any], speeds: Sequence[Any]) -> str:
    """The agreement and speed tables as a report."""
    table = Table(
        ["quantity", "cases", "largest difference", "with the constant or model matched", "cause"],
        [
            [r.quantity, str(r.cases), f"{r.difference:.2g}", f"{r.matched:.2g}", r.cause]
            for r in rows
        ],
        align="lrrrl",
        caption=(
            "Differences are the largest over the cases (for a run: over its control steps) of "
            "max |ours - Basilisk's| over the components, relative to the largest component of "
            "either side."
        ),
    )
    speed = Table(
        ["peer", "bodies", "control steps/s", "x Basilisk"],
        [
            [s.peer, str(s.bodies), report.si(s.steps_per_second), report.times(s.ratio)]
            for s in speeds
        ],
        caption=(
            "The wheel run's scenario, each control step 20 rk4 substeps of 0.05 s: ours is "
            "`World.step` of N bodies, Basilisk's one spacecraft a message written and "
            "`ExecuteSimulation` to the next second (as an RL environment on Basilisk steps). "
            "The env rows are env-steps of WheelPointing-v2 (`gym.make`, and `gym.make_vec` "
            "at N), the same CubeSat in the full environment: its coils, IGRF-14 to degree 13 "
            "on each substep, the J2 orbit, eclipse, SRP, drag, sensors, observation and reward, "
            "far more than Basilisk's spacecraft here computes. Wall time, medians of 5 rounds "
            "taken in turn; on a shared machine the ratios hold better than the rates."
        ),
    )
    header = [
        f"- machine: {report.machine()}",
        f"- versions: {report.versions('rigid_env', 'bsk', 'numba')}",
        "- command: `rigid-env bench peers`",
    ]
    not_compared = (
        "Not compared: Basilisk's WMM (its coefficient file comes from its support-data "
        "fetcher on first use, offline here). The sunlight and the air are compared at the "
        "world's own place on its orbit: Basilisk is handed the Sun, the shadow factor, the "
        "density and the air's velocity that the world's step reads there. In the runs on an "
        "orbit both sides propagate: Basilisk integrates the orbit (rk4 on a point-mass Earth "
        "given our mu) where ours steps Kepler's, and each its own attitude; the coils' field "
        "is Basilisk's centred-dipole module's, fed the Earth's turn and the spacecraft's place."
    )
    return report.markdown(
        "Agreement with Basilisk",
        header,
        [
            Section("Same models, same states", tables=[table], after=[not_compared]),
            Section("Speed", tables=[speed]),
        ],
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The command's flags."""
    parser.add_argument("--out", type=Path, help="folder for peers.md and peers.csv")
    parser.add_argument("--force", action="store_true", help="overwrite earlier results")
    parser.add_argument(
        "--cases", type=int, default=20, help="random states per quantity (default 20)"
    )


def run(args: argparse.Namespace) -> int:
    """Run the comparisons, print the table and write it under ``--out``; 0 on success."""
    if args.cases < 1:
        raise ValueError(f"--cases must be at least 1, got {args.cases}")
    try:
        from rigid_env.bench.peers_cases import agreements, speeds
    except ModuleNotFoundError as exc:
        raise ValueError(
            f"bench peers: needs the package {exc.name!r} (Basilisk); install it with: "
            "pip install -e '.[peers]'"
        ) from None
    out = report.prepare_out(args.out, OUTPUTS, args.force) if args.out is not None else None
    rows = agreements(args.cases)
    timed = speeds()
    text = markdown(rows, timed)
    print(text, end="")
    if out is not None:
        (out / "peers.md").write_text(text, encoding="utf-8")
        report.write_csv(out / "peers.csv", rows)
        report.write_csv(out / "peers_speed.csv", timed)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m rigid_env.bench.peers``: the same as ``rigid-env bench peers``."""
    from rigid_env.cli import main as cli_main

    return cli_main(["bench", "peers", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    sys.exit(main())
