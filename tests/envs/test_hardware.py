"""The tasks' thruster hardware (rigid_env.envs.hardware): presets, fault draws and their effect
on a command, misalignment tilts."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from rigid_env.core.actuators.thrusters import REALISTIC_LAG
from rigid_env.envs.hardware import (
    FAULT_ROW,
    NO_FAULT,
    Fault,
    ThrusterFaults,
    apply_faults,
    cross,
    draw_fault,
    misaligned,
    misaligned_many,
    with_preset,
)
from rigid_env.resources import scene_path
from rigid_env.scene import load_scene


def test_realistic_preset_sets_every_thruster_and_ideal_keeps_the_scene() -> None:
    scene = load_scene(scene_path("detumble"))
    assert with_preset(scene, "ideal") is scene
    real = with_preset(scene, "realistic")
    for t in real.actuators.thrusters:
        assert (t.mode, t.lag, t.noise) == ("on_off", REALISTIC_LAG, 0.05)
        assert 0.0 < t.min_impulse <= t.max_force * real.dt
    with pytest.raises(ValueError, match=r"thrusters: unknown preset 'real'; choose one of"):
        with_preset(scene, "real")


def test_fault_draws_are_seeded_and_each_kind_acts_on_the_command() -> None:
    faults = ThrusterFaults(probability=1.0, within_steps=10)
    a = [draw_fault(np.random.default_rng(s), faults, 6) for s in range(50)]
    b = [draw_fault(np.random.default_rng(s), faults, 6) for s in range(50)]
    assert a == b
    assert {f.kind for f in a if f is not None} == {"stuck_off", "stuck_on", "degraded"}
    assert all(f is not None and 0 <= f.thruster < 6 and 0 <= f.step < 10 for f in a)
    assert draw_fault(np.random.default_rng(0), ThrusterFaults(probability=0.0), 6) is None
    u = np.full(3, 0.5)
    for fault, expected in (
        (Fault(1, 2, "stuck_off", 0.0), 0.0),
        (Fault(1, 2, "stuck_on", -0.7), -0.7),
        (Fault(1, 2, "degraded", 0.4), 0.2),
    ):
        before = u.copy()
        fault.apply(before, 1)  # not yet
        np.testing.assert_array_equal(before, u)
        after = u.copy()
        fault.apply(after, 2)
        np.testing.assert_array_equal(after, [0.5, expected, 0.5])


def test_faults_of_a_batch_act_on_their_own_envs_from_their_own_steps() -> None:
    """apply_faults over envs at different steps: each env's command as its Fault alone makes it
    (acting from its step on), an env without a fault untouched."""
    faults = [
        Fault(0, 3, "stuck_off", 0.0),
        Fault(2, 1, "stuck_on", 0.9),
        Fault(1, 5, "degraded", 0.25),
        None,
        Fault(2, 0, "degraded", 0.5),
    ]
    rows = np.array([NO_FAULT if f is None else f.row for f in faults], dtype=FAULT_ROW)
    steps = np.array([3, 0, 7, 9, 4])
    u = np.linspace(-0.9, 0.8, 15).reshape(5, 3)
    got = u.copy()
    apply_faults(got, steps, rows)
    expected = u.copy()
    expected[0, 0] = 0.0  # from step 3 on
    # env 1: its fault starts at step 1, not yet at step 0
    expected[2, 1] = 0.25 * u[2, 1]
    expected[4, 2] = 0.5 * u[4, 2]
    np.testing.assert_array_equal(got, expected)


def test_cross_is_numpys_cross_bit_for_bit() -> None:
    """The same products and differences in the same order as np.cross: equal, not close."""
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(50, 3)), rng.normal(size=(50, 3)) * 1e3
    np.testing.assert_array_equal(cross(a, b), np.cross(a, b))
    np.testing.assert_array_equal(cross(a[0], b[1]), np.cross(a[0], b[1]))


@pytest.mark.parametrize(
    ("data", "field"),
    [({"probability": 1.5}, "probability"), ({"kinds": ["melted"]}, "kinds")],
)
def test_bad_fault_settings_name_the_field(data: dict, field: str) -> None:
    with pytest.raises(ValidationError, match=field):
        ThrusterFaults(**data)


def test_misalignment_tilts_each_direction_within_the_bound() -> None:
    """Unit directions stay unit, tilted by at most the bound, and by a spread of angles."""
    d = np.eye(3)[[0, 1, 2, 0]]
    tilted = misaligned(d, np.random.default_rng(0), 5.0)
    np.testing.assert_allclose(np.linalg.norm(tilted, axis=1), 1.0, rtol=1e-15)
    angles = np.degrees(np.arccos(np.clip(np.sum(d * tilted, axis=1), -1, 1)))
    assert np.all(angles <= 5.0 + 1e-9) and np.ptp(angles) > 0.0
    np.testing.assert_array_equal(tilted, misaligned(d, np.random.default_rng(0), 5.0))


def test_misaligning_many_envs_at_once_is_misaligning_each_alone() -> None:
    """misaligned_many of K envs: row k is misaligned() of env k's generator alone, bit for bit
    (directions along and off the x axis: both normals' branches), and each generator is left
    where that call leaves it."""
    directions = np.array([[1.0, 0.0, 0.0], [0.0, 0.6, 0.8], [0.95, 0.3122498999199199, 0.0]])
    mine = [np.random.default_rng(40 + k) for k in range(9)]
    ref = [np.random.default_rng(40 + k) for k in range(9)]
    together = misaligned_many(directions, mine, 3.0)
    for k, rng in enumerate(ref):
        np.testing.assert_array_equal(together[k], misaligned(directions, rng, 3.0))
    assert [g.random() for g in mine] == [g.random() for g in ref]
