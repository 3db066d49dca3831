"""A faster ``tanh`` for the policies' hidden layers while they train on the CPU.

PyTorch's CPU ``tanh`` (2.13, the build pip installs) costs about 2.6 ns per float32 element
here, six to seven times NumPy's SIMD ``tanh`` on the same array (0.76 against 5.4 ms for 32,768
x 64 on one thread); in a PPO update of two [64, 64] tanh networks it was the second cost after
the matrix products. :class:`Tanh` computes its forward with NumPy and its backward with
PyTorch's own ``tanh_backward`` (``g (1 - y^2)``, one fused pass), so a training step differs
from ``torch.nn.Tanh``'s only by the rounding of ``tanh`` itself: NumPy's float32 ``tanh`` is
within a few units in the last place of the exact value (tests/agents/test_activations.py),
PyTorch's within one.

:func:`use_fast_tanh` swaps it into a built network in place of each ``torch.nn.Tanh``; the
model a run saves keeps ``torch.nn.Tanh`` in its arguments (``policy_kwargs``), so the zip is
SB3's own and loads anywhere SB3 does, with PyTorch's ``tanh``.
"""

from __future__ import annotations

import numpy as np
import torch


def _numpy_tanh(x: torch.Tensor) -> torch.Tensor:
    """``tanh`` of a float32 CPU tensor, computed by NumPy (a new tensor, no gradient)."""
    return torch.from_numpy(np.tanh(x.detach().contiguous().numpy()))


class _NumpyTanh(torch.autograd.Function):
    """:func:`_numpy_tanh` with its gradient by PyTorch's ``tanh_backward``."""

    @staticmethod
    def forward(ctx, x):
        y = _numpy_tanh(x)
        ctx.save_for_backward(y)
        return y

    @staticmethod
    def backward(ctx, grad):
        (y,) = ctx.saved_tensors
        return torch.ops.aten.tanh_backward(grad, y)


class Tanh(torch.nn.Tanh):
    """``torch.nn.Tanh`` computed by NumPy for float32 CPU tensors (others: PyTorch's)."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if x.dtype != torch.float32 or x.device.type != "cpu":
            return torch.tanh(x)
        if not (torch.is_grad_enabled() and x.requires_grad):
            return _numpy_tanh(x)
        return _NumpyTanh.apply(x)


def use_fast_tanh(module: torch.nn.Module) -> int:
    """Replace every ``torch.nn.Tanh`` in ``module`` (each slot of a network that reuses one
    instance too) by :class:`Tanh`, in place; returns how many slots changed."""
    changed = 0
    for name, child in list(module._modules.items()):
        if child is None:
            continue
        if type(child) is torch.nn.Tanh:
            module._modules[name] = Tanh()
            changed += 1
        else:
            changed += use_fast_tanh(child)
    return changed
