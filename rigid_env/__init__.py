"""rigid_env: Gymnasium environments on a NumPy rigid-body simulator.

Importing the package sets the folder of Numba's kernel cache (:mod:`rigid_env.numba_cache`)
and registers the ``RigidEnv/...-v0`` environments.
"""

__version__ = "0.1.0"

from rigid_env.numba_cache import use_cache_for_this_source

use_cache_for_this_source()  # before the first kernel is defined (importing envs defines them)

from rigid_env import envs as _envs  # noqa: E402, F401  (registers the environments)
