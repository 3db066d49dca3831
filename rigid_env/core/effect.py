"""An effect, declared once: its parameters, its force/torque function, whether it is rare,
its bounds for the world's guard, and whether it depends on velocity.

The declarations (:class:`Effect`) are the registry (:data:`EFFECTS`): the built-in ones of
:mod:`rigid_env.core.forces`, then those of the modules named in the environment variable
``RIGID_ENV_EFFECTS`` (comma-separated module names, each with a sequence ``EFFECTS``). From the
registry the core derives, with no effect named anywhere else:

* the effects' fields of the world's parameters (:class:`rigid_env.core.layout.Params`: the
  flag ``name``, 1 where the scene lists the effect, else 0, then ``fields``);
* the sum of their forces and torques in :func:`rigid_env.core.dynamics.accelerations`, one
  inlined call of each effect's ``apply`` behind its flag (:mod:`rigid_env.core.compose`);
* the guard's reach (:mod:`rigid_env.core.stepping`): the bounds each effect declares;
* the flags the vectorised passes see as the constant 0 (``rare``;
  :func:`rigid_env.core.compose.common`), so that a rare effect's code is not in those loops at all.

Why the registry is closed when the core is imported: Numba composes the effects at compile
time, and the compiled step is cached on disk under a key of the core's sources
(:mod:`rigid_env.numba_cache`). An effect registered later would be missing from code already
compiled in this process, and code cached on disk would not know it. So the registry is read
once, at import, from the core and the ``RIGID_ENV_EFFECTS`` modules, and the cache key hashes
those modules' sources as it hashes the core's: a world of other effects compiles under another
key (one folder per registry), never from stale code.

Adding an effect (the checklist):

1. its declaration: an :class:`Effect` with its kernels, in :mod:`rigid_env.core.forces` (or
   in a module named by ``RIGID_ENV_EFFECTS``);
2. its spec, a :class:`rigid_env.core.effects.ForceEffect` whose ``parameters()`` fills the
   flag and fields by name (and ``potential_energy`` if it is conservative);
3. its scene section in :mod:`rigid_env.scene_sections`;
4. tests: the generic ones (``tests/core/test_effects_generic.py``) pick it up from the
   registry; add one against a closed form.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

ENV_VAR = "RIGID_ENV_EFFECTS"
"""The environment variable naming modules of further effects (comma-separated)."""


@dataclass(frozen=True)
class Effect:
    """A term of the equations of motion, as the compiled core sees it.

    Attributes:
        name: its flag among the world's parameters (the scene key, or its short form:
            ``drag`` for ``quadratic_drag``).
        fields: its numbers' names among the world's parameters (after the flag); its kernels
            read them by name from the named parameters ``c`` (``c.gravity_x``).
        apply: ``(x, v, q, w, m, c, f, tau) -> (f, tau)``: the force (world frame, on the
            centre of mass) [N] and torque (body frame) [N m] accumulated so far, with this
            effect's added, at the state ``(x, v, q, w)`` of the body ``m`` (a ``kernel``).
            Called only where the flag is set.
        rare: stepped body by body (its flag a constant 0 in the vectorised passes): for an
            effect few scenes use, whose code would otherwise cost every world a little.
        velocity_dependent: whether the force or torque depends on ``v`` or ``w`` (the kicks
            of the splitting methods then take more stages to keep their order).
        force_bound: ``(m, c) -> B_F`` [N], the most ``|F|`` it supplies in any state; None: it
            supplies none (or only dissipates: ``F . v <= 0``).
        torque_bound: ``(m, c) -> B_tau`` [N m], the same for ``|tau|``.
        potential_bound: ``(x, m, c) -> sqrt(dV)`` [J^(1/2)] for a conservative effect: the root
            of the most potential energy it can release over the step from position ``x`` (the
            span of its potential over the states reachable in a step); None: not conservative.
            Its work then needs no force or torque bound.
        reads: what it reads of the body's surroundings on its orbit, by name: ``"sunlight"``
            (the Sun's place and the light reaching the body), ``"air"`` (the air's velocity
            and density); the world's flags of those names are set where it is listed, and the
            per-body step then evaluates them at each substep's middle and holds them over it
            (:class:`rigid_env.core.layout.Surroundings`). An effect that reads any takes them
            as ``s`` after ``c``: ``apply(x, v, q, w, m, c, s, f, tau)``, ``force_bound(m, c,
            s)``, ``torque_bound(m, c, s)``; it must be ``rare`` (only the per-body path
            carries them), and a world lists it only with an orbit.
    """

    name: str
    fields: tuple[str, ...]
    apply: Callable
    rare: bool = False
    velocity_dependent: bool = False
    force_bound: Callable | None = None
    torque_bound: Callable | None = None
    potential_bound: Callable | None = None
    reads: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        unknown = [r for r in self.reads if r not in SURROUNDINGS]
        if unknown:
            raise ValueError(
                f"Effect {self.name!r}: reads {unknown[0]!r}, which the orbit does not give; "
                f"choose from {', '.join(SURROUNDINGS)}"
            )
        if self.reads and not self.rare:
            raise ValueError(
                f"Effect {self.name!r}: reads {self.reads[0]!r}, which only the per-body path "
                "carries; declare it rare=True"
            )
        if self.reads and self.potential_bound is not None:
            raise ValueError(
                f"Effect {self.name!r}: one that reads its surroundings declares force and "
                "torque bounds, not a potential_bound"
            )


SURROUNDINGS = ("sunlight", "air")
"""What an effect may read of its surroundings (:attr:`Effect.reads`), each a flag of the
world's parameters."""


