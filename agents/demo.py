"""The main job: the pretrained policies beside the PD controller on fixed unseen seeds.

    rigid-env demo [--task T] [--episodes K] [--out DIR] [--force]

For each task the pretrained policy in ``agents/pretrained/`` (an SB3 zip with its
``VecNormalize`` statistics, loaded by :func:`agents.evaluate.load_policy`) and the PD controller
(:mod:`agents.controllers`) play the same ``K`` episodes, episode ``k`` reset with seed
``DEMO_SEED + k``. No other job uses these seeds: training resets from seeds 0..15, its periodic
evaluation from 1,000,000 + k, the README's tables and the sweeps from 12345 + k.

Written to ``DIR`` (default ``runs/demo``):

* ``results.md`` and ``results.csv``: per task and policy, the success rate, the mean final
  ``|w|`` [rad/s], fuel (in the task's unit: the thrusters' impulse [N s], the coils'
  dipole-time [A m^2 s]) and return over the ``K`` episodes, and the mean time to success [s]
  over the successful episodes only (the first step at which ``info["success"]`` held);
* ``episodes.csv``: the same quantities for every episode, with its seed;
* ``<task>_ppo_vs_<controller>.gif``: episode 0 of the policy (left) and of the task's analytic
  controller (right): ``..._ppo_vs_pd.gif``, or ``..._ppo_vs_bdot.gif`` on BdotDetumble.

Earlier results in ``DIR`` are never overwritten without ``force``.
"""

from __future__ import annotations

import csv
import importlib.util
import io
import json
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from rigid_env.envs import TASKS as REGISTERED

from .controllers import ANALYTIC, CONTROLLERS, PDController
from .evaluate import Policy, load_policy, resolve_env_kwargs, rollout
from .shipped import TASKS, shipped_id

#: Seed of episode 0; episode k uses DEMO_SEED + k (see the module docstring).
DEMO_SEED = 20261201
#: Episodes per task and policy by default: the whole command (imports, the four shipped tasks, the
#: GIFs) takes well under 2 minutes on two busy cores.
DEFAULT_EPISODES = 10
#: The most episodes per task and policy: a success rate over 1000 episodes is known to
#: +-3 % (95 %, binomial, p = 0.5), finer than the demo's table shows, and 8000 episodes take
#: about an hour; more belongs to ``python -m agents.evaluate``.
MAX_EPISODES = 1000
#: Seconds between progress lines within a task.
PROGRESS_EVERY_S = 10.0
DEFAULT_OUT = Path("runs/demo")
PRETRAINED = Path(__file__).resolve().parent / "pretrained"
RESULT_FILES = ("results.md", "results.csv", "episodes.csv")
#: How to install the render extras: the package's own name works for a wheel and a checkout
#: alike (``-e '.[render]'`` works only in a checkout).
RENDER_EXTRAS_HINT = "pip install 'rigid_env[render]' (in a checkout: pip install -e '.[render]')"


class DemoError(ValueError):
    """A user's mistake (unknown task, earlier results in the way, ...); one line."""


@dataclass(frozen=True)
class Episode:
    """One episode's outcome, as :func:`agents.evaluate.rollout` measures it."""

    seed: int
    success: bool
    final_angular_speed: float  # [rad/s]
    fuel: float  # [N s], or a coil's dipole-time [A m^2 s] (the task's fuel unit)
    ret: float  # undiscounted return
    time_to_success: float | None  # first step with success [s]; None if never


@dataclass(frozen=True)
class Row:
    """A task x policy row of the table: its episodes and their summary."""

    task: str
    policy: str
    episodes: list[Episode]
    fuel_unit: str = "N s"
    """The unit of the episodes' fuel (the task's: ``TaskView.fuel_unit``)."""

    @property
    def success_rate(self) -> float:
        return float(np.mean([e.success for e in self.episodes]))

    def mean(self, field: str) -> float:
        return float(np.mean([getattr(e, field) for e in self.episodes]))

    @property
    def time_to_success(self) -> float | None:
        """Mean over the successful episodes only [s]; None if none succeeded."""
        times = [e.time_to_success for e in self.episodes if e.success]
        times = [t for t in times if t is not None]
        return float(np.mean(times)) if times else None


