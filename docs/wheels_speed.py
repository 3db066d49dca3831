"""Issue 42's two ratios, measured interleaved in one process (one thread: run it pinned).

    NUMBA_NUM_THREADS=1 taskset -c 1 .venv/bin/python docs/wheels_speed.py 4096 7
    NUMBA_NUM_THREADS=1 taskset -c 1 .venv/bin/python docs/wheels_speed.py 4096 7 --envs

1. core: body-steps/s of ``rigid-env bench speed``'s wheel world (its ``rk4 + 3 reaction
   wheels`` row: the benchmark body carrying :func:`rigid_env.bench.speed.bench_wheels`, driven
   at random levels) over ``rk4`` without wheels, at N bodies; must hold: >= 0.5x at N = 4096.
2. ``--envs``: integrator steps/s of WheelPointing-v1's vector env over BdotDetumble-v2's
   (each env-steps/s times the integrator steps of one env step), N envs each, random actions;
   must hold: >= 1x at N = 4096.

Peers are timed in turn, round by round (:func:`rigid_env.bench.timing.measure`); each round
gives one ratio, and the median and range of the REPEATS rounds' ratios are printed. On a shared
machine only ratios mean anything; say the load (``uptime``) beside them.
"""

import argparse
import os
import warnings

import gymnasium as gym
import numpy as np

import rigid_env.envs  # noqa: F401  (registers the ids)
from rigid_env.bench.speed import DT, INERTIA, WHEELS_CASE, bench_wheels, spinning_state
from rigid_env.bench.timing import Case, measure
from rigid_env.core.state import BodyModel
from rigid_env.core.world import World

MIN_TIME = 0.2
"""Seconds per timed repeat of each case."""


def _ratios(timings: dict, case: str, peer: str) -> tuple[float, float, float]:
    """Median, least and greatest of the per-round ratios of ``case``'s rate to ``peer``'s."""
    t, u = timings[case], timings[peer]
    r = np.array([(t.work / a) / (u.work / b) for a, b in zip(t.seconds, u.seconds, strict=True)])
    return float(np.median(r)), float(r.min()), float(r.max())


def core(n: int, repeats: int) -> None:
    """Ratio 1: the bench's wheel world over rk4 without wheels."""
    s0 = spinning_state(n)
    model = BodyModel.single(1.0, INERTIA)
    plain = World(model, integrator="rk4", dt=DT, state=s0)
    wheeled = World(model, [bench_wheels()], integrator="rk4", dt=DT, state=s0)
    u = np.random.default_rng(5).uniform(-1.0, 1.0, (n, 3))
    cases = [
        Case("rk4", plain.step, n, reset=lambda: plain.reset(s0)),
        Case(WHEELS_CASE, lambda: wheeled.step(u), n, reset=lambda: wheeled.reset(s0)),
    ]
    timings = measure(cases, min_time=MIN_TIME, repeats=repeats)
    med, lo, hi = _ratios(timings, WHEELS_CASE, "rk4")
    for name, t in timings.items():
        print(f"  {name:28s} {t.rate / 1e6:8.3f} M body-steps/s")
    print(f"core N={n}: wheels / rk4 = {med:.3f}x (rounds {lo:.3f}-{hi:.3f}, {repeats} rounds)")


def envs(n: int, repeats: int) -> None:
    """Ratio 2: WheelPointing-v1's integrator steps/s over BdotDetumble-v2's."""
    warnings.simplefilter("ignore")
    cases, steps = [], {}
    for env_id in ("RigidEnv/WheelPointing-v1", "RigidEnv/BdotDetumble-v2"):
        env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
        env.reset(seed=0)
        task = env.unwrapped.task
        steps[env_id] = int(task.world.substeps * task.repeats.max())
        rng = np.random.default_rng(0)
        pool = rng.uniform(-1.0, 1.0, (8, *env.action_space.shape)).astype(np.float32)
        it = iter(range(1 << 62))

        def step(env=env, pool=pool, it=it) -> None:
            env.step(pool[next(it) % len(pool)])

        cases.append(Case(env_id, step, n * steps[env_id], close=env.close))
    timings = measure(cases, min_time=MIN_TIME, repeats=repeats)
    wp, bd = (c.name for c in cases)
    med, lo, hi = _ratios(timings, wp, bd)
    for name, t in timings.items():
        print(
            f"  {name:28s} {t.rate / steps[name] / 1e3:8.1f} k env-steps/s x {steps[name]:2d} "
            f"= {t.rate / 1e6:6.3f} M integrator steps/s"
        )
    print(f"envs N={n}: WheelPointing-v1 / BdotDetumble-v2 = {med:.3f}x (rounds {lo:.3f}-{hi:.3f})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("n", type=int, help="bodies (envs)")
    parser.add_argument("repeats", type=int, help="rounds")
    parser.add_argument("--envs", action="store_true", help="ratio 2 (the envs) instead")
    args = parser.parse_args()
    threads = os.environ.get("NUMBA_NUM_THREADS", "unset")
    print(f"NUMBA_NUM_THREADS={threads}, load average {os.getloadavg()}")
    (envs if args.envs else core)(args.n, args.repeats)


if __name__ == "__main__":
    main()
