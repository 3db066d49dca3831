"""Time to the bar: how long the shipped PPO configs take to train each task, beside the
previous configs and the rsl-rl learner's, in the same run; and the three rates of each learner.

    rigid-env bench learn [--tasks detumble ...] [--seeds 0 1 2] [--jobs 2]
                          [--previous-limit 240] [--previous-seeds 0 ...] [--rsl-seeds 0 ...]
                          [--sbx-seeds 0 ...] [--sbx-config PATH] [--out DIR] [--force]
    rigid-env bench learn --rates-only [--tasks ...] [--learners sb3 rsl_rl skrl sbx]
                          [--sbx-config PATH] [--repeats 3] [--threads 1] [--sb3-threads N]
                          [--out DIR] [--force]

For each task and seed, ``--jobs`` runs at a time (one thread each, so two on two cores), a
run trains from nothing with ``configs/agents/ppo_<task>.yaml`` (the shipped config, its whole
budget) and, as the peers, with ``configs/agents/previous/ppo_<task>.yaml`` (the configs before
issue 24) and, where the task has one, ``configs/agents/rsl_ppo_<task>.yaml`` (rsl-rl's PPO over
thousands of envs, :mod:`rigid_env.agents.parallel`) and, with ``--sbx-seeds``, sbx-rl's PPO
on that config (:mod:`rigid_env.bench.learn_sbx`), shortened: each stops at its first
evaluation that meets the bar, or after ``--previous-limit`` seconds of CPU time. All evaluate
every ``eval.freq`` steps on the same
100 held-out episodes (:mod:`rigid_env.agents.bar`: at least 95 % success and at most 1.5x
the PD controller's fuel), so *time to bar* is the wall-clock (and process CPU time) and the
env-steps from the start of training to that evaluation. Each final model is then evaluated on
100 further episodes (seeds 12345 + k, which no training or training-time evaluation used).
env-steps/s is over the whole run, evaluations included; training env-steps/s leaves out the
wall-clock of the periodic evaluations (the configs evaluate at different rates).

Writes ``results.md`` (tables), ``results.csv`` (one row per run) and ``time_to_bar.png``
(success of each evaluation against training wall-clock, one curve per run) to ``--out``
(default ``runs/bench_learn``), and the runs themselves under ``--out``/runs. ``--rates-only``
writes ``rates.md`` and ``rates.csv`` instead (:mod:`rigid_env.bench.learn_rates`).
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing as mp
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rigid_env.agents.shipped import TASKS as SHIPPED
from rigid_env.bench import report
from rigid_env.bench.learn_rates import CONFIG_STEMS, LEARNERS, config_file
from rigid_env.resources import data_path, find_data

TASKS = tuple(task.module for task in SHIPPED.values())
"""The tasks trained, by the stem of their configs (``configs/agents/ppo_<module>.yaml``): those
that ship a policy (:data:`rigid_env.agents.shipped.TASKS`), in the registry's order."""
OUTPUTS = ("results.md", "results.csv", "time_to_bar.png")
FINAL_SEED = 12_345
FINAL_EPISODES = 100


@dataclass(frozen=True)
class LearnRow:
    """One training run's time to bar and final result."""

    task: str
    config: str  # "shipped" | "previous" | "rsl_rl" | "sbx"
    seed: int
    steps: int  # env-steps trained
    seconds: float  # training wall-clock
    cpu_seconds: float  # process CPU time of the training
    steps_per_s: float
    train_steps_per_s: float  # env-steps per wall-clock second outside the periodic evaluations
    bar_steps: float  # env-steps at the first evaluation at the bar (nan: never)
    bar_seconds: float
    bar_cpu_seconds: float
    success: float  # final model, 100 unseen episodes
    fuel_ratio: float  # its mean fuel / PD's on the same episodes
    stopped: str  # "budget" | "bar" | "limit"
    history: str  # the run's eval/evaluations.npz


def _count(low: int) -> Any:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"must be >= {low}, got {value}")
        return value

    return parse


