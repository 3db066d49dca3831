"""WheelPointing: the pointing error and the wheels' speeds against time for the PD with
desaturation and a PPO policy on the same held-out episodes, and each one's success, time to
success, final error and the coils' dipole-time.

    .venv/bin/python docs/wheel_figure.py [MODEL.zip]

MODEL: a PPO policy trained on RigidEnv/WheelPointing-v0 (default: the shipped one, if any).
Writes docs/figures/wheel_pointing.png and docs/results/wheels/wheels.txt (100 episodes seeded
from 12345 on, as the baselines' held-out ones).
"""

import sys
from pathlib import Path

import gymnasium as gym
import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from rigid_env.agents.evaluate import load_policy
from rigid_env.agents.wheel_pd import WheelPDController

import rigid_env.envs  # noqa: F401  (registers the ids)
from rigid_env.core.rotation import quat_angle_between

ENV_ID = "RigidEnv/WheelPointing-v0"
ROOT = Path(__file__).resolve().parents[1]
EPISODES, SEED, STEPS = 100, 12345, 120


def run(policy, n: int) -> dict[str, np.ndarray]:
    """Each env's episode: the pointing error [deg] and the wheels' speeds [rpm] per step, its
    success at the end, the first step of success and the coils' fuel [A m^2 s]."""
    env = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point")
    task = env.unwrapped.task
    if policy is None:
        policy = WheelPDController(env)
    obs, _ = env.reset(seed=SEED)

    def error() -> np.ndarray:
        q, target = task.world.state.q, task.target[:, :4]
        return np.degrees([quat_angle_between(q[i], target[i]) for i in range(n)])

    angle = np.empty((STEPS + 1, n))
    speeds = np.empty((STEPS + 1, n, 3))
    angle[0], speeds[0] = error(), task.world.wheel_speed * 60.0 / (2.0 * np.pi)
    first = np.full(n, np.nan)
    for t in range(STEPS):  # (the vector env resets on the step after an episode's last)
        obs, _, _, _, info = env.step(np.clip(policy(obs), -1.0, 1.0))
        angle[t + 1], speeds[t + 1] = error(), task.world.wheel_speed * 60.0 / (2 * np.pi)
        hit = info["success"] & np.isnan(first)
        first[hit] = t + 1
    return {"angle": angle, "speeds": speeds, "success": info["success"], "first": first,
            "fuel": info["fuel"]}  # fmt: skip


def main() -> None:
    default = ROOT / "agents" / "pretrained" / "ppo_wheel_pointing.zip"
    model = Path(sys.argv[1]) if len(sys.argv) > 1 else default
    runs = {"PD": run(None, EPISODES)}
    if model.exists():
        runs["PPO"] = run(load_policy(model, ENV_ID), EPISODES)
    lines = [
        "policy  success  median time to success [s]  median final error [deg]  mean fuel [A m^2 s]"
    ]
    for name, r in runs.items():
        lines.append(
            f"{name:7s} {r['success'].mean():7.2f}  {np.nanmedian(r['first']):26.0f}  "
            f"{np.median(r['angle'][-1]):24.3f}  {r['fuel'].mean():19.1f}"
        )
    out = ROOT / "docs" / "results" / "wheels"
    out.mkdir(parents=True, exist_ok=True)
    (out / "wheels.txt").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    t = np.arange(STEPS + 1)
    for (name, r), color in zip(runs.items(), ("tab:blue", "tab:orange"), strict=False):
        for k in range(3):
            axes[0].semilogy(t, np.maximum(r["angle"][:, k], 1e-3), color=color, lw=0.8,
                             label=name if k == 0 else None)  # fmt: skip
            axes[1].plot(t, r["speeds"][:, k, :], color=color, lw=0.6)
    axes[0].axhline(1.0, color="grey", ls="--", lw=0.8)
    axes[0].set_ylabel("pointing error [deg]")
    axes[0].legend()
    axes[1].set_ylabel("wheel speeds [rpm]")
    axes[1].set_xlabel("time [s]")
    axes[0].set_title("WheelPointing-v0: three held-out episodes")
    fig.tight_layout()
    fig.savefig(ROOT / "docs" / "figures" / "wheel_pointing.png", dpi=110)


if __name__ == "__main__":
    main()
