"""A world's settings, read-only once built (the compiled step is set up for them): ``dt``,
``substeps``, the integrator, the effects and the rest of its frozen plan
(:class:`rigid_env.core.plan.StepPlan`), each refusing assignment with the call that makes a
new world with it (:meth:`Settings.with_settings`; :class:`Settings`, a part of
:class:`rigid_env.core.world.World`)."""

from __future__ import annotations

import functools
from typing import Any

from rigid_env.core.effects import ForceEffect
from rigid_env.core.integrators import get_integrator
from rigid_env.core.layout import STATE_WIDTH

_SETTING_CALLS = {
    "h": "world.with_settings(substeps=k) (h = dt / substeps; or dt=...)",
    "tolerances": "world.with_settings(rtol=..., atol=..., max_substeps=...) (an "
    "error-controlled integrator's)",
    "plan": "world.with_settings(...) with the settings it holds (dt, substeps, integrator, "
    "effects, ...)",
}
"""The read-only values :meth:`World.with_settings` sets under other names (the others: their
own)."""


class Settings:
    """The settings' part of a :class:`~rigid_env.core.world.World` (its frozen ``_plan`` and
    the values it keeps as ``_dt``, ``_substeps``, ``_integrator``)."""

    # ---- settings, read-only: a new world for new ones --------------------------------------

    def _read_only(name: str, doc: str, planned: bool = False) -> property:  # type: ignore[misc]
        """A setting read from ``self._<name>``, or from the frozen plan where ``planned``,
        which refuses assignment with the :meth:`with_settings` call that does it."""

        def get(self: Any) -> Any:
            return getattr(self._plan, name) if planned else getattr(self, "_" + name)

        def refuse(self: Any, value: Any) -> None:
            if name == "tolerances" and self._plan.tolerances is None:
                raise AttributeError(
                    "World.tolerances is read-only, and None here: "
                    + (
                        "no error-controlled integrator steps reaction wheels (a smaller dt or "
                        "more substeps make a fixed step more accurate: world.with_settings("
                        "substeps=k))"
                        if self._wheels is not None
                        else f"integrator {self._plan.integrator.name!r} takes fixed steps; "
                        "make a new world with tolerances: world = world.with_settings("
                        "integrator='dop853', rtol=..., atol=...)"
                    )
                )
            value = getattr(value, "name", value) if name == "integrator" else value
            shown = repr(value) if len(repr(value)) <= 40 else "..."  # not a page of effects
            call = _SETTING_CALLS.get(name, f"world.with_settings({name}={shown})")
            raise AttributeError(
                f"World.{name} is read-only (the compiled step is set up for it); make a new "
                f"world with it: world = {call}"
            )

        return property(get, refuse, doc=doc)

    plan = _read_only("plan", "Every setting the step reads (:class:`StepPlan`, frozen).")
    dt = _read_only("dt", "Time per :meth:`step` [s] (read-only: :meth:`with_settings`).")
    substeps = _read_only("substeps", "Integrator steps per :meth:`step` (read-only).")
    integrator = _read_only("integrator", "The integrator's registry entry (read-only).")
    _planned = functools.partial(_read_only, planned=True)
    h = _planned("h", "The integrator's step ``dt / substeps`` [s] (read-only).")
    max_angular_speed = _planned("max_angular_speed", "The limit on ``|w|`` [rad/s] or None.")
    on_error = _planned("on_error", "``'raise'`` or ``'freeze'`` (read-only).")
    tolerances = _planned(
        "tolerances", "``(rtol, atol, max_substeps)`` of an error-controlled integrator, or None."
    )
    effects = _planned("effects", "The active effects (read-only).")
    del _planned, _read_only

    @property
    def force_effects(self) -> tuple[ForceEffect, ...]:
        """The active force effects (actuators among them)."""
        return tuple(e for e in self._plan.effects if isinstance(e, ForceEffect))

    def with_settings(self, **settings: Any) -> Any:
        """A new world of this one's model, bodies and state (copied) with other settings:
        any of ``effects``, ``integrator``, ``dt``, ``substeps``, ``max_angular_speed`` (None:
        off), ``on_error``, ``rtol``, ``atol``, ``max_substeps``, ``adaptive``; each left out is
        kept (the tolerances while the integrator controls its error). Its step counter is 0.

        Raises:
            ValueError: for an unknown setting, or a value the constructor refuses.
        """
        plan = self._plan
        kept = {
            "effects": plan.effects, "integrator": plan.integrator.name, "dt": plan.dt,
            "substeps": plan.substeps, "max_angular_speed": plan.max_angular_speed,
            "on_error": plan.on_error, "adaptive": plan.adaptive,
        }  # fmt: skip
        unknown = sorted(set(settings) - {*kept, "rtol", "atol", "max_substeps"})
        if unknown:
            raise ValueError(
                f"with_settings: unknown setting {unknown[0]!r}; choose from "
                f"{sorted({*kept, 'rtol', 'atol', 'max_substeps'})}"
            )
        name = settings.get("integrator", kept["integrator"])
        if plan.tolerances is not None and get_integrator(name).error_control:
            kept |= dict(zip(("rtol", "atol", "max_substeps"), plan.tolerances, strict=True))
        merged = kept | settings
        world = type(self)(self.model, merged.pop("effects"), merged.pop("integrator"),
                      state=self._state.copy(), **merged)  # fmt: skip
        if world._cols.shape == self._cols.shape:  # the thrust levels, if they lag; wheels
            world._cols[STATE_WIDTH:] = self._cols[STATE_WIDTH:]
        for name in ("magnetic_field", "orbit_time"):  # the coils' field and orbit clocks
            mine, theirs = getattr(self, name), getattr(world, name)
            if mine is not None and theirs is not None:
                theirs[:] = mine
        maps = self.body_maps
        if maps is not None:
            world.set_body_maps(maps[:, :, :3], maps[:, :, 3:])
        return world