def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0 seconds, got {text}")
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The benchmark's flags."""
    parser.add_argument("--tasks", nargs="+", choices=TASKS, default=list(TASKS))
    parser.add_argument("--seeds", nargs="+", type=_count(0), default=[0, 1, 2])
    parser.add_argument("--jobs", type=_count(1), default=2, help="runs at once (one thread each)")
    parser.add_argument(
        "--previous-limit",
        type=_seconds,
        default=240.0,
        help="CPU seconds after which a previous-config run stops if it has not met the bar",
    )
    parser.add_argument(
        "--previous-seeds",
        nargs="*",
        type=_count(0),
        help="seeds of the previous configs (default: --seeds; none: the shipped configs only)",
    )
    parser.add_argument(
        "--rsl-seeds",
        nargs="*",
        type=_count(0),
        help="seeds of the rsl-rl learner's configs, configs/agents/rsl_ppo_<task>.yaml, where "
        "a task has one (default: --seeds; none: leave them out); they stop at the bar or "
        "after --previous-limit",
    )
    parser.add_argument(
        "--sbx-seeds",
        nargs="*",
        type=_count(0),
        default=[],
        help="seeds of sbx-rl's PPO (JIT-compiled update) on the rsl-rl config, or "
        "--sbx-config (default none: leave it out; pip install 'rigid_env[bench]'); they stop "
        "at the bar or after --previous-limit",
    )
    parser.add_argument(
        "--sbx-config",
        type=Path,
        help="the config sbx-rl runs (time to bar and rates; default "
        "configs/agents/rsl_ppo_<task>.yaml)",
    )
    parser.add_argument(
        "--learners",
        nargs="+",
        choices=LEARNERS,
        default=list(LEARNERS),
        help="whose three rates to measure (env; + inference; full PPO), in the same run",
    )
    parser.add_argument("--repeats", type=_count(1), default=3, help="timed stretches per rate")
    parser.add_argument("--threads", type=_count(1), default=1, help="threads of the rates")
    parser.add_argument(
        "--sb3-threads",
        type=_count(1),
        help="threads of the SB3 path's rates (default: --threads; the guide's allotment is "
        "--sb3-threads 1 --threads 2: one per SB3 run, two runs at once, while a parallel "
        "learner may take both cores)",
    )
    parser.add_argument(
        "--n-envs",
        type=_count(1),
        help="envs of rsl_rl, skrl and sbx in the rates (default: the rsl_rl config's; the "
        "minibatch scales with it)",
    )
    parser.add_argument(
        "--rates-only",
        action="store_true",
        help="measure the three rates of each learner (rates.md) and train nothing",
    )
    parser.add_argument("--out", type=Path, default=Path("runs/bench_learn"))
    parser.add_argument("--force", action="store_true", help="overwrite earlier results in --out")


KINDS = tuple(CONFIG_STEMS)
"""The configs a task trains with: its shipped SB3 config, the SB3 config before issue 24, and
the rsl-rl learner's (``configs/agents/rsl_ppo_<task>.yaml``, where the task has one)."""


def config_path(task: str, previous: bool | str) -> Path:
    """The shipped (``False``, ``"shipped"``), previous (``True``, ``"previous"``) or rsl-rl
    (``"rsl_rl"``) PPO config of ``task``; FileNotFoundError (one line) where it has none."""
    return data_path(config_file(task, _kind(previous)))


def has_config(task: str, previous: bool | str) -> bool:
    """Whether ``task`` has that config (every task has a shipped and a previous one; the
    rsl-rl learner's only some)."""
    return find_data(config_file(task, _kind(previous))) is not None


