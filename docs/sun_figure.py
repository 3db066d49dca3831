"""SunAcquisition: the analytic sun-safe baseline over one orbit of three held-out episodes: the
panel's angle to the Sun (sunlit steps), the body's rate and the wheels' stored momentum, with
each episode's eclipse shaded.

    .venv/bin/python docs/sun_figure.py

Writes docs/figures/sun_acquisition.png (three episodes seeded from 12345 on, as the baselines'
held-out ones).
"""

from pathlib import Path

import gymnasium as gym
import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from rigid_env.agents.sun_safe import SunSafeController

import rigid_env.envs  # noqa: F401  (registers the ids)

ENV_ID = "RigidEnv/SunAcquisition-v0"
ROOT = Path(__file__).resolve().parents[1]
EPISODES, SEED, STEPS = 3, 12345, 2839


def run() -> dict[str, np.ndarray]:
    """Per step and env: the panel's angle to the Sun [deg] (NaN in the umbra), |w| [deg/s],
    the wheels' momentum |h| [mN m s] and whether the Sun is seen; each env's success."""
    env = gym.make_vec(ENV_ID, num_envs=EPISODES, vectorization_mode="vector_entry_point")
    task = env.unwrapped.task
    policy = SunSafeController(env)
    obs, _ = env.reset(seed=SEED)
    rows = np.arange(EPISODES)
    out = {k: np.empty((STEPS, EPISODES)) for k in ("angle", "rate", "momentum", "lit")}
    for t in range(STEPS):  # the episode's last step (2840) would autoreset on the next
        obs, _, _, _, info = env.step(policy(obs))
        out["lit"][t] = np.linalg.norm(task.target[:, :3], axis=1) > 0.0
        out["angle"][t] = np.degrees(task.sun_angle(rows))
        out["rate"][t] = np.degrees(np.linalg.norm(task.world.state.w, axis=1))
        out["momentum"][t] = 1e3 * np.linalg.norm(task.world.wheel_momentum, axis=1)
    out["success"] = info["success"]
    return out


def main() -> None:
    r = run()
    minutes = 2.0 * (np.arange(STEPS) + 1) / 60.0
    fig, axes = plt.subplots(3, 1, figsize=(7, 6.5), sharex=True)
    colors = ("tab:blue", "tab:orange", "tab:green")
    for k, color in enumerate(colors):
        dark = r["lit"][:, k] == 0.0
        edges = np.flatnonzero(np.diff(np.r_[0, dark.astype(int), 0]))
        for start, stop in zip(edges[::2], edges[1::2], strict=True):
            axes[0].axvspan(minutes[start], minutes[stop - 1], color=color, alpha=0.08, lw=0)
        angle = np.where(dark, np.nan, np.maximum(r["angle"][:, k], 1e-2))
        label = f"episode {k} (success {bool(r['success'][k])})"
        axes[0].semilogy(minutes, angle, color=color, lw=0.8, label=label)
        axes[1].semilogy(minutes, np.maximum(r["rate"][:, k], 1e-4), color=color, lw=0.8)
        axes[2].plot(minutes, r["momentum"][:, k], color=color, lw=0.8)
    axes[0].axhline(15.0, color="grey", ls="--", lw=0.8)
    axes[1].axhline(0.5, color="grey", ls="--", lw=0.8)
    axes[0].set_ylabel("panel to Sun [deg]")
    axes[0].legend(fontsize=8, loc="upper right")
    axes[1].set_ylabel("|w| [deg/s]")
    axes[2].set_ylabel("wheels' |h| [mN m s]")
    axes[2].set_xlabel("time [min] (shaded: eclipse)")
    axes[0].set_title("SunAcquisition-v0: the sun-safe baseline, three held-out episodes")
    fig.tight_layout()
    fig.savefig(ROOT / "docs" / "figures" / "sun_acquisition.png", dpi=110)


if __name__ == "__main__":
    main()