def env_id(task: str) -> str:
    """The id its pretrained policy was trained on (:func:`agents.shipped.shipped_id`)."""
    return shipped_id(task)


def resolve_tasks(text: str | None) -> list[str]:
    """The tasks ``--task`` names: a short name (``Detumble``, any case) or its id
    (``RigidEnv/Detumble-v0``); None means every shipped task."""
    if text is None:
        return list(TASKS)
    for task in TASKS:
        if text.strip().lower() in (task.lower(), env_id(task).lower()):
            return [task]
        if text.strip().lower().startswith(f"rigidenv/{task.lower()}-v"):
            raise DemoError(
                f"--task: {text} is not the version the pretrained policy plays; the demo "
                f"runs {env_id(task)}: pass {task} or {env_id(task)} (python -m "
                f"agents.evaluate MODEL --env {text.strip()} evaluates a policy of that version)"
            )
    registered = [name for name in REGISTERED if name.lower() == text.strip().lower()]
    if registered:
        raise DemoError(
            f"--task: {registered[0]} ships no pretrained policy, so the demo does not play it; "
            f"choose one of {', '.join(TASKS)} (python -m agents.evaluate MODEL --env "
            f"{REGISTERED[registered[0]].env_id} evaluates a policy of your own)"
        )
    raise DemoError(
        f"--task: unknown task {text!r}; choose one of {', '.join(TASKS)} "
        f"(or its id, e.g. {env_id(next(iter(TASKS)))})"
    )


def pretrained_model(task: str) -> Path:
    """``agents/pretrained/ppo_<task>.zip`` (module name of the task, e.g. spin_stabilize)."""
    return PRETRAINED / f"ppo_{TASKS[task].module}.zip"


def policy_label(model: Path) -> str:
    """The model's algorithm in capitals (``PPO``), from its ``.json`` beside it."""
    meta = model.with_suffix(".json")
    algo = json.loads(meta.read_text()).get("algo", "policy") if meta.exists() else "policy"
    return str(algo).upper()


def run_episodes(
    task: str,
    policy: Policy,
    episodes: int,
    seed: int,
    progress: Callable[[int], None] | None = None,
    env_kwargs: dict[str, Any] | None = None,
) -> list[Episode]:
    """Episodes ``seed + k`` one at a time, each by :func:`agents.evaluate.rollout` (which
    returns means; one episode at a time keeps each episode's outcome), on the task made with
    ``env_kwargs``; ``progress(k)`` is called after each."""
    out = []
    for k in range(episodes):
        if progress is not None and k:
            progress(k)
        r = rollout(env_id(task), policy, 1, seed + k, env_kwargs)
        out.append(
            Episode(
                seed + k,
                r["success_rate"] == 1.0,
                r["mean_final_angular_speed"],
                r["mean_fuel"],
                r["mean_return"],
                r["mean_time_to_success"],
            )
        )
    return out


def pd_policy(task: str, env_kwargs: dict[str, Any] | None = None) -> Policy:
    """The task's analytic controller, for the task made with ``env_kwargs``."""
    probe = gym.make_vec(
        env_id(task), num_envs=1, vectorization_mode="vector_entry_point", **(env_kwargs or {})
    )
    policy = CONTROLLERS["pd"](probe)
    probe.close()
    return policy


def fuel_unit(task: str, env_kwargs: dict[str, Any] | None = None) -> str:
    """The unit of the task's fuel, as its env says (``N s``; ``A m^2 s`` on coils)."""
    probe = gym.make(env_id(task), **(env_kwargs or {}))
    unit = probe.unwrapped.task.view().fuel_unit
    probe.close()
    return str(unit)


class _Progress:
    """A line every :data:`PROGRESS_EVERY_S` seconds: episodes done and the time left."""

    def __init__(self, what: str, total: int, log: Callable[[str], None]) -> None:
        self.what, self.total, self.log = what, total, log
        self.start = self.last = time.perf_counter()

    def __call__(self, done: int) -> None:
        now = time.perf_counter()
        if now - self.last < PROGRESS_EVERY_S:
            return
        self.last = now
        left = (now - self.start) / done * (self.total - done)
        self.log(f"{self.what}: {done}/{self.total} episodes, about {left:.0f} s left")


# ---- tables ------------------------------------------------------------------------------------

