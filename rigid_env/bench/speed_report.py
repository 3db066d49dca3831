"""What the speed benchmark's tables and panels show, one function per section.

Each takes the measured rows (:class:`rigid_env.bench.speed.Results`) and returns the
section's Markdown (:class:`~rigid_env.bench.report.Section`) and its figure panel
(:class:`~rigid_env.bench.report.Panel`); :mod:`rigid_env.bench.report` writes them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from rigid_env.bench import report
from rigid_env.bench.report import Panel, Section, Series, Table, si, times
from rigid_env.bench.speed_rows import (
    CARTPOLE_CASE,
    CSV_COLUMNS,
    ENV_REFERENCE,
    MJ_INTEGRATORS,
    NO_EFFECTS,
    PPO_ADAPTER,
    PPO_DUMMY,
    PPO_SUBPROC,
    RANDOMISED,
    RESET,
    SECTIONS,
    SYNC_CASE,
    WORLD_STEPS,
    Results,
    Row,
    short_id,
)


def _curves(rows: Sequence[Row], names: Sequence[str], styles: dict[str, Any]) -> list[Series]:
    """One :class:`Series` per case name (value against n, measured rows only), styled by
    ``styles`` or else by the colour cycle."""
    out = []
    for k, name in enumerate(names):
        pts = sorted((r.n, r.value) for r in rows if r.case == name and not r.note)
        if pts:
            style = styles.get(name, {"color": f"C{k % 10}"})
            out.append(Series(name, [p[0] for p in pts], [p[1] for p in pts], **style))
    return out


def core(res: Results) -> tuple[Section, Panel]:
    """Body-steps/s per integrator and N with the ratio to MuJoCo; same-kind pairs; N = 1
    beside ``mj_step``; the log-log panel."""
    rows = res.section("core")
    sizes = sorted({r.n for r in rows})
    names = list(dict.fromkeys(r.case for r in rows))

    def cell(name: str, n: int) -> str:
        r = res.get("core", name, n)
        return "" if r is None else f"{si(r.value)} ({times(r.ratio)})"

    pairs = []
    for n in sizes:
        cells = [str(n)]
        for mj, ours in MJ_INTEGRATORS.items():
            a, b = res.get("core", ours, n), res.get("core", f"MuJoCo {mj} rollout", n)
            cells += [si(a.value) if a else "-", si(b.value) if b else "-"]
            cells.append(times(a.value / b.value) if a and b else "-")
        pairs.append(cells)
    loops = []
    for mj, ours in MJ_INTEGRATORS.items():
        a, b = res.get("core", ours, 1), res.get("core", f"MuJoCo {mj} mj_step loop", 1)
        if a and b:
            us_a, us_b = f"{a.median_s * 1e6:.3g}", f"{b.median_s * 1e6:.3g}"
            loops.append([ours, us_a, f"MuJoCo {mj}", us_b, times(a.value / b.value)])
    pair_header = ["N"]
    for mj, ours in MJ_INTEGRATORS.items():
        pair_header += [ours, f"MuJoCo {mj} rollout", "ratio"]
    tables = [
        Table(
            ["integrator / engine", *[f"N={n}" for n in sizes]],
            [[name, *(cell(name, n) for n in sizes)] for name in names],
            caption="Body-steps per second (ratio to the MuJoCo `rollout` peer at the same N):",
        ),
        Table(pair_header, pairs, caption="Same-kind pairs (ours over MuJoCo, body-steps/s):"),
    ]
    if loops:
        header = ["ours", "us/step", "peer", "us/step", "ours/peer (steps/s)"]
        caption = "N = 1 beside `mj_step` in a Python loop:"
        tables.append(Table(header, loops, "lrlrr", caption=caption))
    section = Section(
        "1. Core: `World.step` throughput against batch size", res.notes["core"], tables
    )
    styles = {
        "MuJoCo Euler rollout": {"style": "s--", "color": "black", "width": 1.5},
        "MuJoCo RK4 rollout": {"style": "D:", "color": "black", "width": 1.5},
        "MuJoCo Euler mj_step loop": {"style": "x", "color": "black", "size": 8},
        "MuJoCo RK4 mj_step loop": {"style": "+", "color": "black", "size": 8},
    }
    ours = [n for n in names if not n.startswith("MuJoCo")]
    panel = Panel(
        "lines",
        "(1) core: World.step vs MuJoCo",
        "bodies N",
        "body-steps / s",
        _curves(rows, ours, {}) + _curves(rows, list(styles), styles),
        ticks=sizes,
        legend="lower right",
    )
    return section, panel


def env(res: Results) -> tuple[Section, Panel]:
    """Microseconds per ``env.step`` and the ratio to InvertedPendulum-v5; a bar panel."""
    rows = res.section("env")
    table = [
        [
            f"`{r.case}`",
            f"{r.value:.1f}" if math.isfinite(r.value) else "n/a",
            si(1e6 / r.value) if math.isfinite(r.value) else "-",
            times(r.ratio),
        ]
        for r in rows
    ]
    header = ["env", "us/step", "steps/s", f"time / {ENV_REFERENCE}"]
    section = Section(
        "2. Single environment: `env.step` through `gym.make`",
        res.notes["env"],
        [Table(header, table)],
    )
    shown = [r for r in rows if math.isfinite(r.value)]
    bars = Series(
        "",
        [],
        [r.value for r in shown],
        color=["tab:blue" if r.case.startswith("RigidEnv/") else "0.55" for r in shown],
        notes=[f"{r.value:.0f} us ({times(r.ratio)})" for r in shown],
    )
    panel = Panel(
        "barh",
        f"(2) single env via gym.make (x = time / {ENV_REFERENCE})",
        "us per env.step (lower is faster)",
        series=[bars],
        categories=[short_id(r.case) for r in shown],
    )
    return section, panel


def vec(res: Results) -> tuple[Section, Panel]:
    """Env-steps/s per vector env and N, over CartPole's and SyncVectorEnv's; log-log."""
    rows = res.section("vec")
    table = []
    for r in rows:
        sync = res.get("vec", SYNC_CASE, r.n)
        vs_sync = r.value / sync.value if sync is not None and r.case != SYNC_CASE else math.nan
        label = r.case + (" *extrapolated*" if r.note.startswith("extrapolated") else "")
        table.append(
            [str(r.n), label, si(r.value), f"{1e6 / r.value:.3g}", times(r.ratio), times(vs_sync)]
        )
    header = ["N", "env", "env-steps/s", "us/env-step", f"x {CARTPOLE_CASE}", "x Detumble Sync"]
    section = Section(
        "3. Vector environment: env-steps per second",
        res.notes["vec"],
        [Table(header, table, "rlrrrr")],
    )
    names = list(dict.fromkeys(r.case for r in rows))
    styles = {
        CARTPOLE_CASE: {"style": "s--", "color": "black"},
        SYNC_CASE: {"style": "o-", "color": "0.5"},
    }
    curves = _curves(rows, [n for n in names if n not in styles], {})
    curves += _curves(rows, list(styles), styles)
    extra = [r for r in rows if r.note]
    measured = [r for r in rows if r.case == SYNC_CASE and not r.note]
    if extra and measured:  # dotted on from the last measured point
        label = f"{SYNC_CASE} (extrapolated)"
        xs = [measured[-1].n] + [r.n for r in extra]
        ys = [measured[-1].value] + [r.value for r in extra]
        curves.append(Series(label, xs, ys, style="o:", color="0.5", hollow=True))
    panel = Panel(
        "lines",
        "(3) vector envs: native, CartPole's, SyncVectorEnv",
        "num_envs N",
        "env-steps / s",
        curves,
        ticks=sorted({r.n for r in rows}),
        legend="upper left",
    )
    return section, panel


def effects(res: Results) -> tuple[Section, Panel]:
    """Step time with each set of effects, over the no-effects world's; grouped bars."""
    rows = res.section("effects")
    sizes = sorted({r.n for r in rows})
    names = list(dict.fromkeys(r.case for r in rows))
    header = ["effects"] + [f"N={n} {c}" for n in sizes for c in ("us/step", "/ none", "extra us")]
    table = []
    ratios: dict[int, list[float]] = {n: [] for n in sizes}
    for name in names:
        cells = [name]
        for n in sizes:
            r, base = res.get("effects", name, n), res.get("effects", NO_EFFECTS, n)
            assert r is not None and base is not None  # every variant runs at every size
            cells += [f"{r.value:.4g}", times(r.ratio), f"{r.value - base.value:+.3g}"]
            ratios[n].append(r.ratio)
        table.append(cells)
    section = Section(
        "4. Effects: only what the scene calls for", res.notes["effects"], [Table(header, table)]
    )
    panel = Panel(
        "barh",
        f"(4) effects ({res.config.effect_integrator}): pay only for what is listed",
        "step time / no-effects step time",
        series=[Series(f"N={n}", [], ratios[n], color=f"C{j + 2}") for j, n in enumerate(sizes)],
        categories=names,
        guides=[1.0],
        legend="center right",
    )
    return section, panel


