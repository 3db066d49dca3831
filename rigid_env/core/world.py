"""World: a batch of bodies, the active effects, an integrator and a time step.

``World.step`` reads as its stages: check the command -> integrate ``substeps`` times (each
step of the integrator evaluates only the active effects) -> per-step maps (damping) -> guard
against non-finite states.

The guard. A body whose state turns NaN or inf is never handed back silently: by default the
step raises :class:`NumericalInstabilityError` (a ``FloatingPointError``) naming the body, the
step, the integrator and what to do; with ``on_error="freeze"`` the failed bodies are held at
their last finite state and flagged in :attr:`World.failed`, and every other body goes on
exactly (bit for bit) as it would without them: no step mixes bodies, the guard's test is per
body, and the implicit solvers iterate each body to its own tolerance.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core import columns
from rigid_env.core.dynamics import Dynamics
from rigid_env.core.effects import ForceEffect, StepMap
from rigid_env.core.integrators import COLUMN_KERNELS, get_integrator
from rigid_env.core.rotation import quat_rotate
from rigid_env.core.state import BodyModel, State
from rigid_env.core.trace import Deopt, compile_batch, compile_one_body

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

ROW_LANE_MAX = 24
"""Largest batch of bodies sharing one model that the single-body lane steps body by body
(on a two-core machine a batch costs the same either way at about 30 bodies)."""
MAX_UNROLLED_SUBSTEPS = 8
"""A single body's step is compiled with at most this many substeps written out."""


