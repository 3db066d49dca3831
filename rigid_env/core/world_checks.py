"""What a world checks besides the step itself: a command's shape and type, a body's mass
properties (a warning where they break the triangle inequality), a spin beyond the
integrator's stable range (a warning), and the likely cause of a failure other than the step
size (:class:`Diagnostics`, a part of :class:`rigid_env.core.world.World`)."""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core.layout import STATE_WIDTH
from rigid_env.core.world_errors import stable_choices

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

ASYMMETRY_LIMIT = 2.0
"""Largest ``|I_j - I_k| / I_i`` of a body's principal moments a world takes without a warning.
Euler's equations turn ``w_i`` at ``(I_j - I_k) / I_i w_j w_k``; a real body has ``|I_j - I_k|
<= I_i`` (the triangle inequality), so no rate exceeds ``|w|^2`` however thin it is, and every
integrator's accuracy and stable ``h |w|`` hold for it. Rounding of a thin body's moments can
exceed 1 (``(r, 1, 1 + r)`` stores ``I_z - I_y`` to one ulp of 1: up to ``2 r`` for ``r`` near
1.1e-16), never 2; a scene's triangle check is relative to the sum of the moments and lets
``(1e-12, 1, 1 + 1e-9)`` through, whose ``w_x`` turns 1000x faster than ``|w|^2``: every
integrator but ``exact_free`` then needs a ``dt`` that much smaller (rk4 errs 5.6 rad/s in 200
steps of 0.01 s, splitting 30, the explicit ones overflow)."""


class Diagnostics:
    """The checks of a :class:`~rigid_env.core.world.World` (its ``action_dim``, ``n``,
    ``model``, ``integrator``, state columns ``_cols`` and wheels)."""

    def _check_action(self, action: ArrayLike | None) -> FloatArray | None:
        """``action`` as the C-contiguous float64 (N | 1, A) command, or None for no command.
        Real numbers of any dtype; bools, strings and complex numbers are refused (a bool is
        no throttle level); values beyond [-1, 1] are clipped in the step
        (:func:`rigid_env.core.layout.command_level`), a NaN or inf refused there.

        Raises:
            ValueError: one line naming the shape or type expected and the one given.
        """
        try:
            raw = np.asarray(action)
        except Exception as exc:  # e.g. a tensor that requires grad, a ragged list
            raise ValueError(
                f"action: must be an array of real numbers, got {type(action).__name__} "
                f"({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})"
            ) from None
        if action is not None and raw.dtype.kind not in "iuf":
            raise ValueError(
                f"action: must be real numbers (an int or float dtype), got dtype {raw.dtype}"
            )
        if action is None or self.action_dim == 0:
            if action is not None and np.size(action) != 0:
                raise ValueError(f"action: the world has no actuators, got {np.size(action)}")
            return None
        act = np.ascontiguousarray(raw, dtype=np.float64)
        if act.ndim == 1:
            act = act.reshape(1, -1)
        if act.ndim != 2 or act.shape[-1] != self.action_dim or act.shape[0] not in (1, self.n):
            raise ValueError(
                f"action: expected shape ({self.n}, {self.action_dim}) or "
                f"({self.action_dim},), got {np.shape(action)}"
            )
        return act

    def _likely_cause(self, bad: BoolArray) -> str:
        """The fix the error proposes when the cause is not the step size ("": the step size):
        a state already non-finite before the step (left as it was), or a body whose mass
        properties are extreme."""
        before = self._cols[:STATE_WIDTH, bad]  # the failed bodies' state before the step
        if not np.isfinite(before).all():
            b = int(np.flatnonzero(bad)[np.flatnonzero(~np.isfinite(before).all(axis=0))[0]])
            return (
                f"body {b}'s state was already non-finite before the step (a NaN or inf written "
                "into world.state or its arrays): set a finite state with world.reset(state)"
            )
        m = self.model
        scale = np.max(np.abs(np.concatenate([m.mass, m.inertia.ravel(), 1.0 / m.inertia.ravel()])))
        if not scale < 1.0e150:
            return (
                "the body's mass properties are extreme (a mass or moment beyond 1e150 or below "
                "1e-150): check the scene's body.mass and body.inertia"
            )
        return ""

    def _check_asymmetry(self) -> None:
        """Warn once (RuntimeWarning) if a body's moments break the triangle inequality by more
        than :data:`ASYMMETRY_LIMIT`: the integrator's step then errs by that factor more."""
        worst, b = self.model.worst_breach()
        self._warn_asymmetry(worst, np.atleast_2d(self.model.inertia)[b], b)

    def _warn_asymmetry(
        self, worst: float, moments: FloatArray, body: int, stacklevel: int = 4
    ) -> None:
        """:meth:`_check_asymmetry`'s warning, once, where body ``body``'s breach ``worst``
        (the largest ``|I_j - I_k| / I_i`` of its ``moments``, the bodies' largest) exceeds
        :data:`ASYMMETRY_LIMIT` (``stacklevel``: that of the World method the user called)."""
        if not worst > ASYMMETRY_LIMIT:
            return
        if self.integrator.name == "exact_free" or getattr(self, "_warned_asymmetry", False):
            return
        self._warned_asymmetry = True
        exact = "" if self._wheels is not None else "'exact_free' (exact for any moments), or "
        warnings.warn(
            f"body {body}: principal moments {moments.tolist()} break the triangle inequality "
            f"(|I_j - I_k| / I_i = {worst:.3g} > {ASYMMETRY_LIMIT:g}; a real body has at "
            f"most 1): Euler's equations turn w up to {worst:.3g}x faster than |w|^2, and "
            f"integrator {self.integrator.name!r} errs that much more per step; use a dt "
            f"{worst:.3g}x smaller, or {exact}check the moments",
            RuntimeWarning,
            stacklevel=stacklevel,
        )

    def _warn_speed(self) -> None:
        self._warned = True
        warnings.warn(
            f"integrator {self.integrator.name!r}: a body spins beyond its stable range (h |w| > "
            f"{self.integrator.stability:g} rad per step at h = {self.h:g} s); results may drift "
            f"or blow up: use a smaller dt or more substeps"
            f"{stable_choices(self._wheels is not None, ', or ', self.integrator.name)}",
            RuntimeWarning,
            stacklevel=3,
        )
