"""Evaluate a trained policy beside the analytic, zero and random controllers on the same seeds.

    python -m agents.evaluate MODEL.zip --env RigidEnv/Detumble-v0 --episodes 100 --seed 12345
                              [--json] [--video out.gif] [--only model,pd,zero,random]

``MODEL`` may also be ``none`` (controllers only). A model's ``VecNormalize`` statistics are
read from ``<model>_vecnormalize.pkl`` or ``vecnormalize.pkl`` beside it, and its environment id
from ``<model>.json`` / ``model.json`` when present.

SB3 model files are pickles: load only files you trust.

Episode ``k`` of every policy uses seed ``seed + k`` (the environment's reset draw), so the
policies face exactly the same initial spins and targets. Metrics per policy:
``success_rate`` (``info["success"]`` at the episode's last step), ``mean_final_angular_speed``
[rad/s], ``mean_fuel`` [N s], ``mean_return``, ``mean_time_to_success`` [s] (first step with
``success``, over the episodes that got there).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import rigid_env  # noqa: F401  (registers the ids)

from .controllers import CONTROLLERS

Policy = Callable[[np.ndarray], np.ndarray]


class EvaluationError(ValueError):
    """A user mistake (missing model, model for another env, ...); one line."""


def rollout(
    env_id: str, policy: Policy, episodes: int, seed: int, env_kwargs: dict[str, Any] | None = None
) -> dict[str, Any]:
    """Run ``episodes`` episodes at once in the native vector env and summarise them."""
    env = gym.make_vec(
        env_id, num_envs=episodes, vectorization_mode="vector_entry_point", **(env_kwargs or {})
    )
    dt = env.unwrapped.task.dt if hasattr(env.unwrapped, "task") else env.task.dt
    obs, info = env.reset(seed=seed)
    n = episodes
    returns = np.zeros(n)
    done = np.zeros(n, dtype=bool)
    final_speed = np.zeros(n)
    fuel = np.zeros(n)
    success = np.zeros(n, dtype=bool)
    first_success = np.full(n, np.nan)
    numerical = np.zeros(n, dtype=bool)
    step = 0
    while not done.all():
        action = policy(obs)
        obs, reward, terminated, truncated, info = env.step(action)
        step += 1
        live = ~done
        returns[live] += reward[live]
        hit = live & info["success"] & np.isnan(first_success)
        first_success[hit] = step * dt
        ended = live & (terminated | truncated)
        final_speed[ended] = info["angular_speed"][ended]
        fuel[ended] = info["fuel"][ended]
        success[ended] = info["success"][ended]
        numerical[ended] = info["numerical_error"][ended]
        done |= ended
    env.close()
    reached = ~np.isnan(first_success)
    return {
        "episodes": n,
        "success_rate": float(success.mean()),
        "mean_final_angular_speed": float(final_speed.mean()),
        "mean_fuel": float(fuel.mean()),
        "mean_return": float(returns.mean()),
        "mean_time_to_success": float(first_success[reached].mean()) if reached.any() else None,
        "numerical_errors": int(numerical.sum()),
    }


def _sidecar(model_path: Path, suffix: str) -> Path | None:
    """``<stem><suffix>`` beside the model, else the run folder's ``model.json`` /
    ``vecnormalize.pkl`` (as agents.train writes them)."""
    stem = model_path.with_suffix("")
    fallback = "model.json" if suffix == ".json" else suffix.lstrip("_")
    for cand in (Path(f"{stem}{suffix}"), model_path.parent / fallback):
        if cand.exists():
            return cand
    return None


def load_policy(model_path: Path, env_id: str) -> Policy:
    """A deterministic policy function from an SB3 zip (+ VecNormalize statistics)."""
    if not model_path.exists():
        raise EvaluationError(
            f"{model_path}: model file not found; train one with "
            "`python -m agents.train` or use agents/pretrained/*.zip"
        )
    meta_path = _sidecar(model_path, ".json")
    algo = None
    if meta_path is not None:
        meta = json.loads(meta_path.read_text())
        if meta.get("env_id") not in (None, env_id):
            raise EvaluationError(
                f"{model_path}: trained on {meta['env_id']}, not {env_id}; "
                f"pass --env {meta['env_id']}"
            )
        algo = meta.get("algo")
    from stable_baselines3 import PPO, SAC, TD3

    classes = {"ppo": PPO, "sac": SAC, "td3": TD3}
    order = [classes[algo]] if algo in classes else list(classes.values())
    model = None
    for cls in order:
        try:
            model = cls.load(str(model_path), device="cpu")
            break
        except Exception:
            continue
    if model is None:
        raise EvaluationError(f"{model_path}: not a loadable SB3 PPO/SAC/TD3 model file")
    probe = gym.make(env_id)
    if (
        model.observation_space.shape != probe.observation_space.shape
        or model.action_space.shape != probe.action_space.shape
    ):
        raise EvaluationError(
            f"{model_path}: observation/action shapes {model.observation_space.shape}"
            f"/{model.action_space.shape} do not match {env_id}'s "
            f"{probe.observation_space.shape}/{probe.action_space.shape}; "
            "pass the --env it was trained on"
        )
    probe.close()
    norm = None
    norm_path = _sidecar(model_path, "_vecnormalize.pkl")
    if norm_path is not None:
        import pickle

        with open(norm_path, "rb") as fh:
            norm = pickle.load(fh)  # trusted: written by agents.train

    def policy(obs: np.ndarray) -> np.ndarray:
        if norm is not None and norm.norm_obs:
            obs = np.clip(
                (obs - norm.obs_rms.mean) / np.sqrt(norm.obs_rms.var + norm.epsilon),
                -norm.clip_obs,
                norm.clip_obs,
            ).astype(np.float32)
        action, _ = model.predict(obs, deterministic=True)
        return action

    return policy


def evaluate(
    model: Path | None,
    env_id: str,
    episodes: int,
    seed: int,
    only: list[str] | None = None,
    env_kwargs: dict[str, Any] | None = None,
) -> dict[str, dict[str, Any]]:
    """Metrics per policy name (``model`` plus the controllers)."""
    names = only or (["model"] if model is not None else []) + list(CONTROLLERS)
    results: dict[str, dict[str, Any]] = {}
    probe = gym.make_vec(
        env_id, num_envs=episodes, vectorization_mode="vector_entry_point", **(env_kwargs or {})
    )
    for name in names:
        if name == "model":
            if model is None:
                continue
            policy = load_policy(model, env_id)
        elif name in CONTROLLERS:
            policy = CONTROLLERS[name](probe)
        else:
            raise EvaluationError(
                f"--only: unknown policy {name!r}; use model, {', '.join(CONTROLLERS)}"
            )
        results[name] = rollout(env_id, policy, episodes, seed, env_kwargs)
    probe.close()
    return results


def markdown_table(results: dict[str, dict[str, Any]]) -> str:
    """Results as a Markdown table."""
    lines = [
        "| policy | success rate | final |w| [rad/s] | fuel [N s] | return | time to success [s] |",
        "|---|---|---|---|---|---|",
    ]
    for name, r in results.items():
        t = "-" if r["mean_time_to_success"] is None else f"{r['mean_time_to_success']:.2f}"
        lines.append(
            f"| {name} | {r['success_rate']:.2f} | {r['mean_final_angular_speed']:.4f} | "
            f"{r['mean_fuel']:.3f} | {r['mean_return']:.2f} | {t} |"
        )
    return "\n".join(lines)


def record_video(model: Path | None, env_id: str, seed: int, path: Path) -> None:
    """One episode of the model (or the PD controller without a model) as a GIF or MP4."""
    env = gym.make(env_id, render_mode="rgb_array")
    policy = load_policy(model, env_id) if model is not None else CONTROLLERS["pd"](env)
    obs, _ = env.reset(seed=seed)
    frames = [env.render()]
    done = False
    while not done:
        obs, _, terminated, truncated, _ = env.step(policy(obs[None])[0])
        frames.append(env.render())
        done = terminated or truncated
    env.close()
    path.parent.mkdir(parents=True, exist_ok=True)
    fps = env.metadata.get("render_fps", 20)
    if path.suffix.lower() == ".gif":
        from PIL import Image

        images = [Image.fromarray(f) for f in frames]
        images[0].save(
            path, save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0
        )
    else:
        from gymnasium.utils.save_video import save_video

        save_video(frames, str(path.parent), fps=fps, name_prefix=path.stem)


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    parser = argparse.ArgumentParser(
        prog="python -m agents.evaluate", description="Evaluate a policy beside analytic baselines."
    )
    parser.add_argument("model", help="SB3 model .zip, or 'none' for the controllers only")
    parser.add_argument("--env", required=True, help="environment id, e.g. RigidEnv/Detumble-v0")
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--seed", type=int, default=12345, help="episode k uses seed + k")
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument("--video", type=Path, help="record one episode (.gif or .mp4)")
    parser.add_argument("--only", help="comma-separated subset of: model,pd,zero,random")
    args = parser.parse_args(argv)
    model = None if args.model.lower() == "none" else Path(args.model)
    try:
        if args.env not in gym.registry:
            raise EvaluationError(f"--env: unknown id {args.env!r}")
        if args.episodes < 1:
            raise EvaluationError("--episodes: must be >= 1")
        only = args.only.split(",") if args.only else None
        results = evaluate(model, args.env, args.episodes, args.seed, only)
        if args.video is not None:
            record_video(model, args.env, args.seed, args.video)
    except EvaluationError as exc:
        print(f"agents.evaluate: error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(results if len(results) > 1 else next(iter(results.values())), indent=2))
    else:
        print(markdown_table(results))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
