"""rigid_env: Gymnasium environments on a NumPy rigid-body simulator.

Importing the package registers the ``RigidEnv/...-v0`` environments.
"""

__version__ = "0.1.0"

from rigid_env import envs as _envs  # noqa: F401  (registers the environments)
