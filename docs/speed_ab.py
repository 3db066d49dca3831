"""A/B of the speed numbers between two trees, one process each, alternated (README, Speed).

    git worktree add /tmp/old 7e52ffa^    # the lane tree before the compiled core (or 43abfe9)
    for i in 1 2 3; do
        .venv/bin/python docs/speed_ab.py new
        PYTHONPATH=/tmp/old .venv/bin/python docs/speed_ab.py old
    done

Prints, best of several rounds each: core body-steps/s at N = 4096 (symplectic_euler, rk4,
splitting; torque-free), one body's World.step with rk4 and the Detumble thrusters, a Detumble
env.step, and vector Detumble env-steps/s at N = 4096. With ``--all`` (``docs/speed_ab.py new
--all``) it prints instead every integrator's body-steps/s at N = 1, 256 and 4096 (the README's
table against the lane). On a shared machine only the same round's pairs compare.
"""

import sys
import time
import warnings
from collections.abc import Callable

import gymnasium as gym
import numpy as np

import rigid_env  # noqa: F401  (registers the ids)
from rigid_env.bench.speed import spinning_state
from rigid_env.core.state import BodyModel
from rigid_env.core.world import World
from rigid_env.resources import scene_path as default_scene_path
from rigid_env.scene import load_scene


def detumble_thrusters() -> object:
    """Detumble's six thrusters, read from its scene as every tree since the lanes can."""
    effects = load_scene(default_scene_path("detumble")).effects()
    return next(e for e in effects if type(e).__name__ == "Thrusters")


def best_rate(call: Callable[[], object], work: float, calls: int, rounds: int = 9) -> float:
    """Work per second of the fastest of ``rounds`` blocks of ``calls`` calls."""
    call()
    best = np.inf
    for _ in range(rounds):
        t = time.perf_counter()
        for _ in range(calls):
            call()
        best = min(best, (time.perf_counter() - t) / calls)
    return work / best


def all_integrators(label: str) -> None:
    """Every integrator's M body-steps/s at N = 1 / 256 / 4096, torque-free."""
    from rigid_env.core.integrators import INTEGRATORS

    warnings.simplefilter("ignore")
    model = BodyModel.single(1.0, (1.0, 2.0, 3.0))
    rows = []
    for name in INTEGRATORS:
        rates = []
        for n in (1, 256, 4096):
            world = World(model, integrator=name, dt=0.01, state=spinning_state(n))
            world.step()  # compiled or loaded here; then one timed call sets a ~20 ms block
            t = time.perf_counter()
            world.step()
            calls = max(2, int(0.02 / (time.perf_counter() - t)))
            rates.append(best_rate(world.step, n, calls, rounds=5) / 1e6)
        rows.append(f"{name}: " + " / ".join(f"{r:.3g}" for r in rates))
    print(label, "M body-steps/s at N = 1 / 256 / 4096 |", " | ".join(rows), flush=True)


def main(label: str) -> None:
    warnings.simplefilter("ignore")
    model = BodyModel.single(1.0, (1.0, 2.0, 3.0))
    out = {}
    for name in ("symplectic_euler", "rk4", "splitting"):
        world = World(model, integrator=name, dt=0.01, state=spinning_state(4096))
        out[f"{name}@4096 [M/s]"] = best_rate(world.step, 4096, 40) / 1e6
    one = World(model, effects=[detumble_thrusters()], integrator="rk4", n=1)
    u = np.random.default_rng(0).uniform(-1, 1, 6)
    out["World.step N=1 rk4+thrusters [us]"] = 1e6 / best_rate(lambda: one.step(u), 1, 20000)
    env = gym.make("RigidEnv/Detumble-v0")
    env.reset(seed=0)
    zero = np.zeros(6, np.float32)

    def env_step() -> None:
        *_, terminated, truncated, _ = env.step(zero)
        if terminated or truncated:
            env.reset()

    out["Detumble env.step [us]"] = 1e6 / best_rate(env_step, 1, 5000)
    venv = gym.make_vec(
        "RigidEnv/Detumble-v0", num_envs=4096, vectorization_mode="vector_entry_point"
    )
    venv.reset(seed=0)
    venv.action_space.seed(0)
    actions = [venv.action_space.sample() for _ in range(8)]
    step = iter(range(10**9))
    rate = best_rate(lambda: venv.step(actions[next(step) % 8]), 4096, 30, rounds=7)
    out["vec Detumble 4096 [M env-steps/s]"] = rate / 1e6
    print(label, " ".join(f"{k}={v:.3g}" for k, v in out.items()), flush=True)


if __name__ == "__main__":
    run = all_integrators if "--all" in sys.argv[2:] else main
    run(sys.argv[1] if len(sys.argv) > 1 else "this tree")
