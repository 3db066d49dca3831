"""An effect registered from outside (``outside_effect.py``, never seen by the core) works
under every integrator. A file of its own: its fresh process compiles every integrator under a
key of its own (about six CPU-minutes on a cold cache), which the test distribution can then put
beside the generic tests of ``test_effects_generic.py`` rather than after them."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rigid_env.core import INTEGRATORS

OUTSIDE = """
import sys
import numpy as np
from rigid_env.core import INTEGRATORS, BodyModel, State, World
from rigid_env.core.effects import ForceEffect

class Spring(ForceEffect):
    name = "spring"
    def parameters(self):
        return {"spring": 1.0, "spring_k": 4.0, "anchor_x": 1.0, "anchor_y": 2.0, "anchor_z": 3.0}
    def potential_energy(self, model, state):
        return 2.0 * np.sum((state.x - [1.0, 2.0, 3.0]) ** 2, axis=1)

for method in INTEGRATORS:
    x0 = np.array([[1.1, 2.0, 3.0]])
    s = State(x0, np.zeros((1, 3)), np.array([[1.0, 0, 0, 0]]), np.zeros((1, 3)))
    world = World(BodyModel(np.array([1.0]), np.array([[1.0, 2.0, 3.0]])), [Spring()], method,
                  np.pi / 200, state=s)
    for _ in range(100):
        world.step()
    print(method, *world.state.x[0], *world.state.w[0])
"""


@pytest.mark.slow
def test_an_effect_registered_from_outside_works_under_every_integrator(tmp_path: Path) -> None:
    """A linear spring ``F = -k (x - a)`` (``outside_effect.py``), registered through
    ``RIGID_ENV_EFFECTS`` in a fresh process (its cache folder keyed by its source too): a body
    let go 0.1 m from the anchor, ``k / m = 4``, is at the other side, ``x - a = -0.1 m``, after
    half a period ``pi / 2`` s (100 steps of ``pi / 200`` s), no spin. A method of order ``p``
    errs at most about ``omega t (omega h)^p`` of the amplitude there (``omega = 2``, ``omega t
    = pi``, ``omega h = pi / 100``); twice that is the tolerance (forward Euler: 20 %)."""
    env = os.environ | {
        "RIGID_ENV_EFFECTS": "outside_effect",
        "PYTHONPATH": os.pathsep.join([str(Path(__file__).parent), *sys.path]),
    }
    run = subprocess.run([sys.executable, "-c", OUTSIDE], env=env, capture_output=True, text=True,
                         timeout=1800, check=False)  # fmt: skip
    assert run.returncode == 0, run.stderr[-2000:]
    rows = {line.split()[0]: np.array(line.split()[1:], float) for line in run.stdout.splitlines()}
    assert set(rows) == set(INTEGRATORS)
    for method, row in rows.items():
        p = INTEGRATORS[method].order
        tol = 2.0 * np.pi * (np.pi / 100) ** min(p, 8) * 0.1
        np.testing.assert_allclose(
            row[:3], [0.9, 2.0, 3.0], rtol=0, atol=max(tol, 1e-12), err_msg=method
        )
        assert np.all(row[3:] == 0.0)
