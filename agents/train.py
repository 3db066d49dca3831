"""Train an SB3 agent on a RigidEnv task from a YAML config.

    python -m agents.train configs/agents/ppo_detumble.yaml [--seed S] [--total-timesteps N]
                           [--runs-dir runs] [--resume] [--no-progress]

A run goes to ``runs/<task>__<algo>__<seed>/``: ``config.yaml`` (the full resolved config),
``tb/`` (TensorBoard), ``checkpoints/`` (model, ``VecNormalize`` statistics and replay buffer
every ``checkpoint_freq`` steps), ``eval/`` (EvalCallback log and best model) and the final
``model.zip`` + ``vecnormalize.pkl``. ``--resume`` continues from the newest checkpoint with
its step count and normalisation statistics.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml

from .config import ConfigError, TrainConfig, algorithm_class, load_config


def make_vec_env(
    cfg: TrainConfig, n_envs: int, seed: int, training: bool = True, norm_stats: Path | None = None
) -> Any:
    """The native SB3 adapter with ``VecMonitor`` and (optionally) ``VecNormalize``."""
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from .vec_adapter import RigidBodySB3VecEnv

    venv = RigidBodySB3VecEnv(cfg.env_id, num_envs=n_envs, **cfg.env_kwargs)
    venv.seed(seed)
    venv = VecMonitor(venv)
    if cfg.normalize.obs or cfg.normalize.reward:
        if norm_stats is not None and norm_stats.exists():
            venv = VecNormalize.load(str(norm_stats), venv)
        else:
            gamma = float(cfg.hyperparams.get("gamma", 0.99))
            venv = VecNormalize(
                venv,
                norm_obs=cfg.normalize.obs,
                norm_reward=cfg.normalize.reward,
                clip_obs=cfg.normalize.clip_obs,
                gamma=gamma,
            )
        venv.training = training
        if not training:
            venv.norm_reward = False
    return venv


def _policy_kwargs(cfg: TrainConfig) -> dict[str, Any]:
    import torch

    kw = dict(cfg.policy_kwargs)
    if "activation_fn" in kw:
        kw["activation_fn"] = {"tanh": torch.nn.Tanh, "relu": torch.nn.ReLU}[kw["activation_fn"]]
    return kw


def _latest_checkpoint(ckpt_dir: Path) -> tuple[Path, int] | None:
    """The newest *complete* checkpoint ``(model zip, steps)``, or None.

    SB3's ``CheckpointCallback`` writes the model, then the replay buffer, then the
    ``VecNormalize`` statistics; a run killed between those writes leaves a newer model
    without its companions. A checkpoint counts only when it has every kind of companion file
    that any checkpoint of the run has."""
    models: dict[int, Path] = {}
    for p in ckpt_dir.glob("model_*_steps.zip"):
        m = re.search(r"model_(\d+)_steps\.zip$", p.name)
        if m:
            models[int(m.group(1))] = p
    kinds = [k for k in ("vecnormalize", "replay_buffer") if any(ckpt_dir.glob(f"model_{k}_*.pkl"))]
    for steps in sorted(models, reverse=True):
        if all((ckpt_dir / f"model_{k}_{steps}_steps.pkl").exists() for k in kinds):
            return models[steps], steps
    return None


def train(
    cfg: TrainConfig,
    runs_dir: Path = Path("runs"),
    resume: bool = False,
    progress: bool = True,
    verbose: int = 0,
    callbacks: Sequence[Any] = (),
) -> Path:
    """Train and save; returns the run directory.

    Args:
        callbacks: extra SB3 callbacks, called after the built-in ones (checkpoints,
            evaluation) at every step, so on an evaluation step right after the evaluation
            (``agents.sweep`` reports to Ray Tune this way).
    """
    from stable_baselines3.common.callbacks import CallbackList, CheckpointCallback, EvalCallback

    run_dir = runs_dir / cfg.run_name
    ckpt_dir = run_dir / "checkpoints"
    if run_dir.exists() and not resume and (run_dir / "config.yaml").exists():
        raise ConfigError(
            f"{run_dir}: a run already exists; pass --resume to continue it, "
            "or choose another --seed or --runs-dir"
        )
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "config.yaml").write_text(yaml.safe_dump(cfg.to_dict(), sort_keys=False))

    algo_cls = algorithm_class(cfg.algo)
    start = _latest_checkpoint(ckpt_dir) if resume else None
    if resume and start is None:
        raise ConfigError(f"{ckpt_dir}: no checkpoint to resume from; start without --resume")
    norm_path = None
    if start is not None:
        norm_path = ckpt_dir / f"model_vecnormalize_{start[1]}_steps.pkl"
    env = make_vec_env(cfg, cfg.n_envs, cfg.seed, training=True, norm_stats=norm_path)
    eval_env = make_vec_env(cfg, 1, cfg.eval.seed, training=False)
    if start is not None:
        model = algo_cls.load(str(start[0]), env=env, device=cfg.device)
        buffer = ckpt_dir / f"model_replay_buffer_{start[1]}_steps.pkl"
        if buffer.exists() and hasattr(model, "load_replay_buffer"):
            model.load_replay_buffer(str(buffer))
    else:
        model = algo_cls(
            cfg.policy,
            env,
            seed=cfg.seed,
            device=cfg.device,
            verbose=verbose,
            tensorboard_log=str(run_dir / "tb"),
            policy_kwargs=_policy_kwargs(cfg),
            **cfg.hyperparams,
        )
    # Share the training normalisation statistics with the evaluation env.
    if hasattr(env, "obs_rms"):
        eval_env.obs_rms = env.obs_rms
    per_env = max(1, cfg.eval.freq // cfg.n_envs)
    callbacks = CallbackList(
        [
            CheckpointCallback(
                save_freq=max(1, cfg.checkpoint_freq // cfg.n_envs),
                save_path=str(ckpt_dir),
                name_prefix="model",
                save_replay_buffer=True,
                save_vecnormalize=True,
            ),
            _SyncNormalization(eval_env),
            EvalCallback(
                eval_env,
                n_eval_episodes=cfg.eval.episodes,
                eval_freq=per_env,
                log_path=str(run_dir / "eval"),
                best_model_save_path=str(run_dir / "eval"),
                deterministic=True,
                verbose=verbose,
            ),
            *callbacks,
        ]
    )
    remaining = cfg.total_timesteps - (model.num_timesteps if start is not None else 0)
    if remaining > 0:
        model.learn(
            total_timesteps=remaining,
            callback=callbacks,
            progress_bar=progress,
            reset_num_timesteps=start is None,
            tb_log_name="run",
        )
    model.save(str(run_dir / "model.zip"))
    if hasattr(env, "save"):
        env.save(str(run_dir / "vecnormalize.pkl"))
    (run_dir / "model.json").write_text(
        json.dumps(
            {
                "env_id": cfg.env_id,
                "algo": cfg.algo,
                "env_kwargs": cfg.env_kwargs,
                "num_timesteps": int(model.num_timesteps),
            },
            indent=2,
        )
    )
    env.close()
    eval_env.close()
    return run_dir


class _SyncNormalization:
    """Callback-like object copying the training ``obs_rms`` into the eval env before each eval."""

    def __new__(cls, eval_env: Any) -> Any:
        from stable_baselines3.common.callbacks import BaseCallback

        class Sync(BaseCallback):
            def _on_step(self) -> bool:
                train_env = self.model.get_env()
                if hasattr(train_env, "obs_rms") and hasattr(eval_env, "obs_rms"):
                    eval_env.obs_rms = train_env.obs_rms
                return True

        return Sync()


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    parser = argparse.ArgumentParser(
        prog="python -m agents.train", description=__doc__.split("\n")[0]
    )
    parser.add_argument("config", help="training config YAML (configs/agents/*.yaml)")
    parser.add_argument("--seed", type=int, help="override the config's seed")
    parser.add_argument("--total-timesteps", type=int, help="override total_timesteps")
    parser.add_argument("--n-envs", type=int, help="override n_envs")
    parser.add_argument(
        "--runs-dir", type=Path, default=Path("runs"), help="where runs go (default runs/)"
    )
    parser.add_argument("--resume", action="store_true", help="continue from the newest checkpoint")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--verbose", type=int, default=0)
    args = parser.parse_args(argv)
    overrides = {
        k: v
        for k, v in (
            ("seed", args.seed),
            ("total_timesteps", args.total_timesteps),
            ("n_envs", args.n_envs),
        )
        if v is not None
    }
    try:
        cfg = load_config(args.config, overrides)
        progress = not args.no_progress
        if progress:
            try:
                import rich  # noqa: F401
                import tqdm  # noqa: F401
            except ImportError:
                progress = False
        run_dir = train(
            cfg, args.runs_dir, resume=args.resume, progress=progress, verbose=args.verbose
        )
    except ConfigError as exc:
        print(f"agents.train: error: {exc}", file=sys.stderr)
        return 2
    print(f"saved {run_dir / 'model.zip'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
