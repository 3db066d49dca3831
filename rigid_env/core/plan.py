"""The world step's plan: every choice made when a :class:`rigid_env.core.world.World` is built
that its step reads, checked once and frozen (:class:`StepPlan`), and the checks of what a user
hands a world (numbers, tolerances, states).

A world's settings change only by building another world (``World.with_settings``), so the
compiled step's parameters (:func:`rigid_env.core.effects.pack`) never go stale.
"""

from __future__ import annotations

import numbers
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from rigid_env.core.actuator import where
from rigid_env.core.effects import ForceEffect, StepMap
from rigid_env.core.integrators import IntegratorInfo, get_integrator
from rigid_env.core.state import State

DEFAULT_RTOL = 1.0e-10
"""Relative tolerance of an error-controlled integrator (``dop853``) when none is given."""
DEFAULT_ATOL = 1.0e-10
"""Absolute tolerance of an error-controlled integrator when none is given."""
DEFAULT_MAX_SUBSTEPS = 1000
"""The most substeps (accepted or rejected) an error-controlled integrator may take per
integrator step before the body counts as failed (``SubstepLimitError``)."""
MIN_RTOL = 100.0 * np.finfo(np.float64).eps
"""The smallest relative tolerance float64 can reach (2.2e-14): a step's error estimate is a
difference of numbers of the state's size, itself rounded to a few ulps of them, so a tolerance
below ~100 ulps is never met (the bound of SciPy's ``solve_ivp`` and Hairer's DOP853, which
also raise such an ``rtol`` to it). A smaller one is clamped to it with a warning."""


MAX_SUBSTEPS = 10**6
"""The most integrator steps per world step: a world step stays bounded in time (a second of
one body's rk4 substeps at most)."""
MAX_BODIES = 2**26
"""The most bodies of a world (67 M: 7 GB of state columns)."""
MAX_SUBSTEP_LIMIT = 10**7
"""The largest ``max_substeps`` of an error-controlled integrator."""


def number(name: str, value: Any, *, integer: bool = False) -> float:
    """``value`` as a float (an int with ``integer``); a string is not a number and a bool is
    not an integer.

    Raises:
        ValueError: one line naming the field, the value and what it must be.
    """
    if isinstance(value, np.ndarray) and value.ndim == 0:  # a 0-d array: the number it holds
        value = value[()]
    whole = isinstance(value, numbers.Integral) or (
        isinstance(value, numbers.Real) and float(value).is_integer()
    )
    if (
        isinstance(value, bool | np.bool_)
        or not isinstance(value, numbers.Real)
        or (integer and not whole)
    ):
        what = "an integer" if integer else "a number"
        raise ValueError(f"{name}: must be {what}, got {value!r} ({type(value).__name__})")
    return int(value) if integer else float(value)


def check_tolerances(
    integrator: str,
    rtol: float | None,
    atol: float | None,
    max_substeps: int,
    wheels: bool = False,
) -> tuple[float, float, int] | None:
    """``(rtol, atol, max_substeps)`` for an error-controlled integrator (defaults filled in;
    an ``rtol`` below :data:`MIN_RTOL` clamped to it, with a ``RuntimeWarning``), None for a
    fixed-step one.

    Raises:
        ValueError: for a tolerance given to a fixed-step integrator, or one out of range.
    """
    if not get_integrator(integrator).error_control:
        given = [k for k, v in (("rtol", rtol), ("atol", atol)) if v is not None]
        if given:
            if wheels:  # the error-controlled integrator refuses wheels: not a fix for them
                raise ValueError(
                    f"{given[0]}: integrator {integrator!r} takes fixed steps, and no "
                    "error-controlled integrator steps reaction wheels; leave rtol and atol out "
                    "(more substeps make a fixed step more accurate)"
                )
            raise ValueError(
                f"{given[0]}: integrator {integrator!r} takes fixed steps; rtol and atol set the "
                "error control of 'dop853' (leave them out, or choose integrator 'dop853')"
            )
        return None
    rtol = DEFAULT_RTOL if rtol is None else number("rtol", rtol)
    atol = DEFAULT_ATOL if atol is None else number("atol", atol)
    max_substeps = number("max_substeps", max_substeps, integer=True)
    if not 0.0 < rtol < 1.0:
        raise ValueError(f"rtol: must be a relative tolerance with 0 < rtol < 1, got {rtol}")
    if not (np.isfinite(atol) and atol > 0.0):
        raise ValueError(f"atol: must be a finite absolute tolerance > 0, got {atol}")
    if not 1 <= max_substeps <= MAX_SUBSTEP_LIMIT:
        raise ValueError(
            f"max_substeps: must be an integer from 1 to {MAX_SUBSTEP_LIMIT}, got {max_substeps}"
        )
    if rtol < MIN_RTOL:
        warnings.warn(
            f"rtol: {rtol:g} is below what float64 can reach; clamped to {MIN_RTOL:.3g}",
            RuntimeWarning,
            stacklevel=4,
        )
        rtol = MIN_RTOL
    return rtol, atol, max_substeps


