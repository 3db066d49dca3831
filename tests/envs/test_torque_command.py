"""The cross-product law of BdotDetumble's torque command, compiled, gives the numbers of its
NumPy form as first published (norm, divide, cross, matmul, scale), bit for bit: the shipped
policy and BdotDetumble-v1's seeded rollouts depend on them."""

from __future__ import annotations

import numpy as np

from rigid_env.envs.bdot_detumble import torque_dipoles


def published(action, field, to_commands, unit):
    size = np.linalg.norm(field, axis=1, keepdims=True)
    across = np.divide(field, size, out=np.zeros_like(field), where=size > 0.0)
    commands = (np.cross(across, action) * unit) @ to_commands
    return commands / np.maximum(1.0, np.abs(commands).max(axis=1, keepdims=True))


def test_torque_dipoles_are_the_published_numpy_form_bit_for_bit():
    rng = np.random.default_rng(3)
    for t in range(2000):
        n = int(rng.integers(1, 9))
        action = rng.uniform(-1.0, 1.0, (n, 3)).astype(np.float32 if t % 2 else np.float64)
        field = rng.normal(size=(n, 3)) * 10.0 ** rng.uniform(-6.0, -3.0)
        field[rng.random(n) < 0.2] = 0.0  # a zero field asks for no dipole
        to_commands = rng.normal(size=(3, 3)) * rng.uniform(0.1, 20.0)  # limits reached too
        got = torque_dipoles(action, field, to_commands, 0.2)
        assert np.array_equal(got, published(action, field, to_commands, 0.2)), t


def test_the_observations_float32_columns_give_the_numbers_of_their_float64_values():
    """As the task calls it: the field read in place from the observation's float32 columns (a
    strided view) and written into the task's own buffers gives, bit for bit, the published
    form of the same numbers converted to float64 (a float32 read in float32 arithmetic would
    not)."""
    rng = np.random.default_rng(4)
    for t in range(500):
        n = int(rng.integers(1, 9))
        obs = rng.normal(size=(n, 9)).astype(np.float32)  # the field in columns 4..6
        field = obs[:, 4:7]
        action = rng.uniform(-1.0, 1.0, (n, 3))
        to_commands = rng.normal(size=(3, 3)) * rng.uniform(0.1, 20.0)
        buffers = (np.empty((n, 3)), np.empty((n, 3)))
        got = torque_dipoles(action, field, to_commands, 0.2, buffers)
        assert got is buffers[1]
        want = published(action, field.astype(np.float64), to_commands, 0.2)
        assert np.array_equal(got, want), t
