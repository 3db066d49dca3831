"""The error-controlled integrator on the hard cases: it takes as many substeps as the spin
needs, so it stays accurate where fixed steps blow up, and a spin beyond any sensible substep
count is a clear error at once, never a hang. (The generic cases of this suite, finite or a
clear error, thin bodies and scale invariance, run it as every registered integrator.)"""

from __future__ import annotations

import numpy as np
import pytest

from rigid_env.bench import stability_cases as st
from rigid_env.core import SubstepLimitError, Tolerances

TOLERANCE_FACTOR = 20.0
"""Error at most 20 x rtol relative to the largest rate (the issue's bound): the controller
keeps each substep's estimated local error within rtol |w| (its 5th-order estimate, above the
error of the 8th-order solution it accepts), and on these orbits about the major axis, or
through a few flips, the flow does not amplify errors by more than a small factor."""


@pytest.mark.parametrize("rtol", [1.0e-8, 1.0e-10])
def test_fast_spin_stays_accurate_by_substeps(rtol: float) -> None:
    """200 rad/s about the major axis of (1, 2, 3) at dt = 0.01 s (h |w| = 2 rad a step, where
    explicit Euler, leapfrog and midpoint blow up): over 1 s the body rates stay within 20 rtol
    of the exact solution, the body taking several substeps per step."""
    inertia, w0 = st.HARD_BODIES["fast_spin"]
    world = st.torque_free_world(
        inertia, w0, "dop853", st.HARD_DT, tolerances=Tolerances(rtol, rtol)
    )
    substeps = 0
    for _ in range(100):
        world.step()
        substeps += int(world.substeps_taken[0])
    exact = st.exact_body_rates(inertia, w0, [1.0])[0]
    error = np.max(np.abs(world.state.w[0] - exact)) / np.max(np.abs(exact))
    assert error <= TOLERANCE_FACTOR * rtol, (error, substeps)
    assert substeps > 2 * 100  # h |w| = 2 rad is more than one substep can take to 1e-8


def test_dzhanibekov_flips_at_a_coarse_step() -> None:
    """The intermediate-axis flips over 30 s at dt = 0.05 s (fixed-step rk4 needs dt = 1e-3 for
    the case): the same three flips as the exact solution, the last within 1e-6 relative (the
    default rtol 1e-10, a flip's timing amplified by the separatrix's ~1e3)."""
    result = st.dzhanibekov("dop853", 30.0, 0.05)
    assert result.flips == result.exact_flips == 3
    assert result.last_flip_rel_error <= 1.0e-6


def test_extreme_spin_is_a_clear_error_at_once() -> None:
    """1e6 rad/s at dt = 0.01 s (1e4 rad a step) would need far more substeps than the default
    limit of 1000: SubstepLimitError names the body and the fixes after at most the limit's
    work (1000 substeps of one body), the state left as it was."""
    world = st.torque_free_world((1.0, 2.0, 3.0), (0.5, 0.5, 1.0e6), "dop853", st.HARD_DT)
    before = world.columns.copy()
    with pytest.raises(SubstepLimitError, match="body 0 needed more than max_substeps = 1000"):
        world.step()
    assert np.array_equal(world.columns, before)
