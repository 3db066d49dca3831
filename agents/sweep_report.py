"""A finished sweep's summary: ``summary.md``, ``summary.csv``, ``summary.png`` and
``best_config.yaml`` in the sweep's folder.

The trials come from Ray Tune's results (:func:`agents.sweep.run_sweep`); they are grouped by
setting with pandas (mean, sample standard deviation, min and max over the seeds), the best
setting is picked by the sweep's metric, and its training config is written ready for
``python -m agents.train``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml

from .config import load_config
from .sweep_config import METRICS, SweepConfig, base_data, grid_points, setting_label, trial_data

if TYPE_CHECKING:
    import pandas as pd

CSV_COLUMNS = ("setting", "seed", "timesteps", *METRICS, "mean_time_to_success", "run_dir")
"""Columns of ``summary.csv``, one row per finished trial."""


@dataclass
class TrialRow:
    """One finished trial's final evaluation."""

    setting: str
    seed: int
    metrics: dict[str, Any]
    """The final evaluation's metrics (:data:`agents.sweep_config.METRICS` and more)."""
    run_dir: str
    curve: list[tuple[int, float, float]]
    """``(timesteps, success_rate, mean_return)`` of every report, final included."""


def trial_table(rows: Sequence[TrialRow]) -> pd.DataFrame:
    """One row per trial, columns :data:`CSV_COLUMNS`."""
    import pandas as pd  # a dependency of ray[tune]

    records = [
        {"setting": r.setting, "seed": r.seed, "run_dir": r.run_dir, **r.metrics} for r in rows
    ]
    return pd.DataFrame.from_records(records, columns=list(CSV_COLUMNS))


def setting_table(rows: Sequence[TrialRow]) -> pd.DataFrame:
    """Per setting (in the order they come): ``seeds`` and, for every metric, ``mean``,
    ``std`` (sample; 0 for one seed), ``min`` and ``max`` over the seeds."""
    trials = trial_table(rows)
    grouped = trials.groupby("setting", sort=False)
    table = grouped[list(METRICS)].agg(["mean", "std", "min", "max"]).fillna(0.0)
    table[("seeds", "count")] = grouped["seed"].count()
    return table


def best_setting(table: pd.DataFrame, metric: str) -> str:
    """The setting with the best mean ``metric`` (ties: the first)."""
    means = table[(metric, "mean")]
    return str(means.idxmax() if METRICS[metric] == "max" else means.idxmin())