def train_one(
    task: str,
    seed: int,
    previous: bool | str,
    runs_dir: Path,
    limit_s: float,
    config: Path | None = None,
) -> dict[str, Any]:
    """Train one run (in a worker process) and evaluate its final model; a row's fields.
    ``config`` replaces the task's config (for searches)."""
    from stable_baselines3.common.callbacks import BaseCallback

    from rigid_env.agents.callbacks import DurableEvaluation
    from rigid_env.agents.config import load_config
    from rigid_env.agents.evaluate import evaluate
    from rigid_env.agents.train import train

    cfg = load_config(config or config_path(task, previous), {"seed": seed})
    stopped = ["budget"]

    class StopAtBar(BaseCallback):
        """The shortened peer: stops at the bar or after ``limit_s`` seconds of CPU time (the
        process's: on a shared machine wall-clock says more about the neighbours)."""

        def _on_training_start(self) -> None:
            self.t0 = time.process_time()
            self.evaluation = next(
                c for c in self.locals["callback"].callbacks if isinstance(c, DurableEvaluation)
            )

        def _on_step(self) -> bool:
            if self.evaluation.first_met is not None:
                stopped[0] = "bar"
                return False
            if time.process_time() - self.t0 > limit_s:
                stopped[0] = "limit"
                return False
            return True

    class EvaluationTimer(BaseCallback):
        """Adds up the wall-clock the run's periodic evaluations take (the configs evaluate at
        different rates: that is not the training path's speed)."""

        def _on_training_start(self) -> None:
            evaluation = next(
                c for c in self.locals["callback"].callbacks if isinstance(c, DurableEvaluation)
            )
            evaluation.evaluation = _Timed(evaluation.evaluation, spent)

        def _on_step(self) -> bool:
            return True

    spent = [0.0]
    t0, c0 = time.perf_counter(), time.process_time()
    if cfg.learner == "rsl_rl":

        def at_bar(evaluation: DurableEvaluation, evaluating_s: float) -> bool:
            spent[0] = evaluating_s
            if evaluation.first_met is not None:
                stopped[0] = "bar"
            elif time.process_time() - c0 > limit_s:
                stopped[0] = "limit"
            return stopped[0] != "budget"

        run_dir = train(cfg, runs_dir, progress=False, stop=at_bar)
    else:
        stop = [StopAtBar()] if _kind(previous) == "previous" or math.isfinite(limit_s) else []
        run_dir = train(cfg, runs_dir, progress=False, callbacks=[EvaluationTimer(), *stop])
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    side = json.loads((run_dir / "model.json").read_text())
    with np.load(run_dir / "eval" / "evaluations.npz") as h:
        hist = {k: h[k] for k in h.files}
    bar = _first_at_bar(hist)
    res = evaluate(
        run_dir / "model.zip", cfg.env_id, FINAL_EPISODES, FINAL_SEED, only=["model", "pd"]
    )
    steps = int(side["num_timesteps"])
    return asdict(
        LearnRow(
            task=task,
            config=_kind(previous),
            seed=seed,
            steps=steps,
            seconds=seconds,
            cpu_seconds=cpu,
            steps_per_s=steps / seconds,
            train_steps_per_s=steps / (seconds - spent[0]),
            bar_steps=bar[0],
            bar_seconds=bar[1],
            bar_cpu_seconds=bar[2],
            success=res["model"]["success_rate"],
            fuel_ratio=res["model"]["mean_fuel"] / res["pd"]["mean_fuel"],
            stopped=stopped[0],
            history=str(run_dir / "eval" / "evaluations.npz"),
        )
    )


def _kind(previous: bool | str) -> str:
    return {True: "previous", False: "shipped"}.get(previous, previous)  # type: ignore[arg-type]


class _Timed:
    """A run's evaluation (a callable with attributes) whose calls add their wall-clock to
    ``spent[0]``."""

    def __init__(self, evaluation: Any, spent: list[float]) -> None:
        self._evaluation, self._spent = evaluation, spent

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        t = time.perf_counter()
        try:
            return self._evaluation(*args, **kwargs)
        finally:
            self._spent[0] += time.perf_counter() - t

    def __getattr__(self, name: str) -> Any:
        return getattr(self._evaluation, name)


