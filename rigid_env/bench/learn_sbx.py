"""Time to the bar of sbx-rl's PPO (the JIT-compiled update) in ``rigid-env bench learn``.

    rigid-env bench learn --tasks detumble --seeds 0 1 2 --previous-seeds --rsl-seeds \\
                          --sbx-seeds 0 1 2 [--sbx-config PATH]

sbx-rl's PPO (:mod:`rigid_env.agents.parallel.sbx_peer`) trains on the task's rsl-rl config
(``configs/agents/rsl_ppo_<task>.yaml``, or ``--sbx-config``: the same PPO arguments and
KL-adaptive rule) over the same env stack as the SB3 path, and is judged as every run of the
benchmark is: the bar's held-out episodes every ``eval.freq`` env-steps (the policy's
deterministic actions on observations normalised with the training statistics of the moment,
:func:`rigid_env.agents.bar.live_policy`), stopped at the bar or after ``--previous-limit``
CPU seconds, then the final model on 100 unseen episodes. It is a benchmark run, not a
training command: its folder holds only ``evaluations.npz`` (the history the report and the
figure read), no model.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

SINGLE_THREAD = "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
"""XLA's flags for a CPU client whose work runs on the calling thread (set before jax loads)."""


def one_xla_thread() -> None:
    """Run XLA's CPU work on the calling thread (the flags take effect when jax first loads;
    flags the environment already sets are kept)."""
    import os

    flags = os.environ.get("XLA_FLAGS", "")
    if "xla_cpu_multi_thread_eigen" not in flags:
        os.environ["XLA_FLAGS"] = f"{flags} {SINGLE_THREAD}".strip()


def train_sbx(
    task: str, seed: int, runs_dir: Path, limit_s: float, config: Path | None = None
) -> dict[str, Any]:
    """Train sbx-rl's PPO on ``task`` until the bar or ``limit_s`` CPU seconds; a
    :class:`rigid_env.bench.learn.LearnRow`'s fields."""
    one_xla_thread()  # the configs train on one thread (torch's and Numba's: limit_threads)
    from stable_baselines3.common.callbacks import BaseCallback

    from rigid_env.agents.bar import BarEvaluation, live_policy
    from rigid_env.agents.config import load_config
    from rigid_env.agents.parallel.sbx_peer import make_sbx
    from rigid_env.agents.train import limit_threads, make_vec_env
    from rigid_env.bench.learn import FINAL_EPISODES, FINAL_SEED, _first_at_bar, config_path

    cfg = load_config(config or config_path(task, "rsl_rl"), {"seed": seed})
    limit_threads(cfg.threads)
    run_dir = runs_dir / f"{cfg.task}__ppo_sbx__{seed}"
    (run_dir / "eval").mkdir(parents=True, exist_ok=True)
    venv = make_vec_env(cfg, cfg.n_envs, cfg.seed)
    model = make_sbx(cfg, venv)
    evaluation = BarEvaluation(cfg.env_id, cfg.env_kwargs, cfg.eval.episodes, cfg.eval.seed)
    evaluation.pd_fuel  # noqa: B018  (computed once, before the clock starts)
    hist: dict[str, list[Any]] = {k: [] for k in ("timesteps", "successes", "fuel", "pd_fuel",
                                                   "seconds", "cpu_seconds")}  # fmt: skip
    stopped, spent = ["budget"], [0.0]
    t0, c0 = time.perf_counter(), time.process_time()

    class AtBar(BaseCallback):
        """Evaluates every ``eval.freq`` env-steps; stops at the bar or after ``limit_s``."""

        def __init__(self) -> None:
            super().__init__()
            self.next_eval = cfg.eval.freq

        def _on_step(self) -> bool:
            if self.num_timesteps < self.next_eval:
                return True
            self.next_eval += cfg.eval.freq
            t = time.perf_counter()
            venv.training = False
            res = evaluation(live_policy(model))
            venv.training = True
            spent[0] += time.perf_counter() - t
            hist["timesteps"].append(self.num_timesteps)
            hist["successes"].append(np.asarray(res["success"], float))
            hist["fuel"].append(np.asarray(res["fuel"], float))
            hist["pd_fuel"].append(evaluation.pd_fuel)
            hist["seconds"].append(time.perf_counter() - t0)
            hist["cpu_seconds"].append(time.process_time() - c0)
            if res["met"]:
                stopped[0] = "bar"
            elif time.process_time() - c0 > limit_s:
                stopped[0] = "limit"
            return stopped[0] == "budget"

    model.learn(cfg.total_timesteps, callback=AtBar())
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    arrays = {k: np.asarray(v) for k, v in hist.items() if k not in ("successes", "fuel")}
    arrays["successes"] = np.asarray(hist["successes"])
    arrays["fuel"] = np.asarray(hist["fuel"])
    history = run_dir / "eval" / "evaluations.npz"
    np.savez(history, **arrays)
    bar = _first_at_bar({k: arrays[k] for k in arrays})
    venv.training = False
    final = BarEvaluation(cfg.env_id, cfg.env_kwargs, FINAL_EPISODES, FINAL_SEED)
    res = final(live_policy(model))
    steps = int(model.num_timesteps)
    return {
        "task": task,
        "config": "sbx",
        "seed": seed,
        "steps": steps,
        "seconds": seconds,
        "cpu_seconds": cpu,
        "steps_per_s": steps / seconds,
        "train_steps_per_s": steps / (seconds - spent[0]),
        "bar_steps": bar[0],
        "bar_seconds": bar[1],
        "bar_cpu_seconds": bar[2],
        "success": res["success_rate"],
        "fuel_ratio": res["fuel_ratio"],
        "stopped": stopped[0],
        "history": str(history),
    }
