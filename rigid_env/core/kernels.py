"""Former home of the per-body maths, kept for the imports of ``rigid_env.envs`` until they
name the new modules (:mod:`~rigid_env.core.maths`, :mod:`~rigid_env.core.dynamics`,
:mod:`~rigid_env.core.layout`, :mod:`~rigid_env.core.threads`, :mod:`~rigid_env.core.jit`)."""

from rigid_env.core.dynamics import kinetic_energy
from rigid_env.core.jit import kernel
from rigid_env.core.layout import body_model
from rigid_env.core.maths import quat_mul, rotate, rotate_inv
from rigid_env.core.threads import split_range

__all__ = [
    "body_model",
    "kernel",
    "kinetic_energy",
    "quat_mul",
    "rotate",
    "rotate_inv",
    "split_range",
]
