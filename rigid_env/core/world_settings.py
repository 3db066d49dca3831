"""A world's settings, read-only once built (the compiled step is set up for them): ``dt``,
``substeps``, the integrator, the effects and the rest of its frozen plan
(:class:`rigid_env.core.plan.StepPlan`: its :class:`~rigid_env.core.plan.Guard` and
:class:`~rigid_env.core.plan.Tolerances`), each refusing assignment with the call that makes a
new world with it (:meth:`Settings.with_settings`; :class:`Settings`, a part of
:class:`rigid_env.core.world.World`)."""

from __future__ import annotations

import functools
from typing import Any

from rigid_env.core.effects import ForceEffect
from rigid_env.core.integrators import get_integrator
from rigid_env.core.layout import STATE_WIDTH
from rigid_env.core.plan import RETIRED, Guard, Tolerances, refuse_retired

_SETTING_CALLS = {
    "h": "world.with_settings(substeps=k) (h = dt / substeps; or dt=...)",
    "plan": "world.with_settings(...) with the settings it holds (dt, substeps, integrator, "
    "effects, guard, tolerances)",
}
"""The read-only values :meth:`World.with_settings` sets under other names (the others: their
own, or a field of a record: :meth:`Settings._setting_call`)."""
SETTINGS = ("effects", "integrator", "dt", "substeps", "guard", "tolerances")
"""What :meth:`Settings.with_settings` takes: the constructor's settings (not its bodies)."""


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
                        "integrator='dop853', tolerances=Tolerances(rtol=..., atol=...))"
                    )
                )
            self._refuse(name, value)

        return property(get, refuse, doc=doc)

    plan = _read_only("plan", "Every setting the step reads (:class:`StepPlan`, frozen).")
    dt = _read_only("dt", "Time per :meth:`step` [s] (read-only: :meth:`with_settings`).")
    substeps = _read_only("substeps", "Integrator steps per :meth:`step` (read-only).")
    integrator = _read_only("integrator", "The integrator's registry entry (read-only).")
    _planned = functools.partial(_read_only, planned=True)
    h = _planned("h", "The integrator's step ``dt / substeps`` [s] (read-only).")
    guard = _planned("guard", "What the step does about a blow-up (:class:`Guard`, read-only).")
    tolerances = _planned(
        "tolerances",
        "The :class:`Tolerances` of an error-controlled integrator (read-only), or None.",
    )
    effects = _planned("effects", "The active effects (read-only).")
    del _planned, _read_only

    @property
    def max_angular_speed(self) -> float | None:
        """The :attr:`guard`'s limit on ``|w|`` [rad/s], or None (read-only)."""
        return self._plan.guard.max_angular_speed

    @max_angular_speed.setter
    def max_angular_speed(self, value: Any) -> None:
        self._refuse("max_angular_speed", value)

    @property
    def on_error(self) -> str:
        """The :attr:`guard`'s ``'raise'`` or ``'freeze'`` (read-only)."""
        return self._plan.guard.on_error

    @on_error.setter
    def on_error(self, value: Any) -> None:
        self._refuse("on_error", value)

    def _refuse(self, name: str, value: Any) -> None:
        """Refuse assigning ``name`` with the :meth:`with_settings` call that sets it."""
        raise AttributeError(
            f"World.{name} is read-only (the compiled step is set up for it); make a new "
            f"world with it: world = {_SETTING_CALLS.get(name) or self._setting_call(name, value)}"
        )

    def _setting_call(self, name: str, value: Any) -> str:
        """The :meth:`with_settings` call that gives a world ``value`` for its ``name``; a
        field of the :attr:`guard` in a whole :class:`Guard` (the other field kept)."""
        guard = self._plan.guard
        value = getattr(value, "name", value) if name == "integrator" else value
        shown = repr(value) if len(repr(value)) <= 40 else "..."  # not a page of effects
        if name == "max_angular_speed":
            name, shown = "guard", f"Guard(max_angular_speed={shown}, on_error={guard.on_error!r})"
        elif name == "on_error":
            speed = guard.max_angular_speed
            name, shown = "guard", f"Guard(max_angular_speed={speed!r}, on_error={shown})"
        elif name == "guard":
            shown = repr(value) if isinstance(value, Guard) else "Guard(...)"
        elif name == "tolerances":
            shown = (
                repr(value) if isinstance(value, Tolerances) else "Tolerances(rtol=..., atol=...)"
            )
        return f"world.with_settings({name}={shown})"

    @property
    def force_effects(self) -> tuple[ForceEffect, ...]:
        """The active force effects (actuators among them)."""
        return tuple(e for e in self._plan.effects if isinstance(e, ForceEffect))

    def with_settings(self, **settings: Any) -> Any:
        """A new world of this one's model, bodies and state (copied) with other settings: any
        of ``effects``, ``integrator``, ``dt``, ``substeps``, ``guard`` (a :class:`Guard`),
        ``tolerances`` (a :class:`Tolerances`; None: the integrator's defaults), as the
        constructor takes them; each left out is kept (the tolerances while the integrator
        controls its error). Its step counter is 0.

        Raises:
            ValueError: for an unknown setting, or a value the constructor refuses.
            TypeError: for a setting that moved into :class:`Guard` or :class:`Tolerances`
                (``max_angular_speed``, ``on_error``, ``rtol``, ``atol``, ``max_substeps``,
                ``adaptive``), naming the record call to pass.
        """
        refuse_retired(
            "with_settings", {k: v for k, v in settings.items() if k in RETIRED}, SETTINGS
        )
        unknown = sorted(set(settings) - set(SETTINGS))
        if unknown:
            raise ValueError(
                f"with_settings: unknown setting {unknown[0]!r}; choose from {sorted(SETTINGS)}"
            )
        plan = self._plan
        kept = {
            "effects": plan.effects, "integrator": plan.integrator.name, "dt": plan.dt,
            "substeps": plan.substeps, "guard": plan.guard,
        }  # fmt: skip
        name = settings.get("integrator", kept["integrator"])
        if plan.tolerances is not None and get_integrator(name).error_control:
            kept["tolerances"] = plan.tolerances
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