def check_state(state: State) -> None:
    """Check an outside state: shapes ``(N, 3|4)``, finite numbers, no zero quaternion.

    Raises:
        ValueError: naming the field, the first bad body and the fix.
    """
    if not isinstance(state, State):
        raise ValueError(f"state: must be a State (x, v, q, w), got {type(state).__name__}")
    n = state.x.shape[0] if np.ndim(state.x) == 2 else -1
    for name, width in (("x", 3), ("v", 3), ("q", 4), ("w", 3)):
        a = np.asarray(getattr(state, name))
        if a.shape != (n, width):
            raise ValueError(
                f"state.{name}: expected shape ({max(n, 1)}, {width}) like state.x, got {a.shape}"
            )
        finite = np.isfinite(a).all(axis=1)
        if not finite.all():
            b = int(np.flatnonzero(~finite)[0])
            raise ValueError(
                f"state.{name}: body {b} has a non-finite entry {a[b].tolist()}; "
                "every state number must be finite"
            )
    zero = ~np.any(state.q != 0.0, axis=1)
    if zero.any():
        b = int(np.flatnonzero(zero)[0])
        raise ValueError(
            f"state.q: body {b} is the zero quaternion, which is no rotation; give "
            "a unit quaternion (w, x, y, z), e.g. [1, 0, 0, 0]"
        )


@dataclass(frozen=True)
class StepPlan:
    """Every construction-time choice the world step reads, checked and frozen.

    Attributes:
        integrator: the integrator's registry entry (its compiled entries).
        effects: the active effects, force effects and per-step maps.
        dt: time per world step [s].
        substeps: integrator steps per world step.
        max_angular_speed: the limit on ``|w|`` [rad/s] (None: off).
        on_error: ``"raise"`` or ``"freeze"`` (:class:`rigid_env.core.world.World`).
        tolerances: ``(rtol, atol, max_substeps)`` of an error-controlled integrator, else None.
        adaptive: an error-controlled integrator's control on (else fixed steps of ``h``).
    """

    integrator: IntegratorInfo
    effects: tuple[ForceEffect | StepMap, ...]
    dt: float
    substeps: int
    max_angular_speed: float | None
    on_error: Literal["raise", "freeze"]
    tolerances: tuple[float, float, int] | None
    adaptive: bool

    @property
    def h(self) -> float:
        """The integrator's step ``dt / substeps`` [s]."""
        return self.dt / self.substeps

    @classmethod
    def build(
        cls,
        effects: Sequence[ForceEffect | StepMap],
        integrator: str,
        dt: Any,
        substeps: Any,
        max_angular_speed: Any,
        on_error: Any,
        tolerances: tuple[Any, Any, Any],
        adaptive: Any,
    ) -> StepPlan:
        """The plan of these settings, each checked (:func:`number`, :func:`check_tolerances`).

        Raises:
            ValueError: one line naming the setting and what it must be.
            TypeError: for an effect that is neither a ForceEffect nor a StepMap.
        """
        dt = number("dt", dt)
        if not (np.isfinite(dt) and dt > 0.0):
            raise ValueError(f"dt: must be a finite time step > 0 [s], got {dt}")
        substeps = number("substeps", substeps, integer=True)
        if not 1 <= substeps <= MAX_SUBSTEPS:
            raise ValueError(
                f"substeps: must be an integer from 1 to {MAX_SUBSTEPS}, got {substeps}"
            )
        if max_angular_speed is not None:
            max_angular_speed = number("max_angular_speed", max_angular_speed)
            if not (np.isfinite(max_angular_speed) and max_angular_speed > 0.0):
                raise ValueError(
                    f"max_angular_speed: must be a finite number > 0 [rad/s] or None "
                    f"(off), got {max_angular_speed}"
                )
        if on_error not in ("raise", "freeze"):
            raise ValueError(f"on_error: must be 'raise' or 'freeze', got {on_error!r}")
        if not isinstance(integrator, str):
            raise ValueError(f"integrator: must be a name (a str), got {integrator!r}")
        if not isinstance(adaptive, bool | np.bool_):
            raise ValueError(f"adaptive: must be True or False, got {adaptive!r}")
        unknown = [e for e in effects if not isinstance(e, ForceEffect | StepMap)]
        if unknown:
            raise TypeError(f"effects: {unknown[0]!r} is neither a ForceEffect nor a StepMap")
        entry = get_integrator(integrator)
        wheels = bool(where(effects, lambda a: a.internal_momentum is not None))
        checked = check_tolerances(integrator, *tolerances, wheels=wheels)
        return cls(entry, tuple(effects), dt, substeps, max_angular_speed, on_error, checked,
                   bool(adaptive))  # fmt: skip
