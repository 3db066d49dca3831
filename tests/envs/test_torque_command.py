"""The cross-product law of BdotDetumble's torque command, compiled: the numbers of its NumPy form
as first published (norm, divide, cross, matmul, scale) where the coils lie along the body axes
(the shipped scenes: the shipped policy and the seeded rollouts of BdotDetumble-v1 and v2 depend
on them), and one order of operations for any number of envs, so that env ``i`` of a vector env
gets the commands it gets alone whatever its coils (tests/envs/test_tilted_hardware.py)."""

from __future__ import annotations

import numpy as np

from rigid_env.envs.bdot_detumble import torque_dipoles


def published(action, field, to_commands, unit, product=np.matmul):
    """The published NumPy form, its dipole-to-command product given."""
    size = np.linalg.norm(field, axis=1, keepdims=True)
    across = np.divide(field, size, out=np.zeros_like(field), where=size > 0.0)
    commands = product(np.cross(across, action) * unit, to_commands)
    return commands / np.maximum(1.0, np.abs(commands).max(axis=1, keepdims=True))


def row_by_row(dipoles, to_commands):
    """``dipoles @ to_commands`` as NumPy's matmul of one row sums it: ``(m_x M[0, k] +
    m_y M[1, k]) + m_z M[2, k]``, each product rounded (no fused multiply-add)."""
    m = dipoles
    return (m[:, 0:1] * to_commands[0] + m[:, 1:2] * to_commands[1]) + m[:, 2:3] * to_commands[2]


def draws(rng, n, dtype=np.float64):
    action = rng.uniform(-1.0, 1.0, (n, 3)).astype(dtype)
    field = rng.normal(size=(n, 3)) * 10.0 ** rng.uniform(-6.0, -3.0)
    field[rng.random(n) < 0.2] = 0.0  # a zero field asks for no dipole
    return action, field


def test_any_coils_give_the_published_form_in_one_order_of_operations_bit_for_bit():
    rng = np.random.default_rng(3)
    for t in range(2000):
        n = int(rng.integers(1, 9))
        action, field = draws(rng, n, np.float32 if t % 2 else np.float64)
        to_commands = rng.normal(size=(3, 3)) * rng.uniform(0.1, 20.0)  # limits reached too
        got = torque_dipoles(action, field, to_commands, 0.2)
        want = published(action, field, to_commands, 0.2, row_by_row)
        assert np.array_equal(got, want), t


def test_coils_along_the_body_axes_give_numpys_matmul_bit_for_bit_for_any_number_of_envs():
    """The shipped scenes' coils: each command is one product plus exact zeros, so NumPy's
    matmul (BLAS's fused multiply-adds for many rows) rounds it as the compiled sum does: the
    published numbers, for a single env and a vector env alike."""
    rng = np.random.default_rng(5)
    for t in range(400):
        n = int(rng.choice([1, 2, 3, 8, 64, 257]))
        action, field = draws(rng, n, np.float32 if t % 2 else np.float64)
        to_commands = np.diag(1.0 / rng.uniform(0.05, 0.5, 3))
        got = torque_dipoles(action, field, to_commands, 0.2)
        assert np.array_equal(got, published(action, field, to_commands, 0.2)), t


def test_the_observations_float32_columns_give_the_numbers_of_their_float64_values():
    """As the task calls it: the field read in place from the observation's float32 columns (a
    strided view) and the commands written into the task's own array give, bit for bit, the
    published form of the same numbers converted to float64 (a float32 read in float32
    arithmetic would not)."""
    rng = np.random.default_rng(4)
    for t in range(500):
        n = int(rng.integers(1, 9))
        obs = rng.normal(size=(n, 9)).astype(np.float32)  # the field in columns 4..6
        field = obs[:, 4:7]
        action = rng.uniform(-1.0, 1.0, (n, 3))
        to_commands = rng.normal(size=(3, 3)) * rng.uniform(0.1, 20.0)
        commands = np.empty((n, 3))
        got = torque_dipoles(action, field, to_commands, 0.2, commands)
        assert got is commands
        want = published(action, field.astype(np.float64), to_commands, 0.2, row_by_row)
        assert np.array_equal(got, want), t