def _first_at_bar(hist: dict[str, np.ndarray]) -> tuple[float, float, float]:
    """(env-steps, seconds, CPU seconds) of the first evaluation at the bar; NaNs if none."""
    from rigid_env.agents.bar import fuel_ratio, meets_bar

    for k in range(len(hist["timesteps"])):
        success = float(np.mean(hist["successes"][k]))
        ratio = fuel_ratio(float(np.mean(hist["fuel"][k])), float(hist["pd_fuel"][k]))
        if meets_bar(success, ratio):
            return (
                float(hist["timesteps"][k]),
                float(hist["seconds"][k]),
                float(hist["cpu_seconds"][k]),
            )
    return math.nan, math.nan, math.nan


MANIFEST = ".bench_learn_manifest.json"
"""In ``--out``: the run folders this benchmark wrote there (relative paths), the only ones it
ever removes."""


def _run_name(task: str, seed: int, previous: bool | str) -> str:
    from rigid_env.agents.config import load_config

    return load_config(config_path(task, previous), {"seed": seed}).run_name


def _sbx_run_name(task: str, seed: int) -> str:
    from rigid_env.agents.config import load_config

    return f"{load_config(config_path(task, 'rsl_rl'), {'seed': seed}).task}__ppo_sbx__{seed}"


def _clear_own_runs(out: Path, planned: list[Path], force: bool) -> None:
    """Make room for the ``planned`` run folders: remove (with ``force``) the ones an earlier
    run of this benchmark wrote, as its manifest in ``out`` lists them, and record the planned
    ones in the manifest before training starts. A folder it did not write is never removed.

    Raises:
        ValueError: a planned folder exists and the manifest does not list it (a user's), or
            one it wrote exists and ``force`` is not set (one line naming it and the fix).
    """
    import shutil

    manifest = out / MANIFEST
    try:
        listed = json.loads(manifest.read_text()) if manifest.is_file() else []
    except (OSError, ValueError):
        listed = []
    own = {str(p) for p in listed if isinstance(p, str)} if isinstance(listed, list) else set()
    for run in planned:
        if not run.exists() and not run.is_symlink():
            continue
        rel = str(run.relative_to(out))
        if rel not in own:
            raise ValueError(
                f"--out: {run} exists and this benchmark did not write it; move it away or "
                "choose another --out (the benchmark never removes what it did not write)"
            )
        if not force:
            raise ValueError(
                f"--out: {run} holds an earlier run of this benchmark; pass --force to replace "
                "it, or choose another --out"
            )
    for rel in sorted(own):
        run = out / rel
        if (run.is_dir() and not run.is_symlink() and run.parent.parent == out / "runs"
                and run in planned):  # fmt: skip
            shutil.rmtree(run)
    manifest.write_text(json.dumps(sorted(own | {str(p.relative_to(out)) for p in planned})))


def _worker(job: tuple[str, int, bool | str, str, float, str | None]) -> dict[str, Any]:
    task, seed, previous, runs_dir, limit_s, config = job
    if previous == "sbx":
        from rigid_env.bench.learn_sbx import train_sbx

        return train_sbx(task, seed, Path(runs_dir), limit_s, config and Path(config))
    return train_one(task, seed, previous, Path(runs_dir), limit_s)


def plan(args: argparse.Namespace) -> list[tuple[str, int, str, float]]:
    """The training runs ``(task, seed, kind, CPU-second limit)`` the arguments ask for: each
    task's shipped config for ``--seeds``, its previous one and its rsl-rl one (where it has
    one) for theirs."""
    previous_seeds = args.seeds if args.previous_seeds is None else args.previous_seeds
    rsl_seeds = args.seeds if args.rsl_seeds is None else args.rsl_seeds
    kinds = (
        ("shipped", math.inf, args.seeds),
        ("previous", args.previous_limit, previous_seeds),
        ("rsl_rl", args.previous_limit, rsl_seeds),
    )
    return [
        (task, seed, kind, lim)
        for task in args.tasks
        for kind, lim, seeds in kinds
        if kind != "rsl_rl" or has_config(task, kind)
        for seed in seeds
    ]


