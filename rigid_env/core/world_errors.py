"""What a world step reports when a body fails: :class:`NumericalInstabilityError` (a state
turned non-finite or exploded) and :class:`SubstepLimitError` (an error-controlled integrator ran
out of substeps), each naming the bodies, the step, the integrator and the fix; and the stable
integrators a fix may name (:func:`stable_choices`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.integrators import NO_WHEELS
from rigid_env.core.stepping import EXPLOSION_FACTOR

STABLE_AT_SPEED = ("implicit_gyro", "splitting", "exact_free")
"""The integrators that stay stable at any spin (an implicit gyroscopic step, exact flows)."""


def stable_choices(wheels: bool, before: str = "", current: str = "") -> str:
    """The stable integrators a fix may name on a world with or without reaction wheels: only
    those that step it (the wheels' registry, :data:`rigid_env.core.wheels.NO_WHEELS`, refuses
    every one of them), ``current`` (the one that failed) left out; ``before`` + ``"a stable
    integrator ('a', 'b' or 'c')"``, or "" where none is left."""
    usable = [f"'{n}'" for n in STABLE_AT_SPEED if n != current and not (wheels and n in NO_WHEELS)]
    if not usable:
        return ""
    listed = usable[0] if len(usable) == 1 else f"{', '.join(usable[:-1])} or {usable[-1]}"
    return f"{before}a stable integrator ({listed})"


def chosen_bodies(n: int, bodies: Any) -> NDArray[np.int64]:
    """The indices ``bodies`` (an index, a slice or a mask of the ``n``) picks, or a one-line
    ValueError naming ``bodies`` (every World method that takes ``bodies`` reads it here)."""
    try:
        return np.arange(n)[bodies]
    except (IndexError, TypeError, ValueError):
        raise ValueError(
            f"bodies: {bodies!r} is no index, slice or mask of this world's {n} "
            f"bodies (indices 0 to {n - 1})"
        ) from None


class NumericalInstabilityError(FloatingPointError):
    """A body's state turned non-finite; the message names the body, step, integrator and fix."""

    def __init__(
        self,
        bodies: Sequence[int],
        step: int,
        integrator: str,
        dt: float,
        cause: str = "",
        wheels: bool = False,
    ) -> None:
        self.bodies = list(bodies)
        self.step = step
        self.integrator = integrator
        self.dt = dt
        shown = ", ".join(str(b) for b in self.bodies[:5])
        if len(self.bodies) > 5:
            shown += f" ... ({len(self.bodies)} bodies)"
        others = stable_choices(wheels, ", or ", integrator)
        fix = cause or f"use a smaller dt or more substeps{others}"
        super().__init__(
            f"state of body {shown} blew up at step {step} (a non-finite number, or a "
            f"kinetic energy {EXPLOSION_FACTOR**2:g}x beyond what the forces can supply in one "
            f"step; integrator {integrator!r}, dt {dt:g} s); {fix}"
        )


class SubstepLimitError(NumericalInstabilityError):
    """An error-controlled integrator needed more substeps than allowed in one step; the message
    names the bodies, the limit, the tolerances and the fixes."""

    def __init__(
        self, bodies: Sequence[int], step: int, integrator: str, dt: float, limit: str
    ) -> None:
        super().__init__(bodies, step, integrator, dt)
        shown = ", ".join(str(b) for b in self.bodies[:5])
        if len(self.bodies) > 5:
            shown += f" ... ({len(self.bodies)} bodies)"
        self.args = (
            f"body {shown} needed more than {limit} in step {step} (integrator "
            f"{integrator!r}, dt {dt:g} s); loosen rtol/atol, use a smaller dt, or allow more "
            "with the world's Tolerances(max_substeps=...)",
        )

    def __str__(self) -> str:
        return str(self.args[0])