def markdown_summary(sweep: SweepConfig, rows: Sequence[TrialRow]) -> str:
    """Per-setting table (mean +- sample std and min..max over seeds), best setting, and
    per-trial table."""
    table = setting_table(rows)
    ev = sweep.evaluation
    lines = [
        f"Sweep `{sweep.name}`: final models on {ev.episodes} fixed episodes (seeds "
        f"{ev.seed}..{ev.seed + ev.episodes - 1}); mean ± std (min..max) over training "
        "seeds.",
        "",
        "| setting | seeds | success rate | return | final \\|w\\| [rad/s] | fuel [N s] |",
        "|---|---|---|---|---|---|",
    ]
    for setting, s in table.iterrows():

        def cell(m: str, f: str, s: pd.Series = s) -> str:
            low, high = s[(m, "min")], s[(m, "max")]
            return f"{s[(m, 'mean')]:{f}} ± {s[(m, 'std')]:{f}} ({low:{f}}..{high:{f}})"

        lines.append(
            f"| {setting} | {int(s[('seeds', 'count')])} | {cell('success_rate', '.2f')} | "
            f"{cell('mean_return', '.1f')} | {s[('mean_final_angular_speed', 'mean')]:.3f} | "
            f"{s[('mean_fuel', 'mean')]:.2f} |"
        )
    if len(table):
        best = best_setting(table, sweep.metric)
        b = table.loc[best]
        lines += [
            "",
            f"Best setting by mean {sweep.metric} ({sweep.mode}): **{best}** "
            f"({b[(sweep.metric, 'mean')]:.3f} ± {b[(sweep.metric, 'std')]:.3f} over "
            f"{int(b[('seeds', 'count')])} seeds).",
        ]
    lines += [
        "",
        "| setting | seed | timesteps | success rate | return | final \\|w\\| | fuel |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        m = r.metrics
        lines.append(
            f"| {r.setting} | {r.seed} | {m['timesteps']} | {m['success_rate']:.2f} | "
            f"{m['mean_return']:.1f} | {m['mean_final_angular_speed']:.3f} | "
            f"{m['mean_fuel']:.2f} |"
        )
    return "\n".join(lines) + "\n"


def plot_summary(sweep: SweepConfig, rows: Sequence[TrialRow], path: Path) -> bool:
    """Figure: final success rate and return per setting (seeds as dots, mean +- std), and
    the success rate during training (mean and min..max over seeds). False without
    matplotlib."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    table = setting_table(rows)
    settings = list(table.index)
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2), constrained_layout=True)
    x = np.arange(len(settings))
    for ax, metric, title in (
        (axes[0], "success_rate", "final success rate"),
        (axes[1], "mean_return", "final mean return"),
    ):
        for i, setting in enumerate(settings):
            v = [float(r.metrics[metric]) for r in rows if r.setting == setting]
            jitter = np.linspace(-0.12, 0.12, len(v)) if len(v) > 1 else np.zeros(1)
            ax.scatter(i + jitter, v, s=18, color="tab:blue", alpha=0.6, zorder=3)
            ax.errorbar(
                i + 0.25,
                table.loc[setting, (metric, "mean")],
                yerr=table.loc[setting, (metric, "std")],
                fmt="o",
                color="black",
                capsize=4,
                zorder=4,
            )
        many = len(settings) > 3
        ax.set_xticks(x, settings, rotation=20 if many else 0, ha="right" if many else "center")
        ax.set_xlim(-0.6, len(settings) - 0.4)
        ax.set_title(f"{title}\n(dots: seeds; black: mean ± std)", fontsize=10)
        ax.grid(alpha=0.3)
    axes[0].set_ylim(-0.05, 1.05)
    ax = axes[2]
    for k, setting in enumerate(settings):
        curves = [r.curve for r in rows if r.setting == setting and r.curve]
        steps = sorted({t for c in curves for t, _, _ in c})
        if not steps:
            continue
        success = np.full((len(curves), len(steps)), np.nan)
        for i, c in enumerate(curves):
            for t, succ, _ in c:
                success[i, steps.index(t)] = succ
        color = f"C{k % 10}"
        for row in success:
            ax.plot(steps, row, color=color, alpha=0.25, linewidth=0.8)
        ax.plot(steps, np.nanmean(success, axis=0), color=color, label=setting, marker=".", lw=2)
    ax.set_xlabel("environment steps")
    ax.set_ylabel("success rate")
    ax.set_ylim(-0.05, 1.05)
    ax.set_title("success rate during training\n(thin: seeds; thick: mean)", fontsize=10)
    ax.grid(alpha=0.3)
    if len(settings) > 1:
        ax.legend(fontsize=8)
    ev = sweep.evaluation
    fig.suptitle(
        f"sweep {sweep.name}: {len(rows)} trials of "
        f"{rows[0].metrics['timesteps'] if rows else 0} steps; each point evaluates "
        f"the policy on {ev.episodes} fixed episodes",
        fontsize=11,
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return True


def write_summary(sweep: SweepConfig, rows: Sequence[TrialRow]) -> dict[str, Path]:
    """``summary.md``, ``summary.csv``, ``summary.png`` and ``best_config.yaml`` in the
    sweep's folder; returns their paths."""
    out = sweep.directory
    out.mkdir(parents=True, exist_ok=True)
    paths = {"table": out / "summary.md", "csv": out / "summary.csv"}
    paths["table"].write_text(markdown_summary(sweep, rows))
    trial_table(rows).to_csv(paths["csv"], index=False)
    if plot_summary(sweep, rows, out / "summary.png"):
        paths["figure"] = out / "summary.png"
    table = setting_table(rows)
    if len(table):
        best = best_setting(table, sweep.metric)
        point = next(p for p in grid_points(sweep) if setting_label(sweep.varying, p) == best)
        point.pop("seed", None)
        cfg = load_config(trial_data(base_data(sweep), point))
        seeds = [r.seed for r in rows if r.setting == best]
        paths["best"] = out / "best_config.yaml"
        paths["best"].write_text(
            f"# Best setting of sweep {sweep.name} ({best}) by mean {sweep.metric} "
            f"over seeds {seeds}.\n# Train it: python -m agents.train {paths['best']}\n"
            + yaml.safe_dump(cfg.to_dict(), sort_keys=False)
        )
    return paths
