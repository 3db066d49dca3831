"""The world step's plan: every choice made when a :class:`rigid_env.core.world.World` is built
that its step reads, checked once and frozen (:class:`StepPlan`), and the checks of what a user
hands a world (numbers, the :class:`Guard` and :class:`Tolerances` records, states).

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


GUARD_ACTIONS = ("raise", "freeze")
"""What a step does about a body whose state turns non-finite (:attr:`Guard.on_error`)."""


@dataclass(frozen=True)
class Guard:
    """What the world step does about a body that blows up, each field checked as the record
    is built.

    Raises:
        ValueError: one line naming the field and what it must be.
    """

    max_angular_speed: float | None = None
    """The limit on ``|w|`` [rad/s], a finite number > 0, or None (off). As PhysX's
    ``setMaxAngularVelocity``, a faster ``w`` is scaled down to it, direction kept, before every
    substep and after the last. A safety valve, not physics; it removes energy and momentum."""
    on_error: Literal["raise", "freeze"] = "raise"
    """``"raise"`` raises :class:`rigid_env.core.world_errors.NumericalInstabilityError` when a
    state turns non-finite (the world left as it was); ``"freeze"`` keeps failed bodies at their
    last finite state, flagged in ``World.failed``, the others going on bit for bit as without
    them (vector envs)."""

    def __post_init__(self) -> None:
        speed = self.max_angular_speed
        if speed is not None:
            speed = number("Guard.max_angular_speed", speed)
            if not (np.isfinite(speed) and speed > 0.0):
                raise ValueError(
                    f"Guard.max_angular_speed: must be a finite number > 0 [rad/s] or None "
                    f"(off), got {speed}"
                )
            object.__setattr__(self, "max_angular_speed", speed)
        if not isinstance(self.on_error, str) or self.on_error not in GUARD_ACTIONS:
            raise ValueError(f"Guard.on_error: must be 'raise' or 'freeze', got {self.on_error!r}")


@dataclass(frozen=True)
class Tolerances:
    """An error-controlled integrator's (``dop853``) error control, each field checked as the
    record is built.

    Raises:
        ValueError: one line naming the field and what it must be.
    """

    rtol: float = DEFAULT_RTOL
    """Relative tolerance of each substep's error, ``0 < rtol < 1``; one below
    :data:`MIN_RTOL` (which float64 cannot meet) is raised to it with a ``RuntimeWarning``."""
    atol: float = DEFAULT_ATOL
    """Absolute tolerance of each substep's error, finite and > 0."""
    max_substeps: int = DEFAULT_MAX_SUBSTEPS
    """The most substeps (accepted or rejected) the integrator may take per integrator step
    (``dt / substeps``), from 1 to :data:`MAX_SUBSTEP_LIMIT`; a body that needs more fails as a
    non-finite one does (:class:`rigid_env.core.world_errors.SubstepLimitError` under
    ``on_error="raise"``, frozen with a warning under ``"freeze"``)."""
    adaptive: bool = True
    """False turns the control off, the integrator then taking one fixed step of
    ``dt / substeps`` per substep (to measure its order)."""

    def __post_init__(self) -> None:
        rtol = number("Tolerances.rtol", self.rtol)
        atol = number("Tolerances.atol", self.atol)
        max_substeps = number("Tolerances.max_substeps", self.max_substeps, integer=True)
        if not 0.0 < rtol < 1.0:
            raise ValueError(
                f"Tolerances.rtol: must be a relative tolerance with 0 < rtol < 1, got {rtol}"
            )
        if not (np.isfinite(atol) and atol > 0.0):
            raise ValueError(
                f"Tolerances.atol: must be a finite absolute tolerance > 0, got {atol}"
            )
        if not 1 <= max_substeps <= MAX_SUBSTEP_LIMIT:
            raise ValueError(
                f"Tolerances.max_substeps: must be an integer from 1 to {MAX_SUBSTEP_LIMIT}, "
                f"got {max_substeps}"
            )
        if not isinstance(self.adaptive, bool | np.bool_):
            raise ValueError(f"Tolerances.adaptive: must be True or False, got {self.adaptive!r}")
        if rtol < MIN_RTOL:
            warnings.warn(
                f"Tolerances.rtol: {rtol:g} is below what float64 can reach; clamped to "
                f"{MIN_RTOL:.3g}",
                RuntimeWarning,
                stacklevel=3,  # the caller of Tolerances(...) (__init__, then this)
            )
            rtol = MIN_RTOL
        for name, value in (("rtol", rtol), ("atol", atol), ("max_substeps", max_substeps),
                            ("adaptive", bool(self.adaptive))):  # fmt: skip
            object.__setattr__(self, name, value)


