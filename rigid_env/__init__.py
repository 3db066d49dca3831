"""rigid_env: Gymnasium environments on a NumPy rigid-body simulator.

Importing the package sets the folder of Numba's kernel cache (:mod:`rigid_env.numba_cache`)
and registers the ``RigidEnv/...-v0`` environments.
"""

__version__ = "0.1.0"

import os as _os
import sys as _sys

from rigid_env.numba_cache import use_cache_for_this_source


def _our_command() -> bool:
    """Whether this process runs one of our commands (``rigid-env``, ``python -m
    rigid_env.cli``, ``python -m agents.train`` ...), whose errors are one line."""
    spec = getattr(_sys.modules.get("__main__"), "__spec__", None)
    module = (getattr(spec, "name", None) or "").split(".")[0]
    script = _os.path.basename(_sys.argv[0]) if _sys.argv else ""
    return script == "rigid-env" or module in ("rigid_env", "agents")


def _one_line(kind: type[BaseException], exc: BaseException, tb: object) -> None:
    """Our commands' hook for an error raised where no command catches it: a module named in
    RIGID_ENV_EFFECTS / _ACTUATORS / _SENSORS that does not import or declares nothing (the
    registries load as the core is imported) is one line; anything else as Python shows it."""
    if isinstance(exc, ImportError | ValueError) and str(exc).startswith("RIGID_ENV_"):
        spec = getattr(_sys.modules.get("__main__"), "__spec__", None)
        prog = getattr(spec, "name", None) or "rigid-env"  # python -m agents.train: its name
        print(f"{prog}: error: {exc}", file=_sys.stderr)
    else:
        _sys.__excepthook__(kind, exc, tb)  # type: ignore[arg-type]


if _our_command() and _sys.excepthook is _sys.__excepthook__:
    _sys.excepthook = _one_line

use_cache_for_this_source()  # before the first kernel is defined (importing envs defines them)

from rigid_env import envs as _envs  # noqa: E402, F401  (registers the environments)