def run(args: argparse.Namespace) -> int:
    """Run the benchmark; 0 on success."""
    if args.rates_only:
        return run_rates(args)
    out = report.prepare_out(args.out, OUTPUTS, args.force)
    runs_dir = out / "runs"
    runs = plan(args)
    planned = [runs_dir / kind / _run_name(task, seed, kind) for task, seed, kind, _ in runs]
    sbx = [(task, seed) for task in args.tasks for seed in args.sbx_seeds
           if args.sbx_config or has_config(task, "rsl_rl")]  # fmt: skip
    if sbx:
        import importlib.util

        if importlib.util.find_spec("sbx") is None:
            raise ValueError("--sbx-seeds: sbx-rl is not installed; pip install "
                             "'rigid_env[bench]', or leave --sbx-seeds out")  # fmt: skip
        planned += [runs_dir / "sbx" / _sbx_run_name(task, seed) for task, seed in sbx]
    _clear_own_runs(out, planned, args.force)
    jobs = [(task, seed, kind, str(runs_dir / kind), lim, None) for task, seed, kind, lim in runs]
    config = str(args.sbx_config) if args.sbx_config else None
    jobs += [(task, seed, "sbx", str(runs_dir / "sbx"), args.previous_limit, config)
             for task, seed in sbx]  # fmt: skip
    t0 = time.perf_counter()
    rows: list[LearnRow] = []
    with mp.get_context("spawn").Pool(args.jobs, maxtasksperchild=1) as pool:
        for r in pool.imap_unordered(_worker, jobs):
            row = LearnRow(**r)
            rows.append(row)
            print(
                f"{row.task} {row.config} seed {row.seed}: bar at {row.bar_steps:,.0f} steps, "
                f"{row.bar_seconds:.1f} s; final success {row.success:.2f}, fuel "
                f"{row.fuel_ratio:.2f}x PD; {row.steps_per_s:,.0f} steps/s",
                flush=True,
            )
    rows.sort(key=lambda r: (TASKS.index(r.task), r.config, r.seed))
    (out / "results.md").write_text(_markdown(rows, args, time.perf_counter() - t0))
    report.write_csv(out / "results.csv", rows)
    _figure(rows, out / "time_to_bar.png")
    print(f"wrote {out / 'results.md'}, results.csv, time_to_bar.png")
    return 0


def run_rates(args: argparse.Namespace) -> int:
    """``--rates-only``: the three rates of each learner on each task (rates.md, rates.csv)."""
    from rigid_env.bench.learn_rates import markdown, measure

    out = report.prepare_out(args.out, ("rates.md", "rates.csv"), args.force)
    rows = []
    t0 = time.perf_counter()
    for task in args.tasks:
        rows += measure(task, tuple(args.learners), args.repeats, args.threads, args.n_envs,
                        sbx_config=args.sbx_config, sb3_threads=args.sb3_threads)  # fmt: skip
    threads = (f"{args.threads} thread(s)" if args.sb3_threads in (None, args.threads) else
               f"SB3 on {args.sb3_threads} thread(s), the others on {args.threads}")  # fmt: skip
    lines = [
        "# Three rates of each learner (rigid-env bench learn --rates-only)",
        "",
        f"{report.machine()}; "
        f"{report.versions('torch', 'stable-baselines3', 'rsl-rl-lib', 'skrl', 'sbx-rl', 'jax')}"
        f"; load at the end: {report.load()}. {threads}, median of "
        f"{args.repeats} interleaved stretches each; {time.perf_counter() - t0:.0f} s in all.",
        "",
        *markdown(rows),
    ]
    (out / "rates.md").write_text("\n".join(lines) + "\n")
    report.write_csv(out / "rates.csv", rows)
    print("\n".join(lines))
    return 0


def _median(values: list[float]) -> float:
    return float(np.median(values)) if values else math.nan


