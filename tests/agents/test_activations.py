"""NumPy's tanh in the policies' hidden layers while they train (agents.activations): the same
function as ``torch.nn.Tanh`` to float32 rounding, forward and backward, swapped into every slot
of a network, and a saved model that stays SB3's own."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch
from stable_baselines3 import PPO

from agents.activations import Tanh, use_fast_tanh
from agents.config import load_config
from agents.train import _new_model, make_vec_env

ULPS = 4.0
"""NumPy's float32 tanh against the exact value, in units in the last place of the result: its
SIMD kernels are within about 1.5 (1.37 measured on 2M normal draws), glibc's scalar tanhf
within 2; 4 covers every path with margin."""
U32 = 2.0**-24
"""Unit roundoff of float32."""


def _arguments() -> np.ndarray:
    """float32 arguments over tanh's whole range: 0, signed zeros and subnormals, the region
    near 0 where tanh(x) ~ x, the bend, and the saturation near +-9 where it rounds to +-1."""
    rng = np.random.default_rng(5)
    parts = [
        np.array([0.0, -0.0, 1e-45, -1e-45, 1e-38, 1e-20, 1e-8, 0.5, 1.0, 9.0, 9.1, 20.0, 88.0]),
        rng.standard_normal(100_000),
        rng.uniform(-10.0, 10.0, 100_000),
        10.0 ** rng.uniform(-30.0, 1.0, 50_000) * rng.choice([-1.0, 1.0], 50_000),
    ]
    return np.concatenate(parts).astype(np.float32)


def test_forward_is_tanh_to_a_few_float32_ulps_and_keeps_inf_and_nan() -> None:
    x = _arguments()
    exact = np.tanh(x.astype(np.float64))
    ours = Tanh()(torch.from_numpy(x)).numpy().astype(np.float64)
    ulp = np.spacing(np.abs(exact).astype(np.float32)).astype(np.float64)
    assert np.max(np.abs(ours - exact) / ulp) <= ULPS
    assert np.all(np.abs(ours) <= 1.0)
    assert np.all(np.signbit(ours) == np.signbit(x))  # odd, -0.0 included
    special = torch.tensor([np.inf, -np.inf, np.nan], dtype=torch.float32)
    out = Tanh()(special).numpy()
    assert out[0] == 1.0 and out[1] == -1.0 and np.isnan(out[2])


def test_backward_is_g_times_one_minus_y_squared() -> None:
    """The gradient of ``sum(g * tanh(x))`` is ``g (1 - y^2)`` at the forward's own ``y``: three
    float32 roundings (``y^2``, ``1 - .``, ``g .``), each at most ``u |g|`` with ``1 - y^2 <= 1``,
    so within ``3 u |g|`` of that product in float64."""
    rng = np.random.default_rng(6)
    x = torch.from_numpy(_arguments()).requires_grad_(True)
    g = torch.from_numpy(rng.standard_normal(x.shape[0]).astype(np.float32))
    y = Tanh()(x)
    (y * g).sum().backward()
    yd, gd = y.detach().numpy().astype(np.float64), g.numpy().astype(np.float64)
    exact = gd * (1.0 - yd * yd)
    assert np.all(np.abs(x.grad.numpy() - exact) <= 3.0 * U32 * np.abs(gd))


def test_without_gradients_it_gives_the_same_numbers() -> None:
    x = torch.from_numpy(_arguments()).requires_grad_(True)
    with_grad = Tanh()(x).detach()
    with torch.no_grad():
        assert torch.equal(Tanh()(x), with_grad)
    with torch.inference_mode():
        assert torch.equal(Tanh()(x.detach()), with_grad)
    assert torch.equal(Tanh()(x[::2]).detach(), with_grad[::2])  # a strided view


def test_other_dtypes_keep_torchs_tanh() -> None:
    x = torch.linspace(-5.0, 5.0, 1001, dtype=torch.float64)
    assert torch.equal(Tanh()(x), torch.tanh(x))


def test_every_slot_is_swapped_a_shared_instance_too() -> None:
    shared = torch.nn.Tanh()
    net = torch.nn.Sequential(
        torch.nn.Linear(3, 4), shared, torch.nn.Linear(4, 4), shared,
        torch.nn.Sequential(torch.nn.Linear(4, 2), torch.nn.Tanh()), torch.nn.ReLU(),
    )  # fmt: skip
    assert use_fast_tanh(net) == 3
    assert [type(m) for m in net.modules()].count(torch.nn.Tanh) == 0
    assert type(net[5]) is torch.nn.ReLU
    assert use_fast_tanh(net) == 0  # done once


def test_a_training_model_uses_it_and_saves_sb3s_own_tanh(tmp_path: Path) -> None:
    """A model from the training path runs NumPy's tanh in all four hidden layers; its saved zip
    names ``torch.nn.Tanh``, and the loaded policy's actions equal the trained one's to float32
    rounding (each hidden value differs by a few ulps; the layers' weights, below 1 in
    magnitude per input and 64 inputs, carry that to about 1e-6 at most)."""
    cfg = load_config(
        Path(__file__).resolve().parents[2] / "configs/agents/ppo_detumble.yaml",
        {"n_envs": 4, "hyperparams": {"n_steps": 16, "batch_size": 64}},
    )
    env = make_vec_env(cfg, cfg.n_envs, cfg.seed)
    try:
        model = _new_model(cfg, env, tmp_path, 0)
        kinds = [type(m) for m in model.policy.modules()]
        assert kinds.count(Tanh) == 4 and torch.nn.Tanh not in kinds
        model.learn(64)
        model.save(tmp_path / "model.zip")
        loaded = PPO.load(tmp_path / "model.zip", device="cpu")
        assert loaded.policy_kwargs["activation_fn"] is torch.nn.Tanh
        assert Tanh not in [type(m) for m in loaded.policy.modules()]
        obs = np.random.default_rng(7).standard_normal((1000, env.observation_space.shape[0]))
        ours, _ = model.predict(obs.astype(np.float32), deterministic=True)
        theirs, _ = loaded.predict(obs.astype(np.float32), deterministic=True)
        np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-6)
    finally:
        env.close()


@pytest.mark.parametrize("shape", [(1, 64), (4096, 64), (7, 3, 5)])
def test_each_shape_is_kept_and_each_element_is_its_own_tanh(shape: tuple[int, ...]) -> None:
    """One row, a minibatch and a 3-D batch: the shape kept and every element within
    :data:`ULPS` of the exact tanh of the element at its own place."""
    x = torch.randn(*shape, generator=torch.Generator().manual_seed(9))
    out = Tanh()(x)
    assert out.shape == x.shape
    exact = np.tanh(x.numpy().astype(np.float64))
    ulp = np.spacing(np.abs(exact).astype(np.float32)).astype(np.float64)
    assert np.max(np.abs(out.numpy() - exact) / ulp) <= ULPS