class NumericalInstabilityError(FloatingPointError):
    """A body's state turned non-finite; the message names the body, step, integrator and fix."""

    def __init__(self, bodies: Sequence[int], step: int, integrator: str, dt: float) -> None:
        self.bodies = list(bodies)
        self.step = step
        self.integrator = integrator
        self.dt = dt
        shown = ", ".join(str(b) for b in self.bodies[:5])
        if len(self.bodies) > 5:
            shown += f" ... ({len(self.bodies)} bodies)"
        super().__init__(
            f"state of body {shown} became non-finite at step {step} (integrator "
            f"{integrator!r}, dt {dt:g} s); use a smaller dt or more substeps, or a stable "
            f"integrator ('implicit_gyro' or 'splitting')"
        )


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
        max_angular_speed: optional limit on ``|w|`` [rad/s]; None (the default) = off, and then
            it costs nothing. As PhysX's ``PxRigidDynamic::setMaxAngularVelocity``
            (``DyBodyCoreIntegrator.h``, ``bodyCoreComputeUnconstrainedVelocity``: ``w *=
            sqrt(max^2 / |w|^2)`` when ``|w| > max``), an angular velocity above the limit is
            scaled down to it, its direction kept: before every substep (the velocity the
            integrator starts from, as PhysX clamps the velocity that then moves the pose) and
            after the last one (so the stored state obeys the limit). A safety valve against
            runaway spin, not physics: it removes energy and angular momentum.
        on_error: ``"raise"`` raises :class:`NumericalInstabilityError` when a state turns
            non-finite; ``"freeze"`` keeps the failed bodies at their last finite state, flags
            them in :attr:`failed` and lets the others go on (what vector envs use).
    """

    def __init__(
        self,
        model: BodyModel,
        effects: Sequence[ForceEffect | StepMap] = (),
        integrator: str = "rk4",
        dt: float = 0.01,
        substeps: int = 1,
        state: State | None = None,
        n: int = 1,
        max_angular_speed: float | None = None,
        on_error: Literal["raise", "freeze"] = "raise",
    ) -> None:
        if not (np.isfinite(dt) and dt > 0.0):
            raise ValueError(f"dt: must be a finite time step > 0 [s], got {dt}")
        if int(substeps) != substeps or substeps < 1:
            raise ValueError(f"substeps: must be an integer >= 1, got {substeps}")
        if max_angular_speed is not None and not (
            np.isfinite(max_angular_speed) and max_angular_speed > 0.0
        ):
            raise ValueError(
                f"max_angular_speed: must be a finite number > 0 [rad/s] or None "
                f"(off), got {max_angular_speed}"
            )
        if on_error not in ("raise", "freeze"):
            raise ValueError(f"on_error: must be 'raise' or 'freeze', got {on_error!r}")
        self.model = model
        self.force_effects = tuple(e for e in effects if isinstance(e, ForceEffect))
        self.step_maps = tuple(e for e in effects if isinstance(e, StepMap))
        unknown = [e for e in effects if not isinstance(e, ForceEffect | StepMap)]
        if unknown:
            raise TypeError(f"effects: {unknown[0]!r} is neither a ForceEffect nor a StepMap")
        self.dynamics = Dynamics(model, self.force_effects)
        self.integrator = get_integrator(integrator)
        self.dt = float(dt)
        self.substeps = int(substeps)
        self.h = self.dt / self.substeps
        self.max_angular_speed = None if max_angular_speed is None else float(max_angular_speed)
        self.on_error = on_error
        if state is not None:
            check_state(state)
        self.state = state.copy() if state is not None else State.zeros(n)
        if model.n not in (1, self.state.n):
            raise ValueError(f"model: has {model.n} bodies but the state has {self.state.n}")
        self.failed = np.zeros(self.state.n, dtype=bool)
        self.step_count = 0
        self._n = self.state.n
        self._lanes: dict[tuple[bool, bool, bool], Callable | None] = {}
        self._last_lane: tuple[Any, bool, Callable | None] = (None, False, None)
        self._batches: dict[tuple[bool, bool, bool, bool], Callable | None] = {}
        self._buffers: FloatArray | None = None
        self._set_lanes()

    # ---------------------------------------------------------------------------------------
    @property
    def state(self) -> State:
        """The bodies' state as (N, 3) and (N, 4) arrays.

        A world of one body on the single-body lane keeps its state as 13 floats between
        steps (:meth:`advance_one`) and makes the arrays at their first read after a step:
        views of one (1, 13) array, so an edit of them in place edits the state."""
        s = self._state
        if s is None:
            packed = self._packed = np.array([self._values])
            s = self._state = State(
                packed[:, 0:3], packed[:, 3:6], packed[:, 6:10], packed[:, 10:13]
            )
        return s

    @state.setter
    def state(self, state: State) -> None:
        self._state: State | None = state
        self._values: Sequence[float] = ()
        self._packed: FloatArray | None = None

    def __getstate__(self) -> dict[str, Any]:
        """Pickled without the compiled steps (they are compiled again at first use)."""
        state = self.__dict__.copy()
        state["_lanes"] = {}
        state["_last_lane"] = (None, False, None)
        state["_batches"] = {}
        state["_buffers"] = None
        return state

    @property
    def n(self) -> int:
        """Number of bodies."""
        return self._n

    @property
    def action_dim(self) -> int:
        """Length of the command vector (all actuators, in scene order)."""
        return self.dynamics.action_dim

    @property
    def time(self) -> float:
        """Simulated time since the last :meth:`reset` [s]."""
        return self.step_count * self.dt

    def set_model(self, model: BodyModel) -> None:
        """Replace the mass properties (per body or shared), e.g. for domain randomisation."""
        if model.n not in (1, self.n):
            raise ValueError(f"model: has {model.n} bodies but the world has {self.n}")
        self.model = model
        self.dynamics = Dynamics(model, self.force_effects)
        self._set_lanes()

    @property
    def single_body_lane(self) -> bool:
        """Whether this world steps on the single-body lane (:meth:`advance_one` applies)."""
        return self._one_body

    def _set_lanes(self) -> None:
        """Decide whether :meth:`step` takes the single-body lane: bodies stepped one by one
        on Python floats by the integrator's column kernel (``symplectic_euler``, ``rk4``,
        ``splitting``) compiled to straight-line code (:mod:`rigid_env.core.trace`), instead of
        on (N,) arrays. The lane runs the very operations a batch runs, so it gives the same
        numbers bit for bit, without NumPy's per-call cost on tiny arrays: a world of one
        body takes it, and so does a small batch of bodies that share one model (up to
        :data:`ROW_LANE_MAX` bodies, where a step of the batch costs about the same either
        way). It needs effects and step maps with a column form and no angular speed limit.

        A larger batch under the same conditions takes the batch lane: the same kernel on
        (N,) columns compiled to ufunc calls into reused buffers (:func:`compile_batch`), the
        same numbers as the kernel on arrays at about three quarters of its cost."""
        lane = (
            self.integrator.name in COLUMN_KERNELS
            and self.max_angular_speed is None
            and self.dynamics.columns_supported
            and all(type(m).apply_columns is not StepMap.apply_columns for m in self.step_maps)
        )
        self._one_body = lane and self.n == 1
        self._row_lane = lane and 1 < self.n <= ROW_LANE_MAX and self.model.n == 1
        self._batch_lane = lane and self.n > 1 and not self._row_lane

    def reset(self, state: State) -> None:
        """Replace the state (copied), clear failures and the step counter.

        Raises:
            ValueError: for a wrong body count, shape, a non-finite number or a zero quaternion.
        """
        if state.n != self.n:
            raise ValueError(f"state: has {state.n} bodies, this world has {self.n}")
        check_state(state)
        self.state = state.copy()
        self.failed[:] = False
        self.step_count = 0

    # ---------------------------------------------------------------------------------------
    def step(self, action: ArrayLike | None = None) -> BoolArray:
        """Advance every body by ``dt``.

        Args:
            action: (N, action_dim) or (action_dim,) command for the actuators; None = zeros.

        Returns:
            (N,) mask of the bodies whose state turned non-finite in this step (only with
            ``on_error="freeze"``; they are left at their state before the step).

        Raises:
            ValueError: if ``action`` has the wrong shape or a non-finite entry.
            NumericalInstabilityError: if a state turns non-finite with ``on_error="raise"``.
        """
        return self.advance(self._check_action(action))

    def advance(self, command: FloatArray | None) -> BoolArray:
        """:meth:`step` with a command already checked: None, or a finite (N, action_dim) or
        (1, action_dim) float64 array (what :meth:`step` makes of its argument; environments
        that validate their actions call this)."""
        if self._one_body:
            return self._step_one_body(command)
        if self._row_lane:
            return self._step_rows(command)
        act = command
        before = self.state
        with np.errstate(over="ignore", invalid="ignore"):
            after = self._step_batch(before, act) if self._batch_lane else None
            if after is None:
                after = self._integrate(before, act)
                for m in self.step_maps:
                    m.apply(after)
            bad = self._guard(after)
        if bad is not None:
            after.put(bad, before)
            self.failed |= bad
        self.state = after
        self.step_count += 1
        return bad if bad is not None else np.zeros(self.n, dtype=bool)

    def _step_one_body(self, command: FloatArray | None) -> BoolArray:
        """:meth:`advance` through :meth:`advance_one`."""
        failed = self.advance_one(None if command is None else command[0].tolist())
        return np.ones(1, dtype=bool) if failed else np.zeros(1, dtype=bool)

    def advance_one(self, u: list[float] | None) -> bool:
        """:meth:`advance` of a world of one body on the single-body lane (see
        :meth:`_set_lanes`), with the command as ``action_dim`` checked floats (or None);
        returns whether the body failed (the guard, as :meth:`advance`)."""
        new = self._lane_step(u, self.one_body_values())
        if not math.isfinite(sum(new)) and not all(map(math.isfinite, new)):
            if self.on_error == "raise":
                raise NumericalInstabilityError(
                    [0], self.step_count + 1, self.integrator.name, self.dt
                )
            self.step_count += 1
            self.failed[0] = True
            return True
        self.step_count += 1
        self._state, self._values = None, new  # arrays only when read (see state)
        return False

    def _step_rows(self, command: FloatArray | None) -> BoolArray:
        """:meth:`advance` of a small batch on the single-body lane, body by body."""
        s = self.state
        rows = [
            a + b + c + d
            for a, b, c, d in zip(
                s.x.tolist(), s.v.tolist(), s.q.tolist(), s.w.tolist(), strict=True
            )
        ]
        n = len(rows)
        if command is None:
            commands: list[Any] = [None] * n
        else:
            commands = command.tolist() if command.shape[0] == n else command.tolist() * n
        new = [self._lane_step(u, r) for u, r in zip(commands, rows, strict=True)]
        bad = [i for i, r in enumerate(new) if not math.isfinite(sum(r))]
        bad = [i for i in bad if not all(map(math.isfinite, new[i]))]
        if bad and self.on_error == "raise":
            raise NumericalInstabilityError(bad, self.step_count + 1, self.integrator.name, self.dt)
        for i in bad:
            new[i] = rows[i]  # frozen at its last finite state
        mask = np.zeros(n, dtype=bool)
        mask[bad] = True
        self.failed |= mask
        packed = np.array(new)
        self.state = State(packed[:, 0:3], packed[:, 3:6], packed[:, 6:10], packed[:, 10:13])
        self.step_count += 1
        return mask

    def _lane_step(self, u: Sequence[float] | None, values: Sequence[float]) -> Sequence[float]:
        """One body's step on the lane: the compiled step, or the kernel itself on floats
        where the compiled step's guards send it back (or it could not be compiled)."""
        lane = self._compiled_lane(u, values)
        if lane is not None:
            try:
                return lane(u or (), values, self.dynamics.model_values)
            except (Deopt, ArithmeticError, ValueError):  # a guard, or no float result
                pass
        return self._one_body_columns(self.dynamics, columns.SCALAR, u, values)

    def one_body_values(self) -> Sequence[float]:
        """The 13 numbers ``(x, v, q, w)`` of a world of one body, as floats (the same
        sequence until the state changes: do not edit it)."""
        s = self._state
        if s is None:
            return self._values
        p = self._packed
        if p is not None and s.x.base is p and s.v.base is p and s.q.base is p and s.w.base is p:
            return p[0].tolist()
        return [*s.x[0].tolist(), *s.v[0].tolist(), *s.q[0].tolist(), *s.w[0].tolist()]

    def _one_body_columns(
        self, dyn: Dynamics, ops: columns.Ops, u: Sequence | None, values: Sequence
    ) -> list:
        """One world step over columns (a body's floats, or a batch's (N,) columns when the
        batch lane traces it): the actuators' wrench, ``substeps`` steps of the integrator's
        column kernel, the step maps. ``values`` and the result are the state's 13 components
        ``(x, v, q, w)``."""
        x, v, q, w = values[0:3], values[3:6], values[6:10], values[10:13]
        wrench = dyn.wrench_columns(u)
        kernel = COLUMN_KERNELS[self.integrator.name]
        for _ in range(self.substeps):
            x, v, q, w = kernel(dyn, ops, x, v, q, w, wrench, self.h)
        for m in self.step_maps:
            v, w = m.apply_columns(v, w)
        return [*x, *v, *q, *w]

    def _compiled_lane(self, u: list[float] | None, values: list[float]) -> Callable | None:
        """:meth:`_one_body_columns` compiled to straight-line code (:mod:`rigid_env.core.trace`)
        for this world's effects, integrator and kind of inertia, traced at its first use with
        these inputs. The mass properties are inputs of the compiled step, so a new model (domain
        randomisation) reuses it. None where the step cannot be traced (an effect whose column
        form calls a function on a number) or has too many substeps to write out."""
        dyn = self.dynamics
        last = self._last_lane
        if last[0] is dyn and last[1] is (u is None):
            return last[2]
        key = (u is None, dyn.model_columns[4], dyn.has_gyro)
        if key in self._lanes:
            self._last_lane = (dyn, u is None, self._lanes[key])
            return self._lanes[key]
        lane = None
        if self.substeps <= MAX_UNROLLED_SUBSTEPS:
            try:
                lane = compile_one_body(
                    self._traced_step(),
                    [("u", u or []), ("s", values), ("m", dyn.model_values)],
                )
            except TypeError:  # an operation the trace cannot record
                lane = None
        self._lanes[key] = lane
        self._last_lane = (dyn, u is None, lane)
        return lane

    def _traced_step(self) -> Callable:
        """:meth:`_one_body_columns` as the compilers trace it, ``step(ops, u, values, m)``:
        this world's dynamics with the mass properties ``m`` (:meth:`_model_inputs`' order)
        as inputs, so that a new model reuses the compiled step."""
        dyn = self.dynamics
        iso = dyn.model_columns[4]

        def step(ops, u, values, m):
            traced = copy.copy(dyn)  # the same dynamics with traced mass properties
            traced.__dict__["model_columns"] = (m[0], m[1:4], m[4], m[5:8], iso)
            traced.__dict__.pop("gyro_columns", None)
            return [self._one_body_columns(traced, ops, u or None, values)]

        return step

    def _step_batch(self, s: State, command: FloatArray | None) -> State | None:
        """:meth:`_one_body_columns` of the whole batch through its compiled form (the batch
        lane, see :meth:`_set_lanes`); None where it cannot run (not compiled, or a guard of
        the compiled step failed) and the kernel must step."""
        step = self._compiled_batch(command, s)
        if step is None:
            return None
        n = self.n
        out = State(*(np.empty((n, k), order="F") for k in (3, 3, 4, 3)))
        dests = _batch_columns(None, out)[1]
        if self._buffers is None or self._buffers.shape[0] < step.buffers:
            self._buffers = np.empty((step.buffers, n))
        try:
            step(*_batch_columns(command, s), self._model_inputs(), dests, self._buffers)
        except Deopt:
            return None
        return out

    def _model_inputs(self) -> list[Any]:
        """The mass properties as the compiled steps take them: ``[mass, I1, I2, I3, 1/mass,
        1/I1, 1/I2, 1/I3]``, floats for a shared model, (N,) columns for one per body."""
        mass, inertia, inv_m, inv_i, _ = self.dynamics.model_columns
        return [mass, *inertia, inv_m, *inv_i]

    def _compiled_batch(self, command: FloatArray | None, s: State) -> Callable | None:
        """The batch lane's compiled step for this world's effects, integrator and kind of
        model (traced at first use on this state and command), or None where the kernel
        cannot be compiled for a batch (a body-by-body choice: a batch mixing isotropic and
        other bodies, an effect calling a function of NumPy on a column)."""
        dyn = self.dynamics
        iso = dyn.model_columns[4]
        if not isinstance(iso, bool) or self.substeps > MAX_UNROLLED_SUBSTEPS:
            return None
        shared = self.model.n == 1
        key = (command is None, shared, iso, dyn.has_gyro)
        if key in self._batches:
            return self._batches[key]
        u, values = _batch_columns(command, s)
        try:
            batch = compile_batch(
                self._traced_step(),
                [("u", u, True), ("s", values, True), ("m", self._model_inputs(), not shared)],
            )
        except (TypeError, ValueError):  # an operation on a column the trace cannot record
            batch = None
        self._batches[key] = batch
        return batch

    def _check_action(self, action: ArrayLike | None) -> FloatArray | None:
        if action is None or self.action_dim == 0:
            if action is not None and np.size(action) != 0:
                raise ValueError(
                    f"action: this world has no actuators, got {np.size(action)} numbers"
                )
            return None
        act = np.asarray(action, dtype=np.float64)
        if act.ndim == 1:
            act = act[None, :]
        if act.ndim != 2 or act.shape[-1] != self.action_dim or act.shape[0] not in (1, self.n):
            raise ValueError(
                f"action: expected shape ({self.n}, {self.action_dim}) or "
                f"({self.action_dim},), got {np.shape(action)}"
            )
        if not np.all(np.isfinite(act)):
            raise ValueError("action: contains NaN or inf; every command must be a finite number")
        return act

    def _integrate(self, s: State, act: FloatArray | None) -> State:
        step, dyn, h, w_max = self.integrator.step, self.dynamics, self.h, self.max_angular_speed
        before = s
        dyn.hold(act)  # the command is constant over the step: actuator wrench computed once
        try:
            for _ in range(self.substeps):
                if w_max is not None:
                    s = _clamped(s, w_max)
                s = step(dyn, s, act, h)
        finally:
            dyn.release()
        if w_max is not None:
            s = _clamped(s, w_max)
        # Integrators may pass an unchanged array through (x' = 0 leaves x as it was); copy it so
        # that the step maps, which work in place, cannot reach the state kept for a rollback.
        if any(getattr(s, k) is getattr(before, k) for k in "xvqw"):
            s = State(
                *(
                    getattr(s, k).copy() if getattr(s, k) is getattr(before, k) else getattr(s, k)
                    for k in "xvqw"
                )
            )
        return s

    def _guard(self, s: State) -> BoolArray | None:
        """Mask of non-finite bodies, or None if all are finite (one reduction when healthy).

        Raises NumericalInstabilityError under ``on_error="raise"``.
        """
        total = s.x.sum() + s.v.sum() + s.q.sum() + s.w.sum()
        if np.isfinite(total):
            return None
        bad = ~(
            np.isfinite(s.x).all(1)
            & np.isfinite(s.v).all(1)
            & np.isfinite(s.q).all(1)
            & np.isfinite(s.w).all(1)
        )
        if not bad.any():  # finite values whose sum overflowed
            return None
        if self.on_error == "raise":
            raise NumericalInstabilityError(
                np.flatnonzero(bad).tolist(), self.step_count + 1, self.integrator.name, self.dt
            )
        return bad

    # ---------------------------------------------------------------------------------------
    def kinetic_energy(self) -> FloatArray:
        """(N,) translational + rotational kinetic energy [J]."""
        return kinetic_energy(self.model, self.state)

    def energy(self) -> FloatArray:
        """(N,) total mechanical energy [J]: kinetic plus the potential of conservative effects."""
        e = self.kinetic_energy()
        for eff in self.force_effects:
            u = eff.potential_energy(self.model, self.state.x)
            if u is not None:
                e = e + u
        return e

    def angular_momentum_world(self) -> FloatArray:
        """(N, 3) spin angular momentum about the centre of mass, world frame [kg m^2/s]."""
        return angular_momentum_world(self.model, self.state)


