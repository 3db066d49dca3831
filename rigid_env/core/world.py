"""World: a batch of bodies, the active effects, an integrator and a time step.

``World.step`` reads as its stages: check the command -> the compiled world step of the
integrator over the (13, N) state columns (a pass of actuator wrenches -> ``substeps`` passes of
the integrator, each evaluating only the active effects and ending in the guard, the per-step
maps after the last; over the cores from :data:`THREAD_MIN_BODIES` bodies on) -> counters and
reports. A body whose state turns NaN or inf is never handed back silently (the ``on_error`` of
the world's :class:`Guard`).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core.actuator import state_rows, where
from rigid_env.core.effects import (
    ForceEffect,
    StepMap,
    pack,
)
from rigid_env.core.integrators import check_wheels, get_integrator
from rigid_env.core.layout import (
    BAD_COMMAND,
    FAILED,
    FROZEN,
    HEALTHY,
    MODEL_WIDTH,
    PLACE_ROWS,
    STATE_WIDTH,
    THRUST,
    WRENCH_WIDTH,
    Params,
    decode,
    no_places,
    no_wheel_rows,
    unpack,
)
from rigid_env.core.orbit_state import ORBIT_WIDTH, OrbitMotion
from rigid_env.core.plan import (
    DEFAULT_ATOL,
    DEFAULT_MAX_SUBSTEPS,
    DEFAULT_RTOL,
    MAX_BODIES,
    Guard,
    StepPlan,
    Tolerances,
    check_state,
    check_tolerances,
    number,
    refuse_retired,
)
from rigid_env.core.state import (
    BAD_MASS,
    INERTIA_MESSAGE,
    MASS_MESSAGE,
    BodyModel,
    State,
    lay_model_columns,
)
from rigid_env.core.stepping import derivatives
from rigid_env.core.threads import THREAD_MIN_BODIES, call_threaded, threaded
from rigid_env.core.world_actuation import ActuationViews
from rigid_env.core.world_checks import ASYMMETRY_LIMIT, Diagnostics
from rigid_env.core.world_energy import EnergyViews, kinetic_energy
from rigid_env.core.world_errors import (
    STABLE_AT_SPEED,
    NumericalInstabilityError,
    SubstepLimitError,
    chosen_bodies,
    stable_choices,
)
from rigid_env.core.world_orbit import OrbitViews
from rigid_env.core.world_settings import Settings
from rigid_env.core.world_wheels import WheelState

__all__ = [
    "ASYMMETRY_LIMIT",
    "DEFAULT_ATOL",
    "DEFAULT_MAX_SUBSTEPS",
    "DEFAULT_RTOL",
    "STABLE_AT_SPEED",
    "THREAD_MIN_BODIES",
    "WORLD_KEYWORDS",
    "Guard",
    "NumericalInstabilityError",
    "SubstepLimitError",
    "Tolerances",
    "World",
    "call_threaded",
    "check_state",
    "check_tolerances",
    "kinetic_energy",
    "stable_choices",
    "threaded",
]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
_FLOAT64 = np.dtype(np.float64)
WORLD_KEYWORDS = (
    "model", "effects", "integrator", "dt", "substeps", "state", "n", "guard", "tolerances",
)  # fmt: skip
"""The keywords :class:`World` takes (named where it refuses another)."""


class World(Settings, ActuationViews, WheelState, OrbitViews, EnergyViews, Diagnostics):
    """A batch of ``N`` free rigid bodies stepped together.

    Args:
        model: mass properties, per body (N) or shared (1).
        effects: the active effects, force effects and per-step maps; nothing else is simulated.
        integrator: a name from :data:`rigid_env.core.integrators.INTEGRATORS`.
        dt: time per :meth:`step` [s].
        substeps: integrator steps per :meth:`step` (each of ``dt / substeps``).
        state: initial state; ``n`` bodies at rest if omitted.
        n: number of bodies when ``state`` is omitted.
        guard: what the step does about a blow-up (:class:`Guard`): the limit on ``|w|``
            (``max_angular_speed``, off by default) and ``on_error``: ``"raise"`` raises
            :class:`NumericalInstabilityError` when a state turns non-finite; ``"freeze"``
            keeps failed bodies at their last finite state, flagged in :attr:`failed`, the
            others going on bit for bit as without them (vector envs).
        tolerances: an error-controlled integrator's (``dop853``) :class:`Tolerances`
            (``rtol``, ``atol``, ``max_substeps``, ``adaptive``); None: its defaults
            (:data:`DEFAULT_RTOL`, :data:`DEFAULT_ATOL`, :data:`DEFAULT_MAX_SUBSTEPS`); refused
            for a fixed-step integrator.

    Raises:
        ValueError: one line naming a setting the step cannot take and what it must be.
        TypeError: for a keyword the world does not take; one of the settings that moved into
            :class:`Guard` or :class:`Tolerances` (``max_angular_speed``, ``on_error``,
            ``rtol``, ``atol``, ``max_substeps``, ``adaptive``) names the record call to pass.
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
        guard: Guard = Guard(),
        tolerances: Tolerances | None = None,
        **retired: Any,
    ) -> None:
        refuse_retired("World", retired, WORLD_KEYWORDS)
        self._plan = plan = StepPlan.build(effects, integrator, dt, substeps, guard, tolerances)
        self._integrator = plan.integrator
        self._dt, self._substeps = plan.dt, plan.substeps
        tol = plan.tolerances
        control = None if tol is None else (tol.rtol, tol.atol, tol.max_substeps, tol.adaptive)
        self.params = pack(
            plan.effects,
            plan.h,
            plan.substeps,
            plan.guard.max_angular_speed,
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
        carried = self.action_dim * (1 + self._noisy) + 3 * self._magnetic
        self._carry = np.empty((self._n, carried)) if carried > self.action_dim else None
        """(N, A + ...) the command and what rides after it (:meth:`_carried`), refilled for
        each step."""
        self.orbit_time = np.zeros(self._n) if self._orbit is not None else None
        """(N,) each body's time along the coils' ``orbit`` [s], advanced by ``dt`` a step and
        cleared by :meth:`restart` (set it to put bodies at other points of the orbit); None
        without an orbit."""
        self._state = State(cols[0:3].T, cols[3:6].T, cols[6:10].T, cols[10:13].T)
        self._wrenches = np.zeros((WRENCH_WIDTH, self._n))
        # where each body is on its orbit in the substep in hand (stepping.orbit_passes)
        self._places = np.zeros((PLACE_ROWS, self._n)) if self._motion else no_places()
        self._copy_before_step = (
            (plan.guard.on_error == "raise" and self._n > 1)
            or plan.substeps > 1
            or hw.lagged != 0.0
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

    def set_model_rows(self, bodies: Any) -> None:
        """Lay out again the compiled model rows of the ``bodies`` (an index, slice or mask)
        after their mass properties were set in place in :attr:`model`'s own per-body arrays, as
        a randomised reset draws them: the other bodies' rows are left as they are, so a reset
        of a few of N bodies costs what they do, not N (:meth:`set_model` lays out all N).

        Raises:
            ValueError: where the bodies share one model row (give each its own with
                :meth:`set_model` first), or for a mass or moment that is not finite and > 0.
        """
        if self.model.mass.shape[0] != self._n or self.model.inertia.shape[0] != self._n:
            raise ValueError(
                "model: the bodies share one row of mass properties; give each body its own "
                "with set_model(BodyModel(masses (N,), moments (N, 3))) first"
            )
        rows = np.atleast_1d(chosen_bodies(self._n, bodies))
        inertia = self.model.inertia[rows]
        code, worst, at = lay_model_columns(self._model_cols, rows, self.model.mass[rows], inertia)
        if code:
            raise ValueError(MASS_MESSAGE if code == BAD_MASS else INERTIA_MESSAGE)
        if rows.size:
            self._warn_asymmetry(worst, inertia[at], int(rows[at]), stacklevel=3)

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

    def _wheel_rows(self, cols: FloatArray) -> tuple[FloatArray, ...]:
        """The K wheels' momenta, a K-tuple of (N,) views of their rows of the state ``cols``,
        their own arrays for the compiled step (the other rows are never read through them,
        and the compiler vectorises the wheels' passes only where it need not check that the
        wheels' rows and the state's overlap). K is a constant of the tuple's type, so that the
        step is compiled for the K in use (:func:`rigid_env.core.layout.wheel_shape`). Without
        wheels :func:`rigid_env.core.layout.no_wheel_rows`, whose type leaves the wheels'
        passes out of the compiled step."""
        if self._wheels is None:
            return no_wheel_rows()
        return tuple(cols[THRUST + k] for k in range(self._wheels.axes.shape[0]))

    def _set_arrays(self) -> None:
        """The compiled step's arrays but the command (whose place is last); an
        error-controlled integrator also writes the substeps each body took."""
        self._arrays = (
            self.params, self._model_cols, self._cols, self._status, self._wrenches, self._momenta,
            self._places,
        )  # fmt: skip
        if self._integrator.error_control:
            self._arrays += (self._counts,)

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

    def restart(self, bodies: Any) -> None:
        """Clear what the ``bodies`` (an index, or a mask, of the N) carry from one step to the
        next besides their state, as :meth:`reset` does for all: the thrusters' lagging levels
        (valves closed), the substep ``dop853`` tries first (its initial-step guess again) and
        the time along an orbit (:attr:`orbit_time`, back to 0).
        For a new episode of some bodies of a world, so that it repeats a fresh world's.

        Raises:
            ValueError: for an index out of range or a mask of the wrong length.
        """
        chosen_bodies(self._n, bodies)
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
            self._orbit.at(self.orbit_time + 0.5 * self._dt, out=self.magnetic_field)
        if self._noisy or self._magnetic:  # the core reads them after the A components
            u = self._carried(u, finite=False)
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
        if code == BAD_COMMAND and self._magnetic:  # nothing stepped: name the field if it is
            self._check_field()  # the one not finite
        if frozen is not None and frozen.any():
            self._cols[THRUST:, frozen] = backup[THRUST:, frozen]
        outcome = self._outcome(code, backup)  # raises where the world was left as it was
        if self.orbit_time is None:
            return outcome
        if self._n == 1:  # a scalar add: NumPy's in-place add costs ~1.5 us on one element
            self.orbit_time[0] += self._dt
        else:
            self.orbit_time += self._dt
        return outcome

    def _carried(self, command: FloatArray, finite: bool = True) -> FloatArray:
        """(N, A + ...) the command (N | 1, A), then the :attr:`thrust_factors` where noisy and
        the :attr:`magnetic_field` where magnetorquers act, each checked (the field's
        finiteness only with ``finite``: the compiled step refuses a non-finite command, its
        carried columns included, before it steps, and :meth:`advance` then names the field).
        The world's own array, refilled at each call."""
        carry, a = self._carry, self.action_dim
        carry[:, :a] = command
        if self._noisy:
            f = np.asarray(self.thrust_factors, dtype=np.float64)
            if f.shape != (self._n, self.action_dim) or not np.all(np.isfinite(f) & (f >= 0.0)):
                raise ValueError(
                    f"thrust_factors: expected finite factors >= 0 of shape ({self._n}, "
                    f"{self.action_dim}), got shape {f.shape}; draw them with "
                    "draw_thrust_factors"
                )
            carry[:, a : 2 * a] = f
        if self._magnetic:
            try:  # one field (3,) for every body, or each body's (N, 3)
                b = self.magnetic_field
                carry[:, -3:] = b if type(b) is np.ndarray else np.asarray(b, dtype=np.float64)
            except (TypeError, ValueError):
                carry[:, -3:] = np.nan  # refused below, named
                finite = True
            if finite:
                self._check_field()
        return carry

    def _check_field(self) -> None:
        """A ValueError naming the :attr:`magnetic_field` where :meth:`_carried` carried a
        number that is not finite (or no field of the shape (3,) or (N, 3))."""
        if not np.all(np.isfinite(self._carry[:, -3:])):
            got = " ".join(repr(self.magnetic_field).split())
            raise ValueError(
                f"magnetic_field: expected finite fields [T], (3,) or ({self._n}, 3), world "
                f"frame, got {got if len(got) <= 60 else got[:57] + '...'}"
            )

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
        if self._plan.guard.on_error == "raise":
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
        tol = self._plan.tolerances
        if tol is None:
            return None
        over = bad & (self._counts[0] > tol.max_substeps)
        if not over.any():
            return None
        return SubstepLimitError(
            np.flatnonzero(over).tolist(), self.step_count + 1, self._integrator.name, self._dt,
            f"max_substeps = {tol.max_substeps} substeps at rtol {tol.rtol:g}, atol {tol.atol:g}",
        )  # fmt: skip

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
        if self._wheels is not None or self._motion is not None:  # its wheels, its orbit now
            if n != self._n:
                raise ValueError(
                    f"x, v, q, w: each body has its wheels or orbit, give {self._n} rows"
                )
            cols = np.ascontiguousarray(np.vstack([cols, self._cols[STATE_WIDTH:]]))
        derivatives(self.params, model, cols, self._momenta, u, out)
        return out[:, 0:3], out[:, 3:6]

    #