def _markdown(rows: list[LearnRow], args: argparse.Namespace, total_s: float) -> str:
    lines = [
        "# Time to the bar (rigid-env bench learn)",
        "",
        f"{report.machine()}; {report.versions('torch', 'stable-baselines3', 'numba')}; "
        f"load at the end: {report.load()}. {args.jobs} runs at once, one thread each; "
        f"{total_s / 60:.1f} min in all. Previous configs stop at the bar or after "
        f"{args.previous_limit:.0f} s.",
        "",
        "| task | config | seed | time to bar [s] | CPU to bar [s] | env-steps to bar | "
        "trained [s] | env-steps | env-steps/s | training env-steps/s | final success | "
        "fuel / PD | stopped |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r.task} | {r.config} | {r.seed} | {r.bar_seconds:.1f} | {r.bar_cpu_seconds:.1f}"
            f" | {r.bar_steps:,.0f} | {r.seconds:.1f} | {r.steps:,} | {r.steps_per_s:,.0f} | "
            f"{r.train_steps_per_s:,.0f} | {r.success:.2f} | {r.fuel_ratio:.2f} | {r.stopped} |"
        )
    lines += [
        "",
        "| task | shipped: median (worst) time to bar [s] | previous: median time to bar [s] | "
        "rsl_rl: median (worst) time to bar [s] | sbx: median (worst) time to bar [s] | "
        "env-steps/s shipped / previous | training env-steps/s shipped / previous | "
        "training env-steps/s rsl_rl / shipped | training env-steps/s sbx / shipped |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for task in TASKS:
        new = [r for r in rows if r.task == task and r.config == "shipped"]
        old = [r for r in rows if r.task == task and r.config == "previous"]
        rsl = [r for r in rows if r.task == task and r.config == "rsl_rl"]
        sbx = [r for r in rows if r.task == task and r.config == "sbx"]
        if not new:
            continue
        ratio, training = (
            (
                _median([r.steps_per_s for r in new]) / _median([r.steps_per_s for r in old]),
                _median([r.train_steps_per_s for r in new])
                / _median([r.train_steps_per_s for r in old]),
            )
            if old
            else (math.nan, math.nan)
        )
        old_bar = _median([r.bar_seconds for r in old]) if old else math.nan
        rsl_speed = (
            _median([r.train_steps_per_s for r in rsl])
            / _median([r.train_steps_per_s for r in new])
            if rsl
            else math.nan
        )
        sbx_speed = (
            _median([r.train_steps_per_s for r in sbx])
            / _median([r.train_steps_per_s for r in new])
            if sbx
            else math.nan
        )
        lines.append(
            f"| {task} | {_bars(new)} | {old_bar:.1f} | {_bars(rsl)} | {_bars(sbx)} | "
            f"{ratio:.2f}x | {training:.2f}x | {rsl_speed:.2f}x | {sbx_speed:.2f}x |"
        )
    return "\n".join(lines) + "\n"


def _bars(rows: list[LearnRow]) -> str:
    """``median (worst)`` time to bar of ``rows`` (worst nan if one never met it)."""
    if not rows:
        return "-"
    bar = [r.bar_seconds for r in rows]
    worst = max(bar) if not any(math.isnan(b) for b in bar) else math.nan
    return f"{_median(bar):.1f} ({worst:.1f})"


def _figure(rows: list[LearnRow], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    tasks = [t for t in TASKS if any(r.task == t for r in rows)]
    fig, axes = plt.subplots(1, len(tasks), figsize=(4 * len(tasks), 3.4), sharey=True)
    for ax, task in zip(np.atleast_1d(axes), tasks, strict=True):
        for r in (r for r in rows if r.task == task):
            with np.load(r.history) as h:
                x = h["seconds"]
                y = [float(np.mean(s)) for s in h["successes"]]
            style = {"shipped": "-", "previous": ":", "rsl_rl": "--", "sbx": "-."}[r.config]
            color = f"C{r.seed}"
            ax.plot(x, y, style, color=color, marker=".", label=f"{r.config} seed {r.seed}")
        ax.axhline(0.95, color="grey", lw=0.8)
        ax.set_title(task)
        ax.set_xlabel("training wall-clock [s]")
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())  # labels at decades only: no overlaps
    np.atleast_1d(axes)[0].set_ylabel("success, 100 held-out episodes")
    np.atleast_1d(axes)[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