COLUMNS = (
    "task",
    "policy",
    "episodes",
    "success rate",
    "final |w| [rad/s]",
    "fuel",
    "return",
    "time to success [s]",
)


def _cells(row: Row) -> list[str]:
    t = row.time_to_success
    return [
        row.task,
        row.policy,
        str(len(row.episodes)),
        f"{row.success_rate:.2f}",
        f"{row.mean('final_angular_speed'):.3f}",
        f"{row.mean('fuel'):.3f} {row.fuel_unit}",
        f"{row.mean('ret'):.2f}",
        "-" if t is None else f"{t:.2f}",
    ]


def text_table(rows: list[Row]) -> str:
    """Aligned plain-text table for the terminal."""
    body = [list(COLUMNS)] + [_cells(r) for r in rows]
    widths = [max(len(line[j]) for line in body) for j in range(len(COLUMNS))]
    # Names left-aligned, numbers right-aligned.
    return "\n".join(
        "  ".join(
            c.ljust(w) if j < 2 else c.rjust(w)
            for j, (c, w) in enumerate(zip(line, widths, strict=True))
        ).rstrip()
        for line in body
    )


def markdown_report(rows: list[Row], seed: int) -> str:
    """``results.md``: where the numbers come from, then the table."""
    k = len(rows[0].episodes)
    return (
        "# rigid-env demo\n\n"
        f"{k} episode{'s' if k > 1 else ''} per task and policy on seeds {seed}..{seed + k - 1} "
        "(episode k resets with the first + k; none is used in training or in the README's "
        "evaluations). Success "
        "rate, final |w|, fuel and return are means over the episodes; time to success is the "
        "mean over the successful episodes only. Fuel is in each task's unit: the impulse the "
        "thrusters delivered [N s], the coils' dipole-time [A m^2 s] on magnetorquers.\n\n"
        + markdown_table(rows)
        + "\n"
    )


def markdown_table(rows: list[Row]) -> str:
    """The table in Markdown (``|`` in headers escaped)."""
    head = [c.replace("|", "\\|") for c in COLUMNS]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(_cells(r)) + " |" for r in rows]
    return "\n".join(lines)


def _num(x: float | None) -> str:
    """A CSV number to 10 significant digits (no ``5.800000000000001``); empty for None."""
    return "" if x is None else f"{x:.10g}"


_MEASURES = ["final_angular_speed_rad_s", "fuel", "fuel_unit", "return", "time_to_success_s"]