def _batch_columns(command: FloatArray | None, s: State) -> tuple[list[Any], list[Any]]:
    """The columns of a command (none for None) and of a state's ``x, v, q, w``, the inputs
    of a compiled batch step."""
    u = [] if command is None else [command[:, k] for k in range(command.shape[1])]
    return u, [a[:, k] for a in (s.x, s.v, s.q, s.w) for k in range(a.shape[1])]


def clamp_angular_speed(w: FloatArray, max_speed: float) -> None:
    """Scale rows of ``w`` (N, 3) in place so that ``|w| <= max_speed`` (PhysX's clamp: the
    direction is kept). A non-finite row stays non-finite (inf becomes NaN) for the guard."""
    speed = np.sqrt(np.sum(w * w, axis=1))
    over = speed > max_speed
    if over.any():
        w[over] *= (max_speed / speed[over])[:, None]


def _clamped(s: State, max_speed: float) -> State:
    """``s`` itself if every ``|w| <= max_speed``, else a state sharing ``x, v, q`` with a
    clamped copy of ``w`` (the input is never modified)."""
    if not np.any(np.sum(s.w * s.w, axis=1) > max_speed * max_speed):
        return s
    w = s.w.copy()
    clamp_angular_speed(w, max_speed)
    return State(s.x, s.v, s.q, w)


