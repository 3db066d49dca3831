"""BdotDetumble: |w| and the coils' dipole against time for B-dot and a PPO policy on the same
held-out episodes, and each one's success, time to success and fuel (dipole-time).

    .venv/bin/python docs/bdot_figure.py [MODEL.zip]

MODEL: a PPO policy trained on RigidEnv/BdotDetumble-v0 (default: the shipped one, if any).
Writes docs/figures/bdot_detumble.png and docs/results/bdot/bdot.txt (episodes seeded from
12345 on, as the baselines' held-out ones).
"""

import sys
from pathlib import Path

import gymnasium as gym
import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from rigid_env.agents.controllers import BdotController
from rigid_env.agents.evaluate import load_policy, resolve_env_kwargs

import rigid_env.envs  # noqa: F401  (registers the ids)

ENV_ID = "RigidEnv/BdotDetumble-v1"
ROOT = Path(__file__).resolve().parents[1]
EPISODES, SEED, STEPS = 100, 12345, 480


def run(policy, n: int, kwargs: dict) -> dict[str, np.ndarray]:
    """Each env's first episode on the task made with ``kwargs``: |w| [deg/s] and the coils'
    |m| [A m^2] per step (NaN after its end), success, steps to success and fuel [A m^2 s]."""
    env = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)
    task = env.unwrapped.task
    if policy is None:
        policy = BdotController(env)
    obs, _ = env.reset(seed=SEED)
    speed = np.full((STEPS + 1, n), np.nan)
    dipole = np.full((STEPS, n), np.nan)
    speed[0] = np.degrees(np.linalg.norm(task.world.state.w, axis=1))
    done, success = np.zeros(n, bool), np.zeros(n, bool)
    steps, fuel = np.full(n, np.nan), np.zeros(n)
    for t in range(STEPS):
        obs, _, term, trunc, info = env.step(policy(obs))
        dipole[t, ~done] = 0.2 * np.linalg.norm(task.command, axis=1)[~done]  # as the coils got it
        speed[t + 1, ~done] = np.degrees(info["angular_speed"][~done])
        new = (term | trunc) & ~done
        success[new], fuel[new] = info["success"][new], info["fuel"][new]
        steps[new & info["success"]] = t + 1
        done |= new
        if done.all():
            break
    return {"speed": speed, "dipole": dipole, "success": success, "steps": steps, "fuel": fuel}


def main() -> None:
    default = ROOT / "agents" / "pretrained" / "ppo_bdot_detumble.zip"
    model = Path(sys.argv[1]) if len(sys.argv) > 1 else default
    # Both play the task the policy was trained on (v1: wanted torques; its sidecar's env kwargs).
    kwargs = resolve_env_kwargs(model)
    runs = {"B-dot": run(None, EPISODES, kwargs)}
    if model.exists():
        runs["PPO"] = run(load_policy(model, ENV_ID, kwargs), EPISODES, kwargs)
    dt = 5.0
    lines = ["policy   success  median time to success [s]  mean fuel [A m^2 s]"]
    for name, r in runs.items():
        median = np.nanmedian(r["steps"]) * dt
        lines.append(
            f"{name:8s} {r['success'].mean():7.2f}  {median:26.0f}  {r['fuel'].mean():19.1f}"
        )
    out = ROOT / "docs" / "results" / "bdot"
    out.mkdir(parents=True, exist_ok=True)
    (out / "bdot.txt").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    for (name, r), color in zip(runs.items(), ("tab:blue", "tab:orange"), strict=False):
        t = np.arange(r["speed"].shape[0]) * dt / 60.0
        for k in range(5):
            axes[0].plot(t, r["speed"][:, k], color=color, lw=0.8, label=name if k == 0 else None)
            axes[1].plot(t[1:], r["dipole"][:, k], color=color, lw=0.8)
    axes[0].axhline(1.0, color="grey", ls="--", lw=0.8)
    axes[0].set_ylabel("|w| [deg/s]")
    axes[0].legend()
    axes[1].set_ylabel("|m| [A m^2]")
    axes[1].set_xlabel("time [min]")
    axes[0].set_title("BdotDetumble-v0: five held-out episodes")
    fig.tight_layout()
    fig.savefig(ROOT / "docs" / "figures" / "bdot_detumble.png", dpi=110)


if __name__ == "__main__":
    main()
