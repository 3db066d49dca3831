"""World: a batch of bodies, the active effects, an integrator and a time step.

``World.step`` reads as its stages: check the command -> the compiled world step of the
integrator over the (13, N) state columns (a pass of actuator wrenches -> ``substeps`` passes of
the integrator, each evaluating only the active effects and ending in the guard, the per-step
maps after the last; over the cores from :data:`THREAD_MIN_BODIES` bodies on) -> counters and
reports. A body whose state turns NaN or inf is never handed back silently (``on_error``,
:class:`World`).
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core.actuator import component_column, state_rows, where
from rigid_env.core.effects import (
    ForceEffect,
    ReactionWheels,
    StepMap,
    pack,
)
from rigid_env.core.integrators import NO_WHEELS, check_wheels, get_integrator
from rigid_env.core.layout import (
    FAILED,
    FROZEN,
    HEALTHY,
    MAX_WHEELS,
    MODEL_WIDTH,
    STATE_WIDTH,
    THRUST,
    WRENCH_WIDTH,
    Params,
    Thruster,
    decode,
    unpack,
)
from rigid_env.core.orbit import Orbit
from rigid_env.core.orbit import states as kepler_states
from rigid_env.core.orbit_state import ORBIT_WIDTH, OrbitMotion, fields_at_clocks
from rigid_env.core.plan import (
    DEFAULT_ATOL,
    DEFAULT_MAX_SUBSTEPS,
    DEFAULT_RTOL,
    MAX_BODIES,
    StepPlan,
    check_state,
    check_tolerances,
    number,
)
from rigid_env.core.rotation import quat_rotate
from rigid_env.core.state import BodyModel, State
from rigid_env.core.stepping import EXPLOSION_FACTOR, derivatives
from rigid_env.core.threads import THREAD_MIN_BODIES, call_threaded, threaded

if TYPE_CHECKING:
    from rigid_env.core.geomagnetic import OrbitField

__all__ = [
    "DEFAULT_ATOL",
    "DEFAULT_MAX_SUBSTEPS",
    "DEFAULT_RTOL",
    "THREAD_MIN_BODIES",
    "NumericalInstabilityError",
    "SubstepLimitError",
    "World",
    "call_threaded",
    "check_state",
    "check_tolerances",
    "threaded",
]

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

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
_FLOAT64 = np.dtype(np.float64)


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


_SETTING_CALLS = {
    "h": "world.with_settings(substeps=k) (h = dt / substeps; or dt=...)",
    "tolerances": "world.with_settings(rtol=..., atol=..., max_substeps=...) (an "
    "error-controlled integrator's)",
    "plan": "world.with_settings(...) with the settings it holds (dt, substeps, integrator, "
    "effects, ...)",
}
"""The read-only values :meth:`World.with_settings` sets under other names (the others: their
own)."""


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
            "with max_substeps",
        )

    def __str__(self) -> str:
        return str(self.args[0])


class World:
    """A batch of ``N`` free rigid bodies stepped together.

    Args:
        model: mass properties, per body (N) or shared (1).
        effects: the active effects, force effects and per-step maps; nothing else is simulated.
        integrator: a name from :data:`rigid_env.core.integrators.INTEGRATORS`.
        dt: time per :meth:`step` [s].
        substeps: integrator steps per :meth:`step` (each of ``dt / substeps``).
        state: initial state; ``n`` bodies at rest if omitted.
        n: number of bodies when ``state`` is omitted.
        max_angular_speed: optional limit on ``|w|`` [rad/s], None = off: as PhysX's
            ``setMaxAngularVelocity``, a faster ``w`` is scaled down to it, direction kept,
            before every substep and after the last. A safety valve, not physics: it removes
            energy and momentum.
        on_error: ``"raise"`` raises :class:`NumericalInstabilityError` when a state turns
            non-finite; ``"freeze"`` keeps failed bodies at their last finite state, flagged in
            :attr:`failed`, the others going on bit for bit as without them (vector envs).
        rtol, atol: an error-controlled integrator's (``dop853``) relative and absolute
            tolerance of each substep's error, ``0 < rtol < 1`` and ``atol > 0`` (None:
            :data:`DEFAULT_RTOL`, :data:`DEFAULT_ATOL`); refused for a fixed-step integrator.
        max_substeps: the most substeps an error-controlled integrator may take per integrator
            step (``dt / substeps``); a body that needs more fails as a non-finite one does
            (:class:`SubstepLimitError` under ``"raise"``, frozen with a warning under
            ``"freeze"``).
        adaptive: False turns an error-controlled integrator's control off: it then takes one
            fixed step of ``dt / substeps`` per substep (to measure its order).
    """

    def __init__(
        self,
        model: BodyModel,
        effects: Sequence[ForceEffect | StepMap] = (),
        integrator: str = "rk4",
        dt: float = 0.01,
        substeps: int = 1,
        *,
        state: State | None = None,
        n: int = 1,
        max_angular_speed: float | None = None,
        on_error: Literal["raise", "freeze"] = "raise",
        rtol: float | None = None,
        atol: float | None = None,
        max_substeps: int = DEFAULT_MAX_SUBSTEPS,
        adaptive: bool = True,
    ) -> None:
        self._plan = plan = StepPlan.build(
            effects, integrator, dt, substeps, max_angular_speed, on_error,
            (rtol, atol, max_substeps), adaptive,
        )  # fmt: skip
        self._integrator = plan.integrator
        self._dt, self._substeps = plan.dt, plan.substeps
        control = None if plan.tolerances is None else (*plan.tolerances, plan.adaptive)
        self.params = pack(
            plan.effects,
            plan.h,
            plan.substeps,
            plan.max_angular_speed,
            plan.integrator.stability,
            control=control,
            dt=plan.dt,
        )
        """The world's parameters for the compiled step: the named :class:`Params`
        (:attr:`parameters`), then the actuators' maps (:mod:`rigid_env.core.layout`)."""
        self.action_dim = int(self.parameters.actions)
        """Length of the command vector (all actuators, in scene order)."""
        if state is not None:
            check_state(state)
            n = state.n
        self._n = number("n", n, integer=True)
        if not 1 <= self._n <= MAX_BODIES:
            raise ValueError(f"n: must be an integer from 1 to {MAX_BODIES} (bodies), got {n}")
        hw = self.parameters
        # The thrusters' levels are state where they lag (rows THRUST + a, zero: valves closed),
        # then the wheels' momenta (rigid_env.core.wheels), each body's own.
        wheels = where(plan.effects, lambda a: a.internal_momentum is not None)
        self._wheels = wheels[0] if wheels else None
        if self._wheels is not None:
            check_wheels(self._integrator.name)
        self.initial_wheel_speed = (
            None if self._wheels is None else np.zeros(self._wheels.axes.shape[0])
        )
        """(K,) the wheels' speeds relative to the body [rad/s] that :meth:`restart` and
        :meth:`reset` give them (a scene's ``speeds``; zeros: at rest); set it with
        :meth:`set_wheel_speed` (``initial=True``); None without wheels."""
        width = STATE_WIDTH + state_rows(plan.effects)
        # Then each body's orbit, Earth angle and clock where the bodies move on an orbit.
        self._motion = next((e for e in plan.effects if isinstance(e, OrbitMotion)), None)
        self._orbit_row = width
        if self._motion is not None:
            if self._integrator.name == "exact_free":
                raise ValueError(
                    "integrator: 'exact_free' does not read the orbit state (its flow holds the "
                    "torque fixed over a step); choose 'rk4', 'dop853' or another compiled one"
                )
            self.params[Params._fields.index("orbit_row")] = float(width)
            width += ORBIT_WIDTH
        self._cols = cols = np.zeros((width, self._n))
        self._momenta = self._wheel_rows(cols)
        self.thrust_factors = np.ones((self._n, self.action_dim))
        """(N, A) the thrusters' noise factors for the next :meth:`step` (where a thruster has
        ``noise``): set them, or draw them with :meth:`draw_thrust_factors`; 1: nominal."""
        self._noisy = hw.noisy != 0.0
        coils = where(plan.effects, lambda a: a.world_input == "field")
        # the command carries the field unless the orbit state gives it (in the step)
        self._magnetic = bool(coils) and hw.field_degree == 0.0
        coils = coils if self._magnetic else []
        self.magnetic_field = np.tile(coils[0].field, (self._n, 1)) if coils else None
        """(N, 3) the field ``B`` each body's coils see in the next :meth:`step`, world frame
        [T], held over the step: set it between steps, or give the coils an ``orbit`` and the
        world sets it at the middle of each body's step (:attr:`orbit_time`; the midpoint rule:
        second order in the field's slow turn); None without magnetorquers."""
        self._orbit = coils[0].orbit if coils else None
        self.orbit_time = np.zeros(self._n) if self._orbit is not None else None
        """(N,) each body's time along the coils' ``orbit`` [s], advanced by ``dt`` a step and
        cleared by :meth:`restart` (set it to put bodies at other points of the orbit); None
        without an orbit."""
        self._state = State(cols[0:3].T, cols[3:6].T, cols[6:10].T, cols[10:13].T)
        self._wrenches = np.zeros((WRENCH_WIDTH, self._n))
        self._copy_before_step = (
            (plan.on_error == "raise" and self._n > 1) or plan.substeps > 1 or hw.lagged != 0.0
        )
        self._state.q[:, 0] = 1.0
        if state is not None:
            self._state.assign(state)
        self._every_body = np.arange(self._n, dtype=np.int64)
        if self._motion is not None:
            self.orbit_rows[:] = self._motion.rows()
            self._state.x[:] = self.orbit_position()
        self._status = np.zeros(self._n, dtype=np.uint8)
        # An error-controlled integrator's substeps in the last step (row 0) and the substep
        # each body tries first in the next (row 1, carried; 0: the integrator's own guess).
        self._counts = np.zeros((2, self._n))
        self._counts[0] = self._substeps
        self._no_command = np.zeros((1, self.action_dim))
        self._one_command = (self.action_dim,)  # and the shapes of a command as it is used:
        self._shapes = ((1, self.action_dim), (self._n, self.action_dim)) if self.action_dim else ()
        self._none_failed = np.zeros(self._n, dtype=bool)
        self._none_failed.flags.writeable = False
        self._warned = self._warned_asymmetry = False
        self.step_count = 0
        self.set_model(model)
        self._serial = self._integrator.world_step_threads is None or not threaded(self._n)
        self._lagged = hw.lagged != 0.0
        # step() calls the kernel itself (a noisy or magnetic world appends to the command)
        self._direct = self._serial and not (
            self._copy_before_step or self._noisy or self._magnetic
        )

    # ---- settings, read-only: a new world for new ones --------------------------------------

    def _read_only(name: str, doc: str, planned: bool = False) -> property:  # type: ignore[misc]
        """A setting read from ``self._<name>``, or from the frozen plan where ``planned``,
        which refuses assignment with the :meth:`with_settings` call that does it."""

        def get(self: World) -> Any:
            return getattr(self._plan, name) if planned else getattr(self, "_" + name)

        def refuse(self: World, value: Any) -> None:
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

    def with_settings(self, **settings: Any) -> World:
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
        world = World(self.model, merged.pop("effects"), merged.pop("integrator"),
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

    # ---------------------------------------------------------------------------------------
    @property
    def state(self) -> State:
        """The bodies' state: (N, 3) and (N, 4) views of the world's (13, N) columns (editing
        them in place edits the world)."""
        return self._state

    @state.setter
    def state(self, state: State) -> None:
        check_state(state)  # as the constructor checks it
        if state.n != self._n:
            raise ValueError(f"state: has {state.n} bodies, this world has {self._n}")
        self._state.assign(state)
        self._counts[1] = 0.0  # dop853 starts again from its own guess, as a new world would

    @property
    def rows(self) -> FloatArray:
        """(N, 13) the state as rows ``(x, v, q, w)``: a view of :attr:`columns`."""
        return self._cols[:STATE_WIDTH].T

    @property
    def columns(self) -> FloatArray:
        """(13, N) the state as columns ``(x, v, q, w)``: what the compiled step advances
        (with the thrust levels after them where the thrusters lag)."""
        return self._cols[:STATE_WIDTH]

    @property
    def thrust_levels(self) -> FloatArray | None:
        """(N, A) each command component's thrust now, in units of its ``max_force`` (signed),
        where the thrusters lag (a view: editable, part of the state); else None."""
        return self._cols[THRUST : THRUST + self.action_dim].T if self._lagged else None

    @property
    def orbit(self) -> OrbitField | None:
        """The orbit the bodies' field follows (its clock :attr:`orbit_time`), or None."""
        return self._orbit

    @property
    def wheels(self) -> ReactionWheels | None:
        """The bodies' reaction wheels (their spec: axes, inertia, limits), or None."""
        return self._wheels

    @property
    def wheel_momentum(self) -> FloatArray | None:
        """(N, K) each reaction wheel's axial angular momentum ``h_k = J_k (a_k . w + Omega_k)``
        [N m s] (a view: editable, part of the state); None without wheels."""
        if self._wheels is None:
            return None
        return self._cols[THRUST : THRUST + self._wheels.axes.shape[0]].T

    @property
    def wheel_speed(self) -> FloatArray | None:
        """(N, K) each wheel's speed relative to the body ``Omega_k = h_k / J_k - a_k . w``
        [rad/s] (a copy; set speeds with :meth:`set_wheel_speed`); None without wheels."""
        e = self._wheels
        return None if e is None else self.wheel_momentum / e.inertia - self.state.w @ e.axes.T

    def set_wheel_speed(
        self, speed: ArrayLike, bodies: Any = slice(None), *, initial: bool = False
    ) -> None:
        """Set the ``bodies``' wheels (an index, a slice or a mask of the N) to the relative
        speeds ``speed`` [rad/s] ((K,) or (n, K) for the n bodies chosen), at their present body
        rates (``h_k = J_k (a_k . w + Omega_k)``); ``initial=True`` also makes ``speed`` (K,)
        the speeds :meth:`restart` and :meth:`reset` give (:attr:`initial_wheel_speed`).

        Raises:
            ValueError: one line naming what is wrong: no wheels, ``bodies`` no index of the
                world's, a shape other than (K,) or (n, K), a speed that is not finite or
                beyond a wheel's ``max_speed``.
        """
        e = self._wheels
        if e is None:
            raise ValueError("wheel speeds: this world has no reaction_wheels")
        k = e.axes.shape[0]
        chosen = self._chosen(bodies)
        try:
            omega = np.asarray(speed, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(
                f"wheel speeds: expected numbers [rad/s], {k} per body, got {speed!r}"
            ) from None
        n = np.size(chosen)
        shapes = ((k,), (n, k)) if np.ndim(chosen) else ((k,),)
        if omega.shape not in shapes or (initial and omega.shape != (k,)):
            allowed = " or ".join(str(s) for s in (shapes[:1] if initial else shapes))
            raise ValueError(
                f"wheel speeds: expected shape {allowed} (one speed per wheel [rad/s]), got "
                f"shape {omega.shape}"
            )
        if not np.all(np.isfinite(omega)):
            raise ValueError(f"wheel speeds: expected finite speeds [rad/s], got {speed!r}")
        beyond = np.abs(omega) > e.max_speed
        if beyond.any():
            j = int(np.flatnonzero(beyond.reshape(-1, k).any(axis=0))[0])
            worst = float(np.max(np.abs(omega.reshape(-1, k)[:, j])))
            raise ValueError(
                f"wheel speeds: wheel {j} at {worst:g} rad/s is beyond its max_speed "
                f"{e.max_speed[j]:g} rad/s; give speeds within +-max_speed"
            )
        momentum = e.inertia * (self.state.w[bodies] @ e.axes.T + omega)
        self.wheel_momentum[bodies] = momentum
        if initial:
            self.initial_wheel_speed = omega.copy()

    @property
    def motion(self) -> OrbitMotion | None:
        """The bodies' orbit and field (:class:`rigid_env.core.orbit_state.OrbitMotion`), or
        None where they move on none."""
        return self._motion

    @property
    def orbit_rows(self) -> FloatArray | None:
        """(N, ORBIT_WIDTH) each body's orbit state (:class:`rigid_env.core.orbit_state.
        OrbitRows`: clock [s from the epoch], elements, Earth angle), a view: editable, part of
        the state (set a clock, a mean anomaly or an Earth angle per body; the step advances
        the clock); None without an orbit."""
        if self._motion is None:
            return None
        return self._cols[self._orbit_row : self._orbit_row + ORBIT_WIDTH].T

    def orbit_position(self, bodies: Any = slice(None)) -> FloatArray | None:
        """(n, 3) the ``bodies``' (default all) position on its orbit at its clock, ECI [m]
        (the Kepler + J2 drift solution of its rows, :func:`rigid_env.core.orbit.state`); None
        without an orbit.
        The step writes it into ``x`` after each substep."""
        if self._motion is None:
            return None
        rows = self.orbit_rows[self._chosen(bodies)].reshape(-1, ORBIT_WIDTH)
        out = np.empty((rows.shape[0], 3))
        for i, row in enumerate(rows):
            orbit = Orbit(*row[1:10].tolist(), self._motion.orbit.mu)
            out[i] = kepler_states(orbit, row[0])[0]
        return out

    def orbit_field(self, bodies: Any = slice(None)) -> FloatArray | None:
        """(n, 3) the field at the ``bodies``' (default all) position at their clock, ECI [T],
        evaluated by the compiled step's own function (:func:`rigid_env.core.orbit_state.
        where`); None without a field from the orbit."""
        if self._motion is None or not self._motion.field_degree:
            return None
        if isinstance(bodies, slice) and bodies == slice(None):
            index = self._every_body  # (the common case, per step: no index to build)
        else:
            index = np.ascontiguousarray(self._chosen(bodies), dtype=np.int64).reshape(-1)
        out = np.empty((index.size, 3))
        fields_at_clocks(self.params, self._cols, index, out)
        return out

    @property
    def thrust_noise(self) -> FloatArray:
        """(A,) each command component's noise ``SIGMA`` (0 for an ideal one)."""
        return component_column(self.force_effects, Thruster, "noise")

    def draw_thrust_factors(self, rng: np.random.Generator, rows: ArrayLike | None = None) -> None:
        """Draw the next step's :attr:`thrust_factors` ``max(0, 1 + SIGMA xi)``, ``xi`` standard
        normal from ``rng`` (a valve does not pull), for the bodies ``rows`` (default all), row
        after row (the generator's stream in that order); nothing is drawn for a world without
        noise."""
        if not self._noisy:
            return
        sigma = self.thrust_noise
        index = slice(None) if rows is None else np.atleast_1d(rows)
        n = self._n if rows is None else index.size
        xi = rng.standard_normal((n, sigma.size))
        self.thrust_factors[index] = np.maximum(0.0, 1.0 + sigma * xi)

    @property
    def no_failures(self) -> BoolArray:
        """The read-only all-False mask :meth:`step` returns when no body failed (compare with
        ``is`` to skip looking at it)."""
        return self._none_failed

    @property
    def failed(self) -> BoolArray:
        """(N,) bodies frozen by a failure (``on_error="freeze"``); writable, to clear them."""
        return self._status.view(np.bool_)

    @property
    def parameters(self) -> Params:
        """The world's parameters by name (the head of :attr:`params`)."""
        return unpack(self.params)

    @property
    def substeps_taken(self) -> NDArray[np.int64]:
        """(N,) the integrator steps each body took in the last :meth:`step`, read-only: for an
        error-controlled integrator the substeps it tried (accepted or rejected; each costs 11
        evaluations of the dynamics, plus one per accepted substep), over all ``substeps``
        passes; for a fixed-step one ``substeps``."""
        taken = self._counts[0].astype(np.int64)
        taken.flags.writeable = False
        return taken

    @property
    def n(self) -> int:
        """Number of bodies."""
        return self._n

    @property
    def time(self) -> float:
        """Simulated time since the last :meth:`reset` [s]."""
        return self.step_count * self.dt

    @property
    def model_columns(self) -> FloatArray:
        """(MODEL_WIDTH, N) the model numbers, a column per body: what the compiled step reads."""
        return self._model_cols

    def set_model(self, model: BodyModel) -> None:
        """Replace the mass properties (per body or shared), e.g. for domain randomisation."""
        if model.n not in (1, self._n):
            raise ValueError(f"model: has {model.n} bodies but the world has {self._n}")
        self.model = model
        maps = getattr(self, "_model_cols", None)
        self._model_cols = model.columns(self._n)
        if maps is not None and maps.shape[0] > MODEL_WIDTH:  # keep the bodies' own maps
            self._model_cols = np.vstack([self._model_cols, maps[MODEL_WIDTH:]])
        self._check_asymmetry()
        self._set_arrays()

    def _wheel_rows(self, cols: FloatArray) -> FloatArray:
        """(MAX_WHEELS, N) the wheels' momenta: a view of their rows of the state ``cols``, its
        own array for the compiled step (the other rows are never read through it, and the
        compiler vectorises the wheels' passes only where it need not check that the wheels'
        rows and the state's overlap); an empty one without wheels."""
        if self._wheels is None:
            return np.zeros((0, self._n))
        return cols[THRUST : THRUST + MAX_WHEELS]

    def _set_arrays(self) -> None:
        """The compiled step's arrays but the command (whose place is last); an
        error-controlled integrator also writes the substeps each body took."""
        self._arrays = (
            self.params, self._model_cols, self._cols, self._status, self._wrenches, self._momenta,
        )  # fmt: skip
        if self._integrator.error_control:
            self._arrays += (self._counts,)

    @property
    def body_maps(self) -> FloatArray | None:
        """(N, A, 6) each body's own actuator maps ``(force, torque)`` at ``|u| = 1`` (body
        frame) once :meth:`set_body_maps` gave them (a view: editable), else None (the world's
        maps for every body)."""
        if self._model_cols.shape[0] == MODEL_WIDTH:
            return None
        return self._model_cols[MODEL_WIDTH:].T.reshape(self._n, self.action_dim, 6)

    def set_body_maps(self, force_map: ArrayLike, torque_map: ArrayLike) -> None:
        """Give every body its own actuator maps (e.g. a misaligned thruster per episode):
        ``force_map``, ``torque_map`` (N, A, 3) body-frame force and torque of each command
        component at ``|u| = 1`` [N], [N m]. The hardware model (lag, pulse width, ...) stays
        the world's."""
        f = np.asarray(force_map, dtype=np.float64)
        t = np.asarray(torque_map, dtype=np.float64)
        shape = (self._n, self.action_dim, 3)
        finite = np.isfinite(f).all() and np.isfinite(t).all()
        if f.shape != shape or t.shape != shape or not finite:
            raise ValueError(
                f"force_map, torque_map: expected finite arrays of shape {shape}, got "
                f"{f.shape} and {t.shape}"
            )
        rows = np.concatenate([f, t], axis=2).reshape(self._n, 6 * self.action_dim).T
        self._model_cols = np.ascontiguousarray(np.vstack([self._model_cols[:MODEL_WIDTH], rows]))
        self.params[Params._fields.index("body_maps")] = 1.0
        self._set_arrays()

    def reset(self, state: State) -> None:
        """Replace the state (copied), clear failures and the step counter.

        Raises:
            ValueError: for a wrong body count, shape, a non-finite number or a zero quaternion.
        """
        if state.n != self.n:
            raise ValueError(f"state: has {state.n} bodies, this world has {self.n}")
        check_state(state)
        self._state.assign(state)
        self.restart(slice(None))
        self._status[:] = 0
        self.step_count = 0

    def _chosen(self, bodies: Any) -> NDArray[np.int64]:
        """The indices ``bodies`` (an index, a slice or a mask of the N) picks, or a one-line
        ValueError naming ``bodies`` (every method that takes ``bodies`` reads it here)."""
        try:
            return np.arange(self._n)[bodies]
        except (IndexError, TypeError, ValueError):
            raise ValueError(
                f"bodies: {bodies!r} is no index, slice or mask of this world's {self._n} "
                f"bodies (indices 0 to {self._n - 1})"
            ) from None

    def restart(self, bodies: Any) -> None:
        """Clear what the ``bodies`` (an index, or a mask, of the N) carry from one step to the
        next besides their state, as :meth:`reset` does for all: the thrusters' lagging levels
        (valves closed), the substep ``dop853`` tries first (its initial-step guess again) and
        the time along an orbit (:attr:`orbit_time`, back to 0).
        For a new episode of some bodies of a world, so that it repeats a fresh world's.

        Raises:
            ValueError: for an index out of range or a mask of the wrong length.
        """
        self._chosen(bodies)
        self._cols[STATE_WIDTH:, bodies] = 0.0
        if self._wheels is not None:  # the wheels at their initial speeds (a scene's speeds)
            self.set_wheel_speed(self.initial_wheel_speed, bodies)
        self._counts[1, bodies] = 0.0
        if self.orbit_time is not None:
            self.orbit_time[bodies] = 0.0
        if self._motion is not None:  # back on the orbit at the epoch
            self.orbit_rows[bodies] = self._motion.rows()
            self._state.x[bodies] = self.orbit_position(bodies)

    def __getstate__(self) -> dict[str, Any]:
        """Pickled with the integrator's name (its compiled step is looked up again)."""
        out = self.__dict__.copy()
        out["_integrator"] = self._integrator.name
        out["_plan"] = replace(self._plan, integrator=self._integrator.name)
        return out

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._integrator = get_integrator(state["_integrator"])
        self._plan = replace(self._plan, integrator=self._integrator)
        cols = self._cols  # pickling copies views apart: make the state views of it again
        self._state = State(cols[0:3].T, cols[3:6].T, cols[6:10].T, cols[10:13].T)
        self._momenta = self._wheel_rows(cols)
        self._set_arrays()

    # ---------------------------------------------------------------------------------------
    def step(self, action: ArrayLike | None = None) -> BoolArray:
        """Advance every body by ``dt``.

        Args:
            action: (N, action_dim), (1, action_dim) or (action_dim,) command for the
                actuators, real numbers; None = zeros. Each component is clipped to [-1, 1]
                (full throttle), the one rule of every entry point (:meth:`advance`, the envs);
                a NaN or inf is refused.

        Returns:
            (N,) mask of the bodies whose state turned non-finite in this step (only with
            ``on_error="freeze"``; they are left at their state before the step). Read-only.

        Raises:
            ValueError: if ``action`` has the wrong shape or type, or a non-finite entry.
            NumericalInstabilityError: if a state turns non-finite with ``on_error="raise"``.
        """
        a = action  # first the common cases: no command, or a float64 array used as it is
        if self._direct:
            u = None
            if a is None:
                u = self._no_command
            elif type(a) is np.ndarray and a.dtype is _FLOAT64:
                u = (
                    a[None]
                    if a.shape == self._one_command
                    else a
                    if a.shape in self._shapes
                    else None
                )
                if u is not None and not (u.flags.c_contiguous and a.base is not self._cols):
                    u = None
            if u is not None:
                code = self._integrator.world_step(*self._arrays, u)
                if code == 0:
                    self.step_count += 1
                    return self._none_failed
                return self._outcome(code, None)
        return self.advance(None if a is None else self._check_action(a))

    def advance(self, command: FloatArray | None) -> BoolArray:
        """:meth:`step` with a command of the right shape already: None, or a C-contiguous
        float64 (N, action_dim) or (1, action_dim) array (environments that shape their
        actions call this). A NaN or inf in it raises ``ValueError``, nothing stepped."""
        if command is None:
            u = self._no_command
        else:  # a view of the state: copied, as the compiled step's arrays must not overlap
            u = command.copy() if command.base is self._cols else command
        if self._orbit is not None:  # each body's field at its step's middle
            self.magnetic_field[:] = self._orbit.at(self.orbit_time + 0.5 * self._dt)
        if self._noisy or self._magnetic:  # the core reads them after the A components
            u = self._carried(u)
        # A failed body is left at its state before the step: by the kernel itself for one
        # substep; for several, and for the other bodies of a batch under "raise" (which leaves
        # the whole world as it was), from this copy.
        backup = self._cols.copy() if self._copy_before_step else None
        # The passes keep a frozen body's x, v, q, w; its lagging thrust levels (rows from
        # THRUST, which the hardware advances per segment) come back from the copy.
        frozen = self._status == FROZEN if self._lagged else None
        if self._serial:
            code = self._integrator.world_step(*self._arrays, u)
        else:
            entry, arrays = self._integrator.world_step_threads, (*self._arrays, u)
            code = call_threaded(lambda t: entry(arrays, 0, self._n, t))
        if frozen is not None and frozen.any():
            self._cols[THRUST:, frozen] = backup[THRUST:, frozen]
        outcome = self._outcome(code, backup)  # raises where the world was left as it was
        if self.orbit_time is not None:
            self.orbit_time += self._dt
        return outcome

    def _carried(self, command: FloatArray) -> FloatArray:
        """(N, A + ...) the command (N | 1, A), then the :attr:`thrust_factors` where noisy and
        the :attr:`magnetic_field` where magnetorquers act, each checked."""
        parts = [np.broadcast_to(command, (self._n, self.action_dim))]
        if self._noisy:
            f = np.asarray(self.thrust_factors, dtype=np.float64)
            if f.shape != (self._n, self.action_dim) or not np.all(np.isfinite(f) & (f >= 0.0)):
                raise ValueError(
                    f"thrust_factors: expected finite factors >= 0 of shape ({self._n}, "
                    f"{self.action_dim}), got shape {f.shape}; draw them with "
                    "draw_thrust_factors"
                )
            parts.append(f)
        if self._magnetic:
            try:  # one field (3,) for every body, or each body's (N, 3)
                b = np.asarray(self.magnetic_field, dtype=np.float64)
                b = np.broadcast_to(b, (self._n, 3))
            except (TypeError, ValueError):
                b = np.full((self._n, 3), np.nan)  # refused below, named
            if not np.all(np.isfinite(b)):
                got = " ".join(repr(self.magnetic_field).split())
                raise ValueError(
                    f"magnetic_field: expected finite fields [T], (3,) or ({self._n}, 3), world "
                    f"frame, got {got if len(got) <= 60 else got[:57] + '...'}"
                )
            parts.append(b)
        return np.ascontiguousarray(np.concatenate(parts, axis=1))

    def _outcome(self, code: int, backup: FloatArray | None) -> BoolArray:
        """The step's result from the world step's ``code`` (:mod:`rigid_env.core.stepping`)."""
        if code == 0:  # the common case: nothing failed, no body past the stable range
            self.step_count += 1
            return self._none_failed
        bad_command, failures, beyond = decode(code)
        if bad_command:
            raise ValueError("action: contains NaN or inf; every command must be a finite number")
        if beyond and not self._warned:
            self._warn_speed()
        if not failures:
            self.step_count += 1
            return self._none_failed
        bad = self._status == FAILED
        if backup is not None:
            self._cols[:, bad] = backup[:, bad]
        limited = self._over_limit(bad)
        if self.on_error == "raise":
            self._status[bad] = HEALTHY
            if backup is not None:
                self._cols[:] = backup
            self._counts[1] = 0.0  # dop853's carried substeps are the failed step's: dropped
            if limited is not None:
                raise limited
            bodies, step = np.flatnonzero(bad).tolist(), self.step_count + 1
            cause = self._likely_cause(bad)
            wheels = self._wheels is not None
            raise NumericalInstabilityError(
                bodies, step, self._integrator.name, self._dt, cause, wheels=wheels
            )
        if limited is not None:
            warnings.warn(str(limited), RuntimeWarning, stacklevel=3)
        self._status[bad] = FROZEN
        self.step_count += 1
        return bad

    def _over_limit(self, bad: BoolArray) -> SubstepLimitError | None:
        """The error for the failed bodies that ran out of substeps (None if none did): those
        that took more than ``max_substeps`` in the step (exact for ``substeps = 1``; with more
        passes a body that failed otherwise after that many substeps is counted here too)."""
        if self.tolerances is None:
            return None
        rtol, atol, limit = self.tolerances
        over = bad & (self._counts[0] > limit)
        if not over.any():
            return None
        return SubstepLimitError(
            np.flatnonzero(over).tolist(), self.step_count + 1, self._integrator.name, self._dt,
            f"max_substeps = {limit} substeps at rtol {rtol:g}, atol {atol:g}",
        )  # fmt: skip

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
        if self.integrator.name == "exact_free" or getattr(self, "_warned_asymmetry", False):
            return
        inertia = np.atleast_2d(self.model.inertia)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.abs(np.roll(inertia, -1, axis=1) - np.roll(inertia, -2, axis=1)) / inertia
        worst = np.nanmax(ratio, axis=1)
        if not np.any(worst > ASYMMETRY_LIMIT):
            return
        self._warned_asymmetry = True
        b = int(np.argmax(worst))
        exact = "" if self._wheels is not None else "'exact_free' (exact for any moments), or "
        warnings.warn(
            f"body {b}: principal moments {inertia[b].tolist()} break the triangle inequality "
            f"(|I_j - I_k| / I_i = {worst[b]:.3g} > {ASYMMETRY_LIMIT:g}; a real body has at "
            f"most 1): Euler's equations turn w up to {worst[b]:.3g}x faster than |w|^2, and "
            f"integrator {self.integrator.name!r} errs that much more per step; use a dt "
            f"{worst[b]:.3g}x smaller, or {exact}check the moments",
            RuntimeWarning,
            stacklevel=3,
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

    def accelerations(
        self,
        x: ArrayLike,
        v: ArrayLike,
        q: ArrayLike,
        w: ArrayLike,
        action: ArrayLike | None = None,
    ) -> tuple[FloatArray, FloatArray]:
        """Linear (world) [m/s^2] and angular (body) [rad/s^2] accelerations (N, 3) of this
        world's bodies and effects at the given (N, 3|4) state, under a command (N | 1, A) (and
        the :attr:`magnetic_field`):
        the right-hand side ``v' = F / m``, ``I w' = tau - w x I w`` of the compiled step."""
        cols = np.ascontiguousarray(np.hstack([np.atleast_2d(a) for a in (x, v, q, w)]).T)
        n = cols.shape[1]
        model = self._model_cols if n == self._n else self.model.columns(n)
        if model.shape[0] > MODEL_WIDTH and n != self._n:
            raise ValueError(f"x, v, q, w: the bodies have their own maps, give {self._n} rows")
        u = self._check_action(action)
        u = self._no_command if u is None else u
        if self._magnetic:  # the field each body sees rides with its command
            if n != self._n:
                raise ValueError(
                    f"x, v, q, w: each body has its magnetic_field, give {self._n} rows"
                )
            u = self._carried(u)
        out = np.empty((cols.shape[1], 6))
        if self._wheels is not None:  # at the wheels' momenta now
            if n != self._n:
                raise ValueError(f"x, v, q, w: each body has its wheels, give {self._n} rows")
            cols = np.ascontiguousarray(np.vstack([cols, self._cols[STATE_WIDTH:]]))
        derivatives(self.params, model, cols, u, out)
        return out[:, 0:3], out[:, 3:6]

    # ---------------------------------------------------------------------------------------
    def kinetic_energy(self) -> FloatArray:
        """(N,) translational + rotational kinetic energy [J]."""
        return kinetic_energy(self.model, self.state)

    def energy(self) -> FloatArray:
        """(N,) total mechanical energy [J]: kinetic plus the potential of conservative effects."""
        e = self.kinetic_energy()
        if self._wheels is not None:  # each wheel's h_k^2 / (2 J_k)
            e = e + 0.5 * np.sum(self.wheel_momentum**2 / self._wheels.inertia, axis=1)
        for eff in self.force_effects:
            u = eff.potential_energy(self.model, self.state)
            if u is not None:
                e = e + u
        return e

    def angular_momentum_world(self) -> FloatArray:
        """(N, 3) spin angular momentum about the COM, world frame, ``R (I w + sum_k a_k h_k)``
        [kg m^2/s] (the wheels' momenta ``h_k`` where the body has wheels)."""
        body = self.model.inertia * self.state.w
        if self._wheels is not None:
            body = body + self.wheel_momentum @ self._wheels.axes
        return quat_rotate(self.state.q, body)


def kinetic_energy(model: BodyModel, s: State) -> FloatArray:
    """(N,) ``1/2 m |v|^2 + 1/2 sum_k I_k w_k^2`` [J]."""
    vv, iww = s.v * s.v, model.inertia * s.w * s.w  # summed by columns, in a fixed order
    trans = vv[:, 0] + vv[:, 1] + vv[:, 2]
    rot = iww[:, 0] + iww[:, 1] + iww[:, 2]
    return 0.5 * (model.mass * trans + rot)