def modules_named(env_var: str) -> list[str]:
    """The module names listed, comma-separated, in the environment variable ``env_var``
    (none if unset)."""
    return [name.strip() for name in os.environ.get(env_var, "").split(",") if name.strip()]


def plugin_modules() -> list[str]:
    """The module names in ``RIGID_ENV_EFFECTS`` (none if unset)."""
    return modules_named(ENV_VAR)


def import_named(env_var: str, module: str) -> Any:
    """The module ``module`` named in the environment variable ``env_var``, imported.

    Raises:
        ImportError: one line naming the variable, the module and why it did not import (the
            module's own error chained beneath, for its traceback).
    """
    try:
        return importlib.import_module(module)
    except Exception as exc:  # a missing module, a syntax error in it, an error it raises
        why = str(exc).splitlines()[0] if str(exc) else ""
        raise ImportError(
            f"{env_var}: module {module!r} did not import ({type(exc).__name__}: {why}); check "
            f"the name and PYTHONPATH, or leave it out of {env_var}"
        ) from exc


def declared_in(env_var: str, built_in: Any, attr: str, kind: str) -> tuple[Any, ...]:
    """A registry of declarations: ``built_in``, then the sequence ``attr`` of each module named
    in ``env_var`` (:func:`modules_named`), each declaration's ``name`` its own.

    Raises:
        ValueError: for a module without ``attr``, or a name declared twice.
    """
    found = list(built_in)
    for module in modules_named(env_var):
        declared = getattr(import_named(env_var, module), attr, None)
        if declared is None:
            raise ValueError(f"{env_var}: module {module!r} has no {attr} (a sequence of {kind})")
        found.extend(declared)
    names = [d.name for d in found]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ValueError(f"{env_var}: {kind.lower()} {twice[0]!r} is declared twice; rename one")
    return tuple(found)


def load_effects() -> tuple[Effect, ...]:
    """The registry: the built-in effects, then each ``RIGID_ENV_EFFECTS`` module's ``EFFECTS``.

    Raises:
        ValueError: for a module without ``EFFECTS``, or a name declared twice.
    """
    from rigid_env.core.forces import BUILT_IN  # the built-ins' kernels, after Effect exists

    return declared_in(ENV_VAR, BUILT_IN, "EFFECTS", "Effect")