def ppo(res: Results) -> tuple[Section, Panel]:
    """PPO's env-steps/s per VecEnv and n_envs, over DummyVecEnv's; bars."""
    rows = res.section("ppo")
    steps = res.config.ppo_timesteps
    table = [
        [f"`{r.case}`", str(r.n), si(r.value), f"{steps / r.value:.2f}", times(r.ratio)]
        for r in rows
    ]
    header = ["VecEnv", "n_envs", "env-steps/s", f"s per learn({steps})", f"x {PPO_DUMMY}"]
    section = Section(
        "5. Training: PPO environment steps per second", res.notes["ppo"], [Table(header, table)]
    )
    short = {PPO_ADAPTER: "adapter", PPO_DUMMY: "Dummy", PPO_SUBPROC: "Subproc"}
    bars = Series(
        "",
        [],
        [r.value for r in rows],
        color=["tab:blue" if r.case == PPO_ADAPTER else "0.55" for r in rows],
        notes=[f"{r.value:.0f}\n({times(r.ratio)})" for r in rows],
    )
    panel = Panel(
        "bar",
        f"(5) PPO on Detumble (x = vs {PPO_DUMMY}, same n_envs)",
        ylabel="env-steps / s",
        series=[bars],
        categories=[f"{short.get(r.case, r.case)}\n{r.n} envs" for r in rows],
    )
    return section, panel


