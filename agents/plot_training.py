"""Training curves from the EvalCallback logs of finished runs.

    python -m agents.plot_training runs/Detumble__ppo__0 [runs/...] --out docs/figures/training.png

One panel per run: mean evaluation return (with its spread over the evaluation episodes)
against environment steps, and the analytic PD controller's mean return on the same evaluation
seeds as a dashed line.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    parser = argparse.ArgumentParser(
        prog="python -m agents.plot_training", description=__doc__.split("\n")[0]
    )
    parser.add_argument(
        "runs", nargs="+", type=Path, help="run folders (runs/<task>__<algo>__<seed>)"
    )
    parser.add_argument("--out", type=Path, default=Path("docs/figures/training.png"))
    args = parser.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .evaluate import evaluate

    runs = []
    for run in args.runs:
        log = run / "eval" / "evaluations.npz"
        meta = run / "model.json"
        if not log.exists() or not meta.exists():
            print(
                f"agents.plot_training: error: {run}: no eval/evaluations.npz or model.json; "
                "is the run finished?",
                file=sys.stderr,
            )
            return 2
        runs.append((run, np.load(log), json.loads(meta.read_text())))
    fig, axes = plt.subplots(1, len(runs), figsize=(4.2 * len(runs), 3.4), squeeze=False)
    for ax, (_run, log, meta) in zip(axes[0], runs, strict=True):
        steps = log["timesteps"]
        ret = log["results"]
        mean, std = ret.mean(axis=1), ret.std(axis=1)
        ax.plot(steps, mean, label=f"{meta['algo'].upper()} (deterministic eval)")
        ax.fill_between(steps, mean - std, mean + std, alpha=0.25)
        cfg_seed = 1_000_000
        pd = evaluate(
            None,
            meta["env_id"],
            episodes=ret.shape[1],
            seed=cfg_seed,
            only=["pd"],
            env_kwargs=meta.get("env_kwargs") or None,
        )["pd"]
        ax.axhline(pd["mean_return"], color="k", ls="--", lw=1, label="PD controller")
        if "successes" in log.files and log["successes"].size:
            ax2 = ax.twinx()
            ax2.plot(steps, log["successes"].mean(axis=1), color="tab:green", lw=1, alpha=0.7)
            ax2.set_ylim(-0.02, 1.02)
            ax2.set_ylabel("success rate", color="tab:green")
        ax.set_title(meta["env_id"].split("/")[-1])
        ax.set_xlabel("environment steps")
        ax.set_ylabel("episode return")
        ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
