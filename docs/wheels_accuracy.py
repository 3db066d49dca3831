"""What accuracy costs with reaction wheels: each integrator that steps wheels, at several
steps, on a tumbling 3U body with four wheels in a pyramid, driven and with viscous friction
(the scene of tests/core/test_wheels.py), over 20 s.

    .venv/bin/python docs/wheels_accuracy.py

Error: the largest difference of (q, w, wheel momenta / their scale) from rk4 at a step 64
times smaller; cost: body-steps per second of 1024 such bodies in one world, every method
measured in the same run, best of 5. Writes docs/results/wheels/accuracy.md.
"""

import time
from pathlib import Path

import numpy as np

from rigid_env.core.effects import ReactionWheels
from rigid_env.core.state import BodyModel
from rigid_env.core.wheels import WHEEL_STEPS
from rigid_env.core.world import World

ROOT = Path(__file__).resolve().parents[1]
T, BODIES = 20.0, 1024
STEPS = (0.2, 0.1, 0.05, 0.025)
PYRAMID = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [-1.0, 0.0, 1.0], [0.0, -1.0, 1.0]])
WHEELS = ReactionWheels(PYRAMID, inertia=2e-5, max_torque=1e-3, max_speed=1e4, viscous=2e-6)
COMMAND = np.array([0.4, -0.7, 0.2, 0.9])
MODEL = BodyModel(np.array([2.0]), np.array([[0.02, 0.03, 0.045]]))


def world(method: str, h: float, n: int = 1) -> World:
    w = World(MODEL, [WHEELS], method, dt=h, n=n)
    w.state.w[:] = [0.3, -0.5, 0.4]
    w.set_wheel_speed([40.0, -25.0, 10.0, 60.0])
    return w


def final(method: str, h: float) -> np.ndarray:
    w = world(method, h)
    for _ in range(round(T / h)):
        w.step(COMMAND)
    scale = WHEELS.inertia[0] * 60.0  # the wheels' momentum at their start speeds' size
    return np.concatenate([w.state.q[0], w.state.w[0], w.wheel_momentum[0] / scale])


def rate(method: str, h: float) -> float:
    """Body-steps per second of BODIES bodies, best of 5 blocks of 20 steps."""
    w = world(method, h, BODIES)
    w.step(COMMAND)
    best = np.inf
    for _ in range(5):
        start = time.perf_counter()
        for _ in range(20):
            w.step(COMMAND)
        best = min(best, time.perf_counter() - start)
    return 20 * BODIES / best


def main() -> None:
    reference = final("rk4", STEPS[-1] / 64)
    lines = [
        "| integrator | "
        + " | ".join(f"error at h = {h:g} s" for h in STEPS)
        + " | body-steps/s (1024 bodies) |",
        "|---|" + "---|" * (len(STEPS) + 1),
    ]
    for method in WHEEL_STEPS:
        errors = [np.abs(final(method, h) - reference).max() for h in STEPS]
        lines.append(
            f"| `{method}` | " + " | ".join(f"{e:.1e}" for e in errors)
            + f" | {rate(method, STEPS[1]) / 1e6:.2f} M |"
        )  # fmt: skip
    out = ROOT / "docs" / "results" / "wheels"
    out.mkdir(parents=True, exist_ok=True)
    (out / "accuracy.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