def random(res: Results) -> tuple[Section, Panel]:
    """Each env's steps and resets with its shipped draws beside its nominal ones, per env step
    and per world step, against the bar; bars of the step ratios."""
    from rigid_env.bench.speed import RESET_BAR, STEP_BAR

    rows = res.section("random")
    names = [r.case for r in rows if not r.case.endswith((RANDOMISED, RESET, WORLD_STEPS))]
    table, shown = [], []
    for name in names:
        n = next(r.n for r in rows if r.case == name)
        step, rand = res.get("random", name, n), res.get("random", name + RANDOMISED, n)
        reset = res.get("random", name + RESET, n)
        rand_reset = res.get("random", name + RANDOMISED + RESET, n)
        world = res.get("random", name + RANDOMISED + WORLD_STEPS, n)
        assert step and rand and reset and rand_reset and world  # measured together
        per_world_step = rand.ratio * world.ratio
        bar = rand.ratio >= STEP_BAR and rand_reset.ratio <= RESET_BAR
        table.append(
            [f"`{name}`", rand.note, str(n), si(step.value), si(rand.value), times(rand.ratio),
             f"{world.value:.3g}", times(per_world_step), f"{reset.value:.3g}",
             f"{rand_reset.value:.3g}", times(rand_reset.ratio), "yes" if bar else "**no**"]
        )  # fmt: skip
        shown.append((name, rand, rand_reset))
    header = [
        "env", "draws", "N", "nominal env-steps/s", "randomised env-steps/s", "x nominal",
        "world steps / env step", "x nominal per world step", "nominal us/reset env",
        "randomised us/reset env", "x nominal", "bar",
    ]  # fmt: skip
    section = Section(
        "6. Randomisation and sensors: the vector env's steps and resets",
        res.notes["random"],
        [Table(header, table, "llrrrrrrrrrl")],
    )
    bars = Series(
        "",
        [],
        [r.ratio for _, r, _ in shown],
        color="tab:blue",
        notes=[f"{times(r.ratio)}; reset {times(z.ratio)}" for _, r, z in shown],
    )
    panel = Panel(
        "barh",
        "(6) shipped randomisation and sensors (x = env-steps/s over the nominal env's)",
        "env-steps/s, randomised / nominal (higher is faster)",
        series=[bars],
        categories=[name for name, _, _ in shown],
    )
    return section, panel


LAYOUTS: dict[str, Callable[[Results], tuple[Section, Panel]]] = {
    "core": core,
    "env": env,
    "vec": vec,
    "effects": effects,
    "ppo": ppo,
    "random": random,
}
"""Section name -> its tables and panel."""


def write(
    res: Results,
    out: Path,
    sections: Sequence[str],
    *,
    command: str,
    date: str,
    load_start: str,
    wall: float,
) -> None:
    """``speed.md`` (the run's header, then a section per measurement), ``speed.csv`` (every
    row) and ``speed.png`` (a panel per measurement) in ``out``."""
    cfg = res.config
    clock = "`time.perf_counter`" if cfg.clock == "wall" else "process CPU time (`--clock cpu`)"
    header = [
        f"- Date: {date}",
        f"- Machine: {report.machine()}; load average {load_start} at the start, "
        f"{report.load()} at the end",
        f"- Versions: {report.versions('mujoco', 'gymnasium', 'stable-baselines3', 'torch')}",
        f"- Run: `{command}` ({cfg.name}: {', '.join(sections)}), {wall:.0f} s",
        f"- Method: {clock}, warm-up, then {cfg.repeats} repeats of >= {cfg.min_time:g} s per "
        f"case (PPO: {cfg.ppo_repeats}), the peers of a table interleaved round by round; "
        "medians; ratios only between peers of the same run. `speed.csv` also has the fastest "
        "and slowest repeat of every case and the median CPU time of the process.",
    ]
    shown = {name: LAYOUTS[name](res) for name in sections}
    text = report.markdown("Speed benchmark", header, [shown[n][0] for n in sections])
    (out / "speed.md").write_text(text, encoding="utf-8")
    report.write_csv(out / "speed.csv", res.rows, CSV_COLUMNS)
    report.write_figure(
        out / "speed.png",
        [shown[name][1] if name in shown else None for name in SECTIONS],
        f"rigid_env speed ({cfg.name}, {cfg.clock} clock) - {report.machine()} - {date}",
        panel_size=(5.7, 5.0),
    )