def _csv(header: list[str], lines: list[list[object]]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    w.writerows(lines)
    return buf.getvalue()


def results_csv(rows: list[Row]) -> str:
    """One line per task and policy: means over its episodes (time to success over the
    successful ones)."""
    header = ["task", "policy", "episodes", "first_seed", "success_rate", *_MEASURES]
    lines = []
    for r in rows:
        lines.append(
            [
                *(r.task, r.policy, len(r.episodes), r.episodes[0].seed, _num(r.success_rate)),
                *(_num(r.mean("final_angular_speed")), _num(r.mean("fuel")), r.fuel_unit),
                *(_num(r.mean("ret")), _num(r.time_to_success)),
            ]
        )
    return _csv(header, lines)


def episodes_csv(rows: list[Row]) -> str:
    """One line per episode, with its seed."""
    header = ["task", "policy", "seed", "success", *_MEASURES]
    lines = [
        [
            *(r.task, r.policy, e.seed, int(e.success), _num(e.final_angular_speed)),
            *(_num(e.fuel), r.fuel_unit, _num(e.ret), _num(e.time_to_success)),
        ]
        for r in rows
        for e in r.episodes
    ]
    return _csv(header, lines)


def _write_text(path: Path, text: str) -> None:
    """Write beside ``path`` and rename into place: a failed write leaves no partial file."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(text)
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)


# ---- the command -------------------------------------------------------------------------------


def animation_path(out: Path, task: str) -> Path:
    """``<module>_ppo_vs_<controller>.gif``: the task's analytic controller by its label in
    lower case (``pd``; ``bdot`` on BdotDetumble, the B-dot law)."""
    controller = ANALYTIC.get(TASKS[task].task_class(), PDController).label
    return out / f"{TASKS[task].module}_ppo_vs_{controller.lower().replace('-', '')}.gif"


def check_out(out: Path, tasks: list[str], force: bool) -> None:
    """Refuse a file in the way of ``out`` or earlier results there (unless ``force``)."""
    if out.exists() and not out.is_dir():
        raise DemoError(f"--out: {out} is a file; give a directory such as {DEFAULT_OUT}")
    if force:
        return
    ours = [out / name for name in RESULT_FILES] + [animation_path(out, t) for t in tasks]
    earlier = [p.name for p in ours if p.exists()]
    if earlier:
        listed = ", ".join(earlier[:3]) + (
            f" and {len(earlier) - 3} more" if len(earlier) > 3 else ""
        )
        raise DemoError(
            f"--out: {out} holds earlier demo results ({listed}); "
            "pass --force to overwrite them, or choose another --out"
        )


def _check_render_extras() -> None:
    missing = [m for m in ("imageio", "pygame", "PIL") if importlib.util.find_spec(m) is None]
    if missing:
        raise DemoError(
            f"demo: the animation needs {', '.join(missing)}; install the render extras with "
            f"{RENDER_EXTRAS_HINT}"
        )


def run(
    task: str | None = None,
    episodes: int | None = None,
    out: Path | None = None,
    force: bool = False,
    seed: int = DEMO_SEED,
    log: Callable[[str], None] = print,
) -> int:
    """Evaluate, tabulate and animate; returns the exit status (0).

    Args:
        task: one task (short name or id); None for every shipped task.
        episodes: episodes per task and policy (>= 1); None for :data:`DEFAULT_EPISODES`.
        out: output directory; None for :data:`DEFAULT_OUT`.
        force: overwrite earlier results in ``out``.
        seed: seed of episode 0.
        log: where the progress lines, the table and the paths written go.

    Raises:
        DemoError: a user's mistake, in one line.
    """
    start = time.perf_counter()
    tasks = resolve_tasks(task)
    episodes = DEFAULT_EPISODES if episodes is None else int(episodes)
    if not 1 <= episodes <= MAX_EPISODES:
        raise DemoError(
            f"--episodes: must be an integer from 1 to {MAX_EPISODES}, got {episodes}; "
            f"{MAX_EPISODES} pin a success rate to +-3 %, more is a job for python -m "
            "agents.evaluate MODEL --episodes N"
        )
    out = DEFAULT_OUT if out is None else Path(out)
    check_out(out, tasks, force)
    _check_render_extras()
    from .side_by_side import record_side_by_side

    log(f"seeds {seed}..{seed + episodes - 1} ({episodes} episodes per task and policy)")
    rows: list[Row] = []
    written: list[Path] = []
    out.mkdir(parents=True, exist_ok=True)
    for name in tasks:
        t0 = time.perf_counter()
        model = pretrained_model(name)
        label = policy_label(model)
        kwargs = resolve_env_kwargs(model)  # both play the task as the sidecar records it
        learned = load_policy(model, env_id(name), kwargs)
        pd = pd_policy(name, kwargs)
        analytic = getattr(pd, "label", "PD")  # the task's analytic baseline: PD, or B-dot
        unit = fuel_unit(name, kwargs)
        for policy_name, policy in ((label, learned), (analytic, pd)):
            ticker = _Progress(f"{name} {policy_name}", episodes, log)
            played = run_episodes(name, policy, episodes, seed, ticker, kwargs)
            rows.append(Row(name, policy_name, played, unit))
        gif = animation_path(out, name)
        pair = [(f"{label} (pretrained)", learned), (f"{analytic} controller", pd)]
        record_side_by_side(env_id(name), pair, seed, gif, env_kwargs=kwargs)
        written.append(gif)
        log(
            f"{name}: {rows[-2].success_rate:.2f} / {rows[-1].success_rate:.2f} success "
            f"({label} / {analytic}), {time.perf_counter() - t0:.1f} s"
        )
    for name, text in (
        ("results.md", markdown_report(rows, seed)),
        ("results.csv", results_csv(rows)),
        ("episodes.csv", episodes_csv(rows)),
    ):
        _write_text(out / name, text)
        written.append(out / name)
    log("")
    log(text_table(rows))
    log("")
    for path in sorted(written):
        log(f"wrote {path}")
    log(f"done in {time.perf_counter() - start:.1f} s")
    return 0