def check_state(state: State) -> None:
    """Check a state given from outside: shapes ``(N, 3|4)``, finite numbers, no zero
    quaternion.

    Raises:
        ValueError: naming the field, the first bad body and the fix.
    """
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


def kinetic_energy(model: BodyModel, s: State) -> FloatArray:
    """(N,) ``1/2 m |v|^2 + 1/2 sum_k I_k w_k^2`` [J] (summed by columns: a body's value is the
    same alone or in any batch)."""
    return columns.kinetic_energy(
        model.mass,
        [model.inertia[:, k] for k in range(3)],
        [s.v[:, k] for k in range(3)],
        [s.w[:, k] for k in range(3)],
    )


def angular_momentum_world(model: BodyModel, s: State) -> FloatArray:
    """(N, 3) ``R (I w)`` [kg m^2/s]."""
    return quat_rotate(s.q, model.inertia * s.w)


def simulate(world: World, steps: int, action: ArrayLike | None = None) -> dict[str, FloatArray]:
    """Step ``world`` ``steps`` times with a constant command and record the trajectory.

    Returns:
        Arrays of every body with a leading time axis of length ``T = steps + 1``: ``t (T,)``,
        ``position (T, N, 3)``, ``velocity``, ``orientation (T, N, 4)``,
        ``angular_velocity_body``, ``angular_velocity_world``, ``energy (T, N)``,
        ``angular_momentum_world (T, N, 3)``.
    """
    if int(steps) != steps or steps < 0:
        raise ValueError(f"steps: must be an integer >= 0, got {steps}")
    rec: dict[str, list[FloatArray]] = {
        k: []
        for k in (
            "position",
            "velocity",
            "orientation",
            "angular_velocity_body",
            "angular_velocity_world",
            "energy",
            "angular_momentum_world",
        )
    }

    def record() -> None:
        s = world.state
        rec["position"].append(s.x.copy())
        rec["velocity"].append(s.v.copy())
        rec["orientation"].append(s.q.copy())
        rec["angular_velocity_body"].append(s.w.copy())
        rec["angular_velocity_world"].append(quat_rotate(s.q, s.w))
        rec["energy"].append(world.energy())
        rec["angular_momentum_world"].append(world.angular_momentum_world())

    t0 = world.time
    record()
    for _ in range(int(steps)):
        world.step(action)
        record()
    out = {k: np.stack(v) for k, v in rec.items()}
    out["t"] = t0 + world.dt * np.arange(int(steps) + 1)
    return out