RETIRED = {
    "max_angular_speed": "guard",
    "on_error": "guard",
    "rtol": "tolerances",
    "atol": "tolerances",
    "max_substeps": "tolerances",
    "adaptive": "tolerances",
}
"""The settings a world once took one by one, by the record keyword that now holds each."""


def refuse_retired(caller: str, given: dict[str, Any], known: Sequence[str]) -> None:
    """Refuse, in one line, keywords ``caller`` does not take: a setting that moved into
    :class:`Guard` or :class:`Tolerances` is named with the record call that gives it (built
    from the values given), any other with the keywords ``caller`` takes. Nothing given: no-op.

    Raises:
        TypeError: naming the keywords and the fix.
    """
    if not given:
        return
    retired = [k for k in given if k in RETIRED]
    if not retired:
        raise TypeError(
            f"{caller}: unexpected keyword {next(iter(given))!r}; it takes {', '.join(known)}"
        )
    records, calls = [], []
    for keyword, record in (("guard", "Guard"), ("tolerances", "Tolerances")):
        fields = ", ".join(f"{k}={given[k]!r}" for k in retired if RETIRED[k] == keyword)
        if fields:
            records.append(record)
            calls.append(f"{keyword}={record}({fields})")
    moved = (
        f"{retired[0]} is now a field"
        if len(retired) == 1
        else f"{', '.join(retired)} are now fields"
    )
    raise TypeError(f"{caller}: {moved} of {' and '.join(records)}; pass {', '.join(calls)}")


def check_tolerances(
    integrator: str, tolerances: Tolerances | None, wheels: bool = False
) -> Tolerances | None:
    """The tolerances an ``integrator`` steps with: ``tolerances`` (:class:`Tolerances`' own
    defaults where None) for an error-controlled integrator, None for a fixed-step one.

    Raises:
        ValueError: for tolerances given to a fixed-step integrator (naming an integrator that
            takes them, none where the world has reaction wheels), or a value not a Tolerances.
    """
    if tolerances is not None and not isinstance(tolerances, Tolerances):
        raise ValueError(
            f"tolerances: must be a Tolerances(rtol, atol, max_substeps, adaptive) or None, "
            f"got {type(tolerances).__name__}"
        )
    if get_integrator(integrator).error_control:
        return Tolerances() if tolerances is None else tolerances
    if tolerances is not None:
        if wheels:  # the error-controlled integrator refuses wheels: not a fix for them
            raise ValueError(
                f"tolerances: integrator {integrator!r} takes fixed steps, and no "
                "error-controlled integrator steps reaction wheels; leave tolerances out "
                "(more substeps make a fixed step more accurate)"
            )
        raise ValueError(
            f"tolerances: integrator {integrator!r} takes fixed steps; tolerances set the error "
            "control of 'dop853' (leave them out, or choose integrator 'dop853')"
        )
    return None


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
        guard: what the step does about a blow-up (:class:`Guard`).
        tolerances: an error-controlled integrator's :class:`Tolerances` (its defaults where
            none were given), None for a fixed-step one.
    """

    integrator: IntegratorInfo
    effects: tuple[ForceEffect | StepMap, ...]
    dt: float
    substeps: int
    guard: Guard
    tolerances: Tolerances | None

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
        guard: Guard,
        tolerances: Tolerances | None,
    ) -> StepPlan:
        """The plan of these settings, each checked (:func:`number`; the records check their
        own fields as they are built; :func:`check_tolerances` whether the integrator takes
        tolerances).

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
        if not isinstance(guard, Guard):
            raise ValueError(
                f"guard: must be a Guard(max_angular_speed, on_error), got {type(guard).__name__}"
            )
        if not isinstance(integrator, str):
            raise ValueError(f"integrator: must be a name (a str), got {integrator!r}")
        unknown = [e for e in effects if not isinstance(e, ForceEffect | StepMap)]
        if unknown:
            raise TypeError(f"effects: {unknown[0]!r} is neither a ForceEffect nor a StepMap")
        entry = get_integrator(integrator)
        wheels = bool(where(effects, lambda a: a.internal_momentum is not None))
        checked = check_tolerances(integrator, tolerances, wheels=wheels)
        return cls(entry, tuple(effects), dt, substeps, guard, checked)
