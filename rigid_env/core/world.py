"""World: a batch of bodies, the active effects, an integrator and a time step.

``World.step`` reads as its stages: check the command -> integrate ``substeps`` times (each
step of the integrator evaluates only the active effects) -> per-step maps (damping) -> guard
against non-finite states.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.core.dynamics import Dynamics
from rigid_env.core.effects import ForceEffect, StepMap
from rigid_env.core.integrators import get_integrator
from rigid_env.core.rotation import quat_rotate
from rigid_env.core.state import BodyModel, State

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


class NumericalInstabilityError(FloatingPointError):
    """A body's state turned non-finite; the message names the body, step, integrator and fix."""

    def __init__(self, bodies: Sequence[int], step: int, integrator: str, dt: float) -> None:
        self.bodies = list(bodies)
        self.step = step
        self.integrator = integrator
        shown = ", ".join(str(b) for b in self.bodies[:5]) + (" ..." if len(self.bodies) > 5 else "")
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
        max_angular_speed: optional clamp on ``|w|`` [rad/s] after every substep (PhysX's
            ``maxAngularVelocity``: ``w`` is scaled down to this length); None = off.
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
        if max_angular_speed is not None and not (max_angular_speed > 0.0):
            raise ValueError(f"max_angular_speed: must be > 0 [rad/s] or omitted, got {max_angular_speed}")
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
        self.max_angular_speed = max_angular_speed
        self.on_error = on_error
        self.state = state.copy() if state is not None else State.zeros(n)
        if model.n not in (1, self.state.n):
            raise ValueError(f"model: has {model.n} bodies but the state has {self.state.n}")
        self.failed = np.zeros(self.state.n, dtype=bool)
        self.step_count = 0

    # ---------------------------------------------------------------------------------------
    @property
    def n(self) -> int:
        """Number of bodies."""
        return self.state.n

    @property
    def action_dim(self) -> int:
        """Length of the command vector (all actuators, in scene order)."""
        return self.dynamics.action_dim

    @property
    def time(self) -> float:
        """Simulated time since the last :meth:`reset` [s]."""
        return self.step_count * self.dt

    def reset(self, state: State) -> None:
        """Replace the state (copied), clear failures and the step counter."""
        if state.n != self.n:
            raise ValueError(f"state: has {state.n} bodies, this world has {self.n}")
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
        act = self._check_action(action)
        before = self.state
        with np.errstate(over="ignore", invalid="ignore"):
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

    def _check_action(self, action: ArrayLike | None) -> FloatArray | None:
        if action is None or self.action_dim == 0:
            if action is not None and np.size(action) != 0:
                raise ValueError(f"action: this world has no actuators, got {np.size(action)} numbers")
            return None
        act = np.asarray(action, dtype=np.float64)
        if act.ndim == 1:
            act = act[None, :]
        if act.shape[-1] != self.action_dim or act.shape[0] not in (1, self.n):
            raise ValueError(f"action: expected shape ({self.n}, {self.action_dim}) or "
                             f"({self.action_dim},), got {np.shape(action)}")
        if not np.all(np.isfinite(act)):
            raise ValueError("action: contains NaN or inf; every command must be a finite number")
        return act

    def _integrate(self, s: State, act: FloatArray | None) -> State:
        step, dyn, h = self.integrator.step, self.dynamics, self.h
        for _ in range(self.substeps):
            s = step(dyn, s, act, h)
            if self.max_angular_speed is not None:
                clamp_angular_speed(s.w, self.max_angular_speed)
        if s is self.state:  # an integrator that returned its input (cannot happen today)
            s = s.copy()
        return s

    def _guard(self, s: State) -> BoolArray | None:
        """Mask of non-finite bodies, or None if all are finite (one reduction when healthy).

        Raises NumericalInstabilityError under ``on_error="raise"``.
        """
        total = s.x.sum() + s.v.sum() + s.q.sum() + s.w.sum()
        if np.isfinite(total):
            return None
        bad = ~(np.isfinite(s.x).all(1) & np.isfinite(s.v).all(1) & np.isfinite(s.q).all(1)
                & np.isfinite(s.w).all(1))
        if not bad.any():  # finite values whose sum overflowed
            return None
        if self.on_error == "raise":
            raise NumericalInstabilityError(np.flatnonzero(bad).tolist(), self.step_count + 1,
                                            self.integrator.name, self.dt)
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


def clamp_angular_speed(w: FloatArray, max_speed: float) -> None:
    """Scale rows of ``w`` (N, 3) in place so that ``|w| <= max_speed`` (PhysX's clamp)."""
    speed = np.sqrt(np.sum(w * w, axis=1))
    over = speed > max_speed
    if over.any():
        w[over] *= (max_speed / speed[over])[:, None]


def kinetic_energy(model: BodyModel, s: State) -> FloatArray:
    """(N,) ``1/2 m |v|^2 + 1/2 sum_k I_k w_k^2`` [J]."""
    return 0.5 * (model.mass * np.sum(s.v * s.v, axis=1)
                  + np.sum(model.inertia * s.w * s.w, axis=1))


def angular_momentum_world(model: BodyModel, s: State) -> FloatArray:
    """(N, 3) ``R (I w)`` [kg m^2/s]."""
    return quat_rotate(s.q, model.inertia * s.w)


def simulate(world: World, steps: int, action: ArrayLike | None = None) -> dict[str, FloatArray]:
    """Step ``world`` ``steps`` times with a constant command and record the trajectory.

    Returns:
        Arrays of every body with a leading time axis of length ``T = steps + 1``: ``t (T,)``, ``position (T, N, 3)``, ``velocity``, ``orientation (T, N, 4)``,
        ``angular_velocity_body``, ``angular_velocity_world``, ``energy (T, N)``,
        ``angular_momentum_world (T, N, 3)``.
    """
    if int(steps) != steps or steps < 0:
        raise ValueError(f"steps: must be an integer >= 0, got {steps}")
    rec: dict[str, list[FloatArray]] = {k: [] for k in (
        "position", "velocity", "orientation", "angular_velocity_body", "angular_velocity_world",
        "energy", "angular_momentum_world")}

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
