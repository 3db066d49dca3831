"""The baselines' results table: trained runs over seeds beside the controllers, with robustness.

    python -m agents.baselines RUN_DIR [RUN_DIR ...] [--out runs/baselines] [--episodes 100]
                               [--seed 12345] [--force]

Each ``RUN_DIR`` is a folder ``agents.train`` wrote (``runs/Reorient__ppo__0``); the runs are
grouped by env id, algorithm and training env kwargs, so the three seeds of one config make
one row, and the PD, zero and random controllers run once per task. Every policy runs on the
same episodes (episode ``k`` resets with ``seed + k``; ``agents.train`` evaluates on other
seeds) under each of :data:`CONDITIONS`:

* ``nominal``: the task as registered (a model trained under randomisation is evaluated
  without it);
* ``randomised``: mass, inertia (each principal moment) and thrust drawn within +-30 % per
  episode, and gaussian noise of 0.01 rad/s on the observed angular velocity;
* ``inertia +-90 %``: each principal moment drawn within +-90 % per episode;
* ``control step x2`` and ``x4``: the task's control step ``dt`` doubled and quadrupled (0.1
  and 0.2 s on the thruster tasks, whose step is 0.05 s; 10 and 20 s on BdotDetumble), so each
  action holds that much longer.

A model is run with the env kwargs its sidecar records, the condition's merged over them; a
registered variant merges them into its own defaults key by key
(:func:`rigid_env.envs.variant_kwargs`), so ``RigidEnv/DetumbleFaults-v0``'s ``nominal`` keeps
its misalignment and faults and turns the rest off, its ``randomised`` adds mass, inertia,
thrust and noise to them.
``<out>/results.md`` is the summary (per row: success rate as the mean over seeds with the
worst and best seed, fuel and its ratio to the PD controller's on the same episodes, time to
success over the successful episodes only, success under each other condition);
``<out>/results.csv`` has every (task, policy, seed, condition) with all metrics.
"""

from __future__ import annotations

import csv
import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from rigid_env.config_files import read_yaml

from ._cli import OneLineParser, folder_problem, integer, path
from .evaluate import EvaluationError, evaluate


@dataclass(frozen=True)
class Steps:
    """A condition's control step: ``factor`` times the task's registered ``dt``."""

    factor: float


def condition_kwargs(condition: str, env_id: str) -> dict[str, Any]:
    """The env kwargs of ``condition`` on the task ``env_id`` (a :class:`Steps` made a
    ``dt`` in seconds from the task's registered one)."""
    over = dict(CONDITIONS[condition])
    if isinstance(over.get("dt"), Steps):
        env = gym.make(env_id)
        over["dt"] = over["dt"].factor * env.unwrapped.task.dt
        env.close()
    return over


_OFF = {"mass": 0.0, "inertia": 0.0, "thrust": 0.0, "sensor_noise": 0.0}
#: Name -> env kwargs merged over the model's recorded ones.
CONDITIONS: dict[str, dict[str, Any]] = {
    "nominal": {"randomization": dict(_OFF)},
    "randomised": {
        "randomization": {"mass": 0.3, "inertia": 0.3, "thrust": 0.3, "sensor_noise": 0.01}
    },
    "inertia +-90 %": {"randomization": {**_OFF, "inertia": 0.9}},
    "control step x2": {"randomization": dict(_OFF), "dt": Steps(2)},
    "control step x4": {"randomization": dict(_OFF), "dt": Steps(4)},
}
CONTROLLER_ROWS = ("pd", "zero", "random")
METRICS = (
    "success_rate",
    "mean_final_angular_speed",
    "mean_fuel",
    "mean_return",
    "mean_time_to_success",
    "numerical_errors",
)


@dataclass(frozen=True)
class Run:
    """A finished training run: its final model and what trained it."""

    path: Path
    env_id: str
    algo: str
    seed: int
    timesteps: int
    env_kwargs: dict[str, Any]

    @property
    def label(self) -> str:
        """The row's policy name: the algorithm, and what it was trained with if not the
        task's defaults (``PPO rand.inertia=0.5``)."""
        flat = " ".join(_flat(self.env_kwargs))
        flat = flat.replace("randomization.", "rand.").replace("sensor_noise", "noise")
        return f"{self.algo.upper()} {flat}".strip()

    @property
    def model(self) -> Path:
        return self.path / "model.zip"


def find_run(folder: Path) -> Run:
    """The finished run in ``folder``.

    Raises:
        EvaluationError: no final model (not finished, or not a run folder).
    """
    meta_path, config_path = folder / "model.json", folder / "config.yaml"
    if not (meta_path.exists() and (folder / "model.zip").exists() and config_path.exists()):
        raise EvaluationError(
            f"{folder}: no finished run (model.zip, model.json and config.yaml); finish it with "
            f"`python -m agents.train {config_path} --resume`"
        )
    meta = json.loads(meta_path.read_text())
    config = read_yaml(config_path)
    return Run(folder, meta["env_id"], meta["algo"], int(config["seed"]),
               int(meta["num_timesteps"]), dict(config.get("env_kwargs") or {}))  # fmt: skip


