"""A run of the rsl-rl learner, in the SB3 path's run folder (``python -m agents.train CONFIG``
with ``learner: rsl_rl``).

The folder is :mod:`agents.train`'s: ``config.yaml``, ``eval/`` (the same held-out evaluations
against the bar, ``evaluations.npz`` and ``best_model``), ``checkpoints/`` and the final
``model.zip`` + ``vecnormalize.pkl`` + ``model.json``, each model an SB3 ``PPO`` zip with its
sidecar (:func:`agents.parallel.learner.to_sb3`), so ``agents.evaluate``, ``rigid-env demo``,
``PPO.load`` and rl-zoo3 read it as they read the SB3 path's. Beside each snapshot
``<name>.optim.pt`` keeps Adam's state: ``--resume`` continues from the newest complete
snapshot with its weights, statistics and optimiser (without that file, a fresh optimiser,
with a warning). The training envs, the same ``VecNormalize`` and seeds, come from
:func:`agents.train.make_vec_env`.

One rollout is ``n_envs x n_steps`` env-steps; checkpoints and evaluations happen at the first
rollout boundary at or after each multiple of their frequency.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import torch
import yaml

from ..bar import BarEvaluation, evaluation_env_kwargs
from ..callbacks import DurableEvaluation, save_snapshot, warn, write_atomic
from ..config import TrainConfig
from ..meaning import stamp
from .learner import from_sb3, make_runner, ppo_arguments, to_sb3

Stop = Callable[[DurableEvaluation, float], bool]
"""Called after each evaluation with it and the wall-clock seconds all evaluations took so far;
True ends the run there (the learning benchmark stops a run at the bar)."""


def _optim_path(model_zip: Path) -> Path:
    return model_zip.with_suffix(".optim.pt")


def _snapshot(runner: Any, model: Any, zip_path: Path, norm: Path, meta: dict[str, Any]) -> None:
    """The learner as an SB3 snapshot (:func:`agents.callbacks.save_snapshot`), Adam's state
    written first beside it."""
    to_sb3(runner, model)
    state = runner.alg.optimizer.state_dict()
    zip_path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic({_optim_path(zip_path): lambda p: torch.save(state, p)})
    save_snapshot(model, zip_path, norm, None, meta)


def train_parallel(
    cfg: TrainConfig,
    run_dir: Path,
    start: tuple[Any, Any, Any, list[str]] | None,
    trained: bool,
    progress: bool = True,
    stop: Stop | None = None,
) -> Path:
    """Train ``cfg`` (``learner: rsl_rl``) in ``run_dir`` from ``start`` (``(model, env,
    snapshot, skipped)`` of :func:`agents.train._resume_point`, or None: from nothing); the caller
    (:func:`agents.train.train`) holds the folder's lock and has made the resume checks."""
    if start is not None:
        model, venv, snap, skipped = start
        for problem in skipped:
            warn(f"{run_dir}: {problem}; falling back to the previous checkpoint")
        steps = snap.steps
    else:
        from ..train import _new_model, make_vec_env

        venv = make_vec_env(cfg, cfg.n_envs, cfg.seed, training=True)
        model = _new_model(cfg, venv, run_dir, 0)
        steps = 0
    from ..train import training_episode_steps

    runner = make_runner(cfg, venv, training_episode_steps(cfg))
    if start is not None:
        from_sb3(model, runner)
        optim = _optim_path(snap.model)
        if optim.exists():
            runner.alg.optimizer.load_state_dict(torch.load(optim, weights_only=True))
            runner.alg.learning_rate = runner.alg.optimizer.param_groups[0]["lr"]  # adaptive
        else:
            warn(f"{run_dir}: {optim.name} is missing; Adam starts afresh from {snap.model.name}")
    stamp(model, cfg.env_id, cfg.env_kwargs)  # what its actions mean, saved inside every zip
    run_dir.mkdir(parents=True, exist_ok=True)
    config_text = yaml.safe_dump(cfg.to_dict(), sort_keys=False)
    write_atomic({run_dir / "config.yaml": lambda p: p.write_text(config_text)})
    meta = {
        "env_id": cfg.env_id,
        "algo": cfg.algo,
        "env_kwargs": evaluation_env_kwargs(cfg.env_kwargs),
        "trained_env_kwargs": cfg.env_kwargs,
        "config": cfg.to_dict(),
    }
    from stable_baselines3.common.logger import configure

    model.set_logger(configure(str(run_dir / "tb" / f"run_{int(time.time())}"), ["tensorboard"]))
    evaluation = DurableEvaluation(
        BarEvaluation(cfg.env_id, cfg.env_kwargs, cfg.eval.episodes, cfg.eval.seed),
        run_dir / "eval",
        1,
        meta,
        resumed_from=steps if start is not None else (0 if trained else None),
    )
    evaluation.init_callback(model)
    evaluation.on_training_start({}, {})
    rollout = cfg.n_envs * ppo_arguments(cfg)["n_steps"]
    next_eval = (steps // cfg.eval.freq + 1) * cfg.eval.freq
    next_ckpt = (steps // cfg.checkpoint_freq + 1) * cfg.checkpoint_freq
    t0 = time.perf_counter()
    steps0, evaluating = steps, 0.0
    while steps < cfg.total_timesteps:
        runner.learn(1)
        steps += rollout
        model.num_timesteps = steps
        if steps >= next_ckpt:
            n = steps
            folder = run_dir / "checkpoints"
            _snapshot(runner, model, folder / f"model_{n}_steps.zip",
                      folder / f"model_vecnormalize_{n}_steps.pkl", meta)  # fmt: skip
            next_ckpt = (steps // cfg.checkpoint_freq + 1) * cfg.checkpoint_freq
        if steps >= next_eval or steps >= cfg.total_timesteps:
            t_eval = time.perf_counter()
            to_sb3(runner, model)
            evaluation.on_step()
            evaluating += time.perf_counter() - t_eval
            model.logger.dump(steps)
            next_eval = (steps // cfg.eval.freq + 1) * cfg.eval.freq
            if progress:
                _progress_line(cfg, steps, steps0, t0, evaluation)
            if stop is not None and stop(evaluation, evaluating):
                break
    _snapshot(runner, model, run_dir / "model.zip", run_dir / "vecnormalize.pkl", meta)
    venv.close()
    return run_dir


def _progress_line(
    cfg: TrainConfig, steps: int, steps0: int, t0: float, evaluation: DurableEvaluation
) -> None:
    rate = (steps - steps0) / max(time.perf_counter() - t0, 1e-9)
    last = evaluation.latest or {}
    met = evaluation.first_met
    bar = f" (bar met at {met[0]:,}, {met[1]:.1f} s)" if met else ""
    print(
        f"{cfg.run_name}   {steps:,}/{cfg.total_timesteps:,} steps   {rate / 1e3:.1f}k steps/s"
        f"   eval: success {last.get('success_rate', float('nan')):.2f}, fuel "
        f"{last.get('fuel_ratio', float('nan')):.2f}x PD{bar}",
        file=sys.stdout,
        flush=True,
    )