def _flat(kwargs: dict[str, Any], prefix: str = "") -> list[str]:
    out = []
    for key, value in kwargs.items():
        if isinstance(value, dict):
            out += _flat(value, f"{prefix}{key}.")
        else:
            out.append(f"{prefix}{key}={value}")
    return out


def evaluate_runs(runs: list[Run], episodes: int, seed: int) -> list[dict[str, Any]]:
    """One record per (env id, policy, seed, condition): the metrics of
    :func:`agents.evaluate.evaluate` plus ``env_id, policy, seed, condition, timesteps``."""
    records: list[dict[str, Any]] = []
    for env_id in dict.fromkeys(r.env_id for r in runs):  # in the order given
        for condition in CONDITIONS:
            kwargs = condition_kwargs(condition, env_id)
            for run in (r for r in runs if r.env_id == env_id):
                res = evaluate(run.model, env_id, episodes, seed, ["model"], kwargs)["model"]
                records.append(_record(env_id, run.label, run.seed, condition, run.timesteps, res))
            ctrl = evaluate(None, env_id, episodes, seed, list(CONTROLLER_ROWS), kwargs)
            for name, res in ctrl.items():
                records.append(_record(env_id, name, None, condition, None, res))
    return records


def _record(env_id, policy, seed, condition, timesteps, res) -> dict[str, Any]:
    return {"env_id": env_id, "policy": policy, "seed": seed, "condition": condition,
            "timesteps": timesteps, **{k: res[k] for k in METRICS}}  # fmt: skip


def _mean(values: list[float | None]) -> float | None:
    kept = [v for v in values if v is not None]
    return float(np.mean(kept)) if kept else None


def summary_table(records: list[dict[str, Any]]) -> str:
    """The Markdown summary: a row per (task, policy) over its seeds."""
    conditions = [c for c in CONDITIONS if c != "nominal"]
    head = ["task", "policy", "budget", "seeds", "success (worst-best)", "fuel [N s]",
            "fuel / PD", "time to success [s]"] + [f"success, {c}" for c in conditions]  # fmt: skip
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    rows: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in records:
        rows.setdefault((r["env_id"], r["policy"]), []).append(r)
    pd_fuel = {
        r["env_id"]: r["mean_fuel"]
        for r in records
        if r["policy"] == "pd" and r["condition"] == "nominal"
    }
    for (env_id, policy), rs in rows.items():
        by = {c: [r for r in rs if r["condition"] == c] for c in CONDITIONS}
        nominal = by["nominal"]
        success = [r["success_rate"] for r in nominal]
        fuel = _mean([r["mean_fuel"] for r in nominal]) or 0.0
        t = _mean([r["mean_time_to_success"] for r in nominal])
        steps = nominal[0]["timesteps"]
        ratio = fuel / pd_fuel[env_id] if pd_fuel.get(env_id) else None
        cells = [
            env_id.removeprefix("RigidEnv/"),
            policy,
            "-" if steps is None else f"{steps / 1e6:.1f}M",
            str(len(nominal)) if steps is not None else "-",
            f"{np.mean(success):.2f}"
            + (f" ({min(success):.2f}-{max(success):.2f})" if len(success) > 1 else ""),
            f"{fuel:.3f}",
            "-" if ratio is None else f"{ratio:.2f}",
            "-" if t is None else f"{t:.2f}",
        ] + [f"{np.mean([r['success_rate'] for r in by[c]]):.2f}" for c in conditions]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    parser = OneLineParser(
        prog="python -m agents.baselines",
        description="Evaluate trained runs over seeds beside the controllers, with robustness.",
    )
    parser.add_argument("runs", nargs="+", type=Path, help="run folders agents.train wrote")
    parser.add_argument("--out", type=path, default=Path("runs/baselines"))
    parser.add_argument("--episodes", type=integer, default=100)
    parser.add_argument("--seed", type=integer, default=12345, help="episode k uses seed + k")
    parser.add_argument("--force", action="store_true", help="overwrite an existing --out")
    args = parser.parse_args(argv)
    md, table = args.out / "results.md", args.out / "results.csv"
    try:
        problem = folder_problem(args.out)  # found now, not after the evaluation
        if problem is not None:
            raise EvaluationError(f"--out: {problem}; give a folder you can write to")
        if (md.exists() or table.exists()) and not args.force:
            raise EvaluationError(f"--out: {args.out} holds results; pass --force to replace them")
        runs = [find_run(p) for p in args.runs]
        records = evaluate_runs(runs, args.episodes, args.seed)
    except EvaluationError as exc:
        print(f"agents.baselines: error: {exc}", file=sys.stderr)
        return 2
    except MemoryError:  # each evaluation runs its episodes at once
        print(
            f"agents.baselines: error: --episodes: {args.episodes} episodes at once do not fit "
            "in memory; give fewer",
            file=sys.stderr,
        )
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    text = summary_table(records)
    md.write_text(text + "\n")
    with open(table, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(records[0]))
        writer.writeheader()
        writer.writerows(records)
    print(text)
    print(f"wrote {md} and {table}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
