"""Numerical stability: the hard cases of ``tests/stability``, each with the bound it must meet.

Each case is a function that runs one hard situation (a Dzhanibekov flip, a fast spin, thin rods
and flat plates, a separatrix, a long horizon, extreme scales) and returns what it reached; the
bounds it is held to are named constants here. :mod:`rigid_env.bench.stability` runs them all at
full length into a table; the test-suite runs the same functions at shorter lengths.

Why two lengths: one step of one body costs ~0.2-0.4 ms of NumPy call overhead whatever the
batch size (a few hundred small-array operations), so 60,000 sequential steps take ~20 s.
Batching only helps across bodies, not across time; so several cases that share a step size
run as bodies of one batch (:func:`hard_batch`), and cases that share the step-size-free
product ``h |w|`` could be rescaled onto one ``h`` (the map of every integrator here depends on
``h`` and ``w`` only through ``h w`` for torque-free motion, since Euler's equations are
homogeneous of degree 2 in ``w``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import ellipj, ellipkinc

from rigid_env.core.effects import ForceEffect, Gravity, QuadraticDrag, StepMap, Thrusters
from rigid_env.core.exact import free_rotation_exact
from rigid_env.core.plan import Guard, Tolerances
from rigid_env.core.rotation import (
    quat_angle_between,
    quat_from_rotvec,
    quat_integrate_exp,
    quat_integrate_linear,
    quat_mul,
    quat_norm,
    quat_rotate,
)
from rigid_env.core.state import BodyModel, State
from rigid_env.core.world import NumericalInstabilityError, World

FloatArray = NDArray[np.float64]

# --------------------------------------------------------------------------------------------
# Bounds (the tests import these; each says what it means)
# --------------------------------------------------------------------------------------------

FLIP_TIME_RTOL = 0.01
"""Dzhanibekov: the last flip of the intermediate axis lands within 1 % of the exact time."""
L_NORM_RTOL = 1.0e-9
"""Fast spin / thin bodies: ``splitting`` keeps ``|L|`` to 1e-9 relative (it is exact up to
rounding, ~1e-14 over 20,000 steps)."""
ENERGY_GAIN_RTOL = 1.0e-14
"""'Never gains energy': no step raises ``E`` by more than 1e-14 relative, ~50 ulps, the
rounding of ``E = 1/2 sum I w^2`` itself (a real gain of one Newton step at ``h|w| = 2``
is 3e-7)."""
SPLITTING_ENERGY_BELOW_LIMIT = 1.0e-5
"""Fast spin at ``h|w| = 1.5`` (below splitting's linear stability limit 2.195 for spin about
the major axis of (1, 2, 3)): ``splitting``'s relative energy error stays below 1e-5."""
SEPARATRIX_W_TOL = 2.0e-3
"""Separatrix: ``rk4`` at 60 Hz stays within 2e-3 rad/s of the exact ``w(t)`` over 10 s."""
UNIT_Q_TOL = 1.0e-12
"""Long horizon: ``| |q| - 1 |`` below 1e-12 after every step."""
SECULAR_DRIFT_FACTOR = 2.0
"""Long horizon: the largest energy error of the last 10 % of the run is at most twice the
largest of the first 10 % (a bounded oscillation, no secular drift)."""
SCALE_RTOL = 1.0e-9
"""Scale invariance: mass x 1e-6 / 1e6 and lengths x 1e-3 / 1e3 give the same rotation (and
``w``, and position / length scale) to 1e-9 relative."""
EXP_MAP_TOL = 1.0e-12
"""Orientation at speed: the exponential map matches the exact rotation of constant ``w`` to
1e-12 rad after a second of 60 Hz steps at 50 rad/s."""
LINEAR_LAG_RTOL = 0.15
"""Orientation at speed: the linear update's lag per step is ``(h|w|)^3 / 12`` to 15 % at
``h|w| = 0.83`` (the next term of the series, ``-(h|w|)^5 / 80``, is 10 % of the first)."""
ROTATION_EDGE_TOL = 5.0e-14
"""Rotation edges: round trips and shortest arcs at the edges land within rounding [rad]. The
longest chain checked, Euler -> q -> Euler -> q and the angle between the two quaternions,
rounds each quaternion component by <= 3 transcendental calls (4 ulps each, NumPy's AVX-512
functions included) and 4 operations per ``euler_to_quat`` (28 U, U = 2^-53), the recovered
angles by <= 3 calls of pi / 2 (38 U), and the angle between is at most twice the distance of
the components: 4 (2 * 28 + 38) U = 4.2e-14 (measured: 2.4e-15 with glibc's sin and cos)."""

# --------------------------------------------------------------------------------------------
# Exact torque-free rotation (Landau & Lifshitz, Mechanics, Sec. 37)
# --------------------------------------------------------------------------------------------


def exact_body_rates(inertia: ArrayLike, w0: ArrayLike, t: ArrayLike) -> FloatArray:
    """Exact body-frame angular velocity ``w(t)`` (T, 3) [rad/s] of a torque-free body.

    For ``I1 < I2 < I3`` and ``M^2 > 2 E I2`` (L&L eq. 37.10):

        w1 = A1 cn(tau), w2 = A2 sn(tau), w3 = A3 dn(tau),   tau = lam (t - t0)
        A1^2 = (2 E I3 - M^2) / (I1 (I3 - I1)),  A2^2 = (2 E I3 - M^2) / (I2 (I3 - I2)),
        A3^2 = (M^2 - 2 E I1) / (I3 (I3 - I1)),  lam^2 = (I3 - I2)(M^2 - 2 E I1) / (I1 I2 I3),
        k^2 = (I2 - I1)(2 E I3 - M^2) / ((I3 - I2)(M^2 - 2 E I1)),

    and for ``M^2 < 2 E I2`` the same with axes 1 and 3 exchanged (then ``I1 > I2 > I3``, and
    the formula solves the time-reversed equations, which is what an odd permutation of the
    axes turns Euler's equations into). Other axis orders are sorted first (an odd sort
    reverses time again); ``w3 < 0`` is handled by the symmetry ``(w1, w2, w3) -> (-w1, w2,
    -w3)`` of Euler's equations; ``t0`` comes from ``am(lam t0) = atan2(w2 / A2, w1 / A1)``.

    Args:
        inertia: (3,) principal moments, pairwise distinct [kg m^2].
        w0: (3,) initial body angular velocity [rad/s], not on the separatrix.
        t: (T,) times [s].
    """
    inertia = np.asarray(inertia, dtype=np.float64)
    w0 = np.asarray(w0, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    order = np.argsort(inertia)
    time_sign = float(np.linalg.det(np.eye(3)[order]))  # odd permutation: time runs backwards
    moments = inertia[order]
    w = w0[order]
    m2 = float(np.sum((moments * w) ** 2))
    e2 = float(np.sum(moments * w * w))
    swapped = m2 < e2 * moments[1]
    if swapped:
        moments, w = moments[::-1], w[::-1]
    i1, i2, i3 = moments
    flip = -1.0 if w[2] < 0.0 else 1.0
    w = w * np.array([flip, 1.0, flip])
    a1 = np.sqrt((e2 * i3 - m2) / (i1 * (i3 - i1)))
    a2 = np.sqrt((e2 * i3 - m2) / (i2 * (i3 - i2)))
    a3 = np.sqrt((m2 - e2 * i1) / (i3 * (i3 - i1)))
    lam = np.sqrt((i3 - i2) * (m2 - e2 * i1) / (i1 * i2 * i3))
    k2 = (i2 - i1) * (e2 * i3 - m2) / ((i3 - i2) * (m2 - e2 * i1))
    tau0 = ellipkinc(np.arctan2(w[1] / a2, w[0] / a1), k2)
    sn, cn, dn, _ = ellipj(tau0 + lam * time_sign * t, k2)
    out = np.stack([a1 * cn, a2 * sn, a3 * dn], axis=-1) * np.array([flip, 1.0, flip])
    if swapped:
        out = out[..., ::-1]
    result = np.empty_like(out)
    result[..., order] = out
    return result


def sign_changes(t: FloatArray, y: FloatArray) -> FloatArray:
    """Times (linearly interpolated) at which ``y`` (T,) changes sign."""
    s = np.sign(y)
    k = np.flatnonzero(s[1:] * s[:-1] < 0.0)
    return t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k])


# --------------------------------------------------------------------------------------------
# Running a world and recording it
# --------------------------------------------------------------------------------------------


@dataclass
class Run:
    """A recorded run: ``x (T+1, N, 3)``, ``q (T+1, N, 4)``, ``w (T+1, N, 3)`` up to the last
    completed step.

    Attributes:
        steps: steps completed.
        error: the :class:`NumericalInstabilityError` message if the run stopped on one.
        failed: (N,) bodies the world flagged (``on_error="freeze"``).
        first_failure: (N,) first step at which each body failed (-1: never).
        all_finite: every recorded state was finite (never a silent NaN).
    """

    x: FloatArray
    q: FloatArray
    w: FloatArray
    steps: int
    error: str | None
    failed: NDArray[np.bool_]
    first_failure: NDArray[np.int64]
    all_finite: bool


def record(world: World, steps: int, action: ArrayLike | None = None) -> Run:
    """Step ``world`` ``steps`` times, recording ``x``, ``q`` and ``w`` after each step.

    A :class:`NumericalInstabilityError` ends the run early (``Run.error`` keeps its message);
    the world's state then is the last finite one, which is recorded as the final row.
    """
    n = world.n
    x = np.empty((steps + 1, n, 3))
    q = np.empty((steps + 1, n, 4))
    w = np.empty((steps + 1, n, 3))
    x[0], q[0], w[0] = world.state.x, world.state.q, world.state.w
    first = np.full(n, -1, dtype=np.int64)
    error = None
    done = 0
    for k in range(1, steps + 1):
        try:
            bad = world.step(action)
        except NumericalInstabilityError as exc:
            error = str(exc)
            break
        if bad.any():
            first[(first < 0) & bad] = k
        x[k], q[k], w[k] = world.state.x, world.state.q, world.state.w
        done = k
    x, q, w = x[: done + 1], q[: done + 1], w[: done + 1]
    finite = bool(np.isfinite(x).all() and np.isfinite(q).all() and np.isfinite(w).all())
    return Run(x, q, w, done, error, world.failed.copy(), first, finite)


def energy(inertia: FloatArray, w: FloatArray) -> FloatArray:
    """Rotational kinetic energy ``1/2 sum I w^2`` (...,) of body rates ``w`` (..., 3)."""
    return 0.5 * np.sum(inertia * w * w, axis=-1)


def momentum_world(inertia: FloatArray, w: FloatArray, q: FloatArray) -> FloatArray:
    """World-frame angular momentum ``R(q) I w`` (..., 3)."""
    return quat_rotate(q, inertia * w)


def max_step_gain(e: FloatArray) -> FloatArray:
    """Largest relative one-step energy increase ``(E[k+1] - E[k]) / E[k]`` per body (N,)."""
    if e.shape[0] < 2:
        return np.zeros(e.shape[1:])
    with np.errstate(invalid="ignore", over="ignore"):
        return np.max((e[1:] - e[:-1]) / e[:-1], axis=0)


def torque_free_world(
    inertia: ArrayLike,
    w0: ArrayLike,
    integrator: str,
    dt: float,
    guard: Guard = Guard(),
    tolerances: Tolerances | None = None,
) -> World:
    """A world of torque-free bodies: per-body ``inertia`` (N, 3) and ``w0`` (N, 3), at the
    origin with identity orientation, with the world's ``guard`` and ``tolerances``."""
    inertia = np.atleast_2d(np.asarray(inertia, dtype=np.float64))
    w0 = np.atleast_2d(np.asarray(w0, dtype=np.float64))
    state = State.zeros(w0.shape[0])
    state.w[:] = w0
    model = BodyModel(np.ones(inertia.shape[0]), inertia)
    return World(
        model, (), integrator=integrator, dt=dt, state=state, guard=guard, tolerances=tolerances
    )


# --------------------------------------------------------------------------------------------
# Case: Dzhanibekov (intermediate-axis) flip
# --------------------------------------------------------------------------------------------

DZHANIBEKOV_INERTIA = (1.0, 2.0, 3.0)
DZHANIBEKOV_W0 = (1.0e-3, 3.0, 1.0e-3)
DZHANIBEKOV_DT = 1.0e-3


@dataclass(frozen=True)
class FlipResult:
    """Flips of the intermediate axis (sign changes of ``w2``) against the exact solution."""

    integrator: str
    t_end: float
    flips: int
    exact_flips: int
    last_flip: float
    exact_last_flip: float

    @property
    def last_flip_rel_error(self) -> float:
        """``|t_last - t_last_exact| / t_last_exact`` (inf if the counts differ or are 0)."""
        if self.flips != self.exact_flips or self.flips == 0:
            return float("inf")
        return abs(self.last_flip - self.exact_last_flip) / self.exact_last_flip


def dzhanibekov(integrator: str, t_end: float, dt: float = DZHANIBEKOV_DT) -> FlipResult:
    """Spin ``w = (1e-3, 3, 1e-3)`` about the intermediate axis of ``I = (1, 2, 3)``: the axis
    flips every ~10.4 s (first at 5.6 s). Counts the flips up to ``t_end`` and times the last,
    for ``integrator`` at ``dt`` and for the exact solution."""
    steps = round(t_end / dt)
    world = torque_free_world(DZHANIBEKOV_INERTIA, DZHANIBEKOV_W0, integrator, dt)
    run = record(world, steps)
    t = dt * np.arange(run.steps + 1)
    flips = sign_changes(t, run.w[:, 0, 1])
    exact = sign_changes(t, exact_body_rates(DZHANIBEKOV_INERTIA, DZHANIBEKOV_W0, t)[:, 1])
    last = float(flips[-1]) if flips.size else float("nan")
    exact_last = float(exact[-1]) if exact.size else float("nan")
    return FlipResult(integrator, t_end, int(flips.size), int(exact.size), last, exact_last)


# --------------------------------------------------------------------------------------------
# Case: fast spin, thin rods, flat plates (one batch per integrator, dt = 0.01)
# --------------------------------------------------------------------------------------------

HARD_DT = 0.01
HARD_BODIES: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    # name: (principal moments [kg m^2], initial body rates [rad/s])
    # Fast spin about the major axis of (1, 2, 3): |w| dt = 2 rad per step.
    "fast_spin": ((1.0, 2.0, 3.0), (0.5, 0.5, 200.0)),
    # Thin rods, I1 / I3 = 1e-4 and 1e-6 (rectangular section: I3 - I2 = I1 / 2), spinning about
    # the long axis at 20 rad/s while tumbling.
    "rod_1e-4": ((1.0e-4, 1.0, 1.0 + 0.5e-4), (20.0, 1.0, 0.5)),
    "rod_1e-6": ((1.0e-6, 1.0, 1.0 + 0.5e-6), (20.0, 1.0, 0.5)),
    # Flat plates: I1 + I2 - I3 = 2 int z^2 dm is 1e-4 and 1e-6 of I3, and exactly 0 (a plate
    # of zero thickness, 1 m x 0.5 m, m = 12 kg), on the triangle inequality itself.
    "plate_1e-4": ((1.0, 2.0, 3.0 * (1.0 - 1.0e-4)), (1.0, 0.5, 2.0)),
    "plate_1e-6": ((1.0, 2.0, 3.0 * (1.0 - 1.0e-6)), (1.0, 0.5, 2.0)),
    "plate_flat": ((0.25, 1.0, 1.25), (1.0, 0.5, 2.0)),
}
THIN_BODIES = ("rod_1e-4", "rod_1e-6", "plate_1e-4", "plate_1e-6", "plate_flat")
FORWARD_EULER_W = ("explicit_euler", "symplectic_euler")
"""Integrators whose ``w`` update is forward Euler on Euler's equations (symplectic Euler only
moves ``q`` with the new ``w``): their energy grows on every spin, the thin rods included, so
the thin-body bound excludes both."""


@dataclass
class HardRun:
    """One integrator's batch of :data:`HARD_BODIES` (``on_error="freeze"``)."""

    integrator: str
    names: tuple[str, ...]
    run: Run
    inertia: FloatArray

    def index(self, name: str) -> int:
        """Batch index of body ``name``."""
        return self.names.index(name)

    def l_norm_drift(self, name: str, steps: int | None = None) -> float:
        """Largest ``| |L_k| - |L_0| | / |L_0|`` over the first ``steps`` steps."""
        b = self.index(name)
        w = self.run.w[: None if steps is None else steps + 1, b]
        ln = np.linalg.norm(self.inertia[b] * w, axis=-1)
        return float(np.max(np.abs(ln - ln[0])) / ln[0])

    def l_world_drift(self, name: str, steps: int | None = None) -> float:
        """Largest ``|L_world,k - L_world,0| / |L_0|``."""
        b = self.index(name)
        sl = slice(None, None if steps is None else steps + 1)
        lw = momentum_world(self.inertia[b], self.run.w[sl, b], self.run.q[sl, b])
        return float(np.max(np.linalg.norm(lw - lw[0], axis=-1)) / np.linalg.norm(lw[0]))

    def energy(self, name: str, steps: int | None = None) -> FloatArray:
        """Energy (T+1,) of body ``name``."""
        b = self.index(name)
        return energy(self.inertia[b], self.run.w[: None if steps is None else steps + 1, b])

    def finite(self, name: str, steps: int | None = None) -> bool:
        """Body ``name`` never failed within ``steps`` (and every recorded state is finite)."""
        first = int(self.run.first_failure[self.index(name)])
        within = first < 0 or (steps is not None and first > steps)
        return bool(within and self.run.all_finite)


def hard_batch(integrator: str, steps: int, names: Sequence[str] = tuple(HARD_BODIES)) -> HardRun:
    """Run the bodies ``names`` of :data:`HARD_BODIES` as one batch at ``dt = 0.01`` with
    ``on_error="freeze"``: a body that diverges is held and flagged, the others go on."""
    inertia = np.array([HARD_BODIES[k][0] for k in names])
    w0 = np.array([HARD_BODIES[k][1] for k in names])
    world = torque_free_world(inertia, w0, integrator, HARD_DT, Guard(on_error="freeze"))
    return HardRun(integrator, tuple(names), record(world, steps), inertia)


# --------------------------------------------------------------------------------------------
# Case: needles and plates over thinness ratios, body-frame w against the exact solution
# --------------------------------------------------------------------------------------------

THIN_RATIOS = (*(10.0**-k for k in range(2, 13)), 1.0e-100)
"""Smallest over middle moment of the needles and plates: 1e-2 .. 1e-12, and 1e-100, the
smallest moment a scene accepts."""
THIN_W0 = (0.3, 2.0, 0.1)
"""Initial body rates [rad/s]: a tumble with a spin ``w_x`` about the thin axis (``h |w| =
0.02`` at :data:`THIN_DT`, far inside every integrator's stable range)."""
THIN_DT = 0.01
THIN_GROWTH = 2.0
"""Thinness does not cost accuracy: an integrator's largest ``|w - w_exact|`` over the ratios is
at most twice its error on the thickest body (ratio 1e-2) of the same kind, plus round-off
(:data:`THIN_ROUNDOFF_PER_STEP`). A real body's Euler rates ``(I_j - I_k) / I_i w_j w_k`` stay
below ``|w|^2`` however thin it is (``|I_j - I_k| <= I_i``), so a method whose error follows
those rates has the same error constant at every ratio (measured: equal to 2 or 3 digits); the
three-axis splitting before the middle-moment reference grew like ``1 / I_min`` (3e6 rad/s at
1e-12 in 200 steps)."""
THIN_ROUNDOFF_PER_STEP = 200 * 2.0**-52 * float(np.linalg.norm(THIN_W0))
"""[rad/s] Round-off allowed per step, 200 ulps of ``|w0|`` (9e-14): the splittings round ``w``
by a few ulps a step (measured: 0.2 ulp a step on average over 2,000 steps, errors mostly
cancel); ``exact_free`` evaluates ``ellipkinc``, ``ellipj`` and square roots each step, whose
rounding moves the elliptic phase (measured: up to 23 ulps a step, 4.6e-11 rad/s after
2,000)."""


def thin_inertia(kind: str, ratio: float) -> tuple[float, float, float]:
    """Principal moments [kg m^2] of a ``"needle"`` ``(r, 1, 1)`` (a thin rod: symmetric, its
    ``w_x`` constant and ``(w_y, w_z)`` turning at ``(1 - r) w_x``) or a ``"plate"`` ``(r, 1, 1 +
    r)`` (a flat strip, ``I_z = I_x + I_y`` exactly: asymmetric, moments in that order)."""
    return (ratio, 1.0, 1.0) if kind == "needle" else (ratio, 1.0, 1.0 + ratio)


THIN_KINDS = ("needle", "plate")


@dataclass
class ThinRun:
    """One integrator on every needle and plate of :data:`THIN_RATIOS` (one batch)."""

    integrator: str
    bodies: tuple[tuple[str, float], ...]
    steps: int
    w_error: FloatArray
    """(B,) largest ``|w - w_exact|`` [rad/s] over the run, body frame (inf if it failed)."""
    wx_drift: FloatArray
    """(B,) largest ``|w_x - w_x0|`` [rad/s] (0 exactly for a needle)."""
    speed_drift: FloatArray
    """(B,) largest ``| |w| - |w0| |`` [rad/s] (0 exactly for a needle)."""
    finite: bool

    def errors(self, kind: str) -> FloatArray:
        """``w_error`` of the bodies of ``kind``, in the order of :data:`THIN_RATIOS`."""
        return np.array(
            [e for (k, _), e in zip(self.bodies, self.w_error, strict=True) if k == kind]
        )

    @property
    def roundoff(self) -> float:
        """[rad/s] The round-off allowed over the run: ``steps`` x
        :data:`THIN_ROUNDOFF_PER_STEP`."""
        return self.steps * THIN_ROUNDOFF_PER_STEP

    def growth_bound(self, kind: str) -> float:
        """The bound of :data:`THIN_GROWTH` for ``kind``: twice the error at ratio 1e-2 plus
        :attr:`roundoff`."""
        return THIN_GROWTH * float(self.errors(kind)[0]) + self.roundoff


def thin_bodies(integrator: str, steps: int) -> ThinRun:
    """Every needle and plate of :data:`THIN_RATIOS`, torque-free from :data:`THIN_W0`, for
    ``steps`` steps of :data:`THIN_DT` (``on_error="freeze"``), against the exact solution
    (Jacobi elliptic functions, :func:`rigid_env.core.exact.free_rotation_exact`, evaluated at
    each time from the start, never stepped)."""
    bodies = tuple((kind, r) for kind in THIN_KINDS for r in THIN_RATIOS)
    inertia = np.array([thin_inertia(kind, r) for kind, r in bodies])
    w0 = np.tile(np.asarray(THIN_W0, dtype=np.float64), (len(bodies), 1))
    run = record(
        torque_free_world(inertia, w0, integrator, THIN_DT, Guard(on_error="freeze")), steps
    )
    identity = np.tile([1.0, 0.0, 0.0, 0.0], (len(bodies), 1))
    exact = np.stack(
        [
            free_rotation_exact(identity, w0, inertia, k * THIN_DT, False)[1]
            for k in range(run.steps + 1)
        ]
    )
    with np.errstate(over="ignore", invalid="ignore"):
        w_error = np.max(np.linalg.norm(run.w - exact, axis=-1), axis=0)
        wx_drift = np.max(np.abs(run.w[..., 0] - w0[:, 0]), axis=0)
        speed = np.linalg.norm(run.w, axis=-1)
        speed_drift = np.max(np.abs(speed - speed[0]), axis=0)
    failed = (run.first_failure >= 0) | (run.steps < steps)
    w_error = np.where(failed, np.inf, w_error)
    return ThinRun(integrator, bodies, steps, w_error, wx_drift, speed_drift, run.all_finite)


# --------------------------------------------------------------------------------------------
# Case: explicit Euler on an unstable spin
# --------------------------------------------------------------------------------------------

EXPLICIT_EULER_GROWTH = 264.0
"""Growth factor forward Euler's energy reaches on :func:`explicit_euler_growth` before the
guard stops it. The guard fails a step only if it multiplies ``E`` by more than
``EXPLOSION_FACTOR^2 = 100`` (no forces act); forward Euler's factor is at most ``1 + 3
(h|w|)^2`` on a real body (the derivation of ``EXPLOSION_FACTOR``), so ``|w|`` has reached
``sqrt(99 / 3) / h = 115`` rad/s first, from ``|w0| = 5``: ``E >= I_min |w|^2 / 2 = 6600`` J
against ``E0 = 25.0`` J (measured 3.7e4; 9.4e165 when the run went on to the overflow)."""
UNSTABLE_INERTIA = (1.0, 2.0, 3.0)
UNSTABLE_W0 = (0.1, 5.0, 0.1)
UNSTABLE_DT = 0.05


@dataclass(frozen=True)
class GrowthResult:
    """Energy of forward Euler until the guard stops it."""

    energy: FloatArray
    error: str | None
    last_state_finite: bool

    @property
    def growth(self) -> float:
        """Largest finite ``E / E_0`` before the error (at the very end ``w`` is still finite
        but ``w^2`` may already overflow)."""
        e = self.energy[np.isfinite(self.energy)]
        return float(np.max(e) / self.energy[0])

    @property
    def min_step_ratio(self) -> float:
        """Smallest ``E[k+1] / E[k]``: >= 1 means the energy never decreased."""
        with np.errstate(invalid="ignore", over="ignore"):
            e = self.energy[np.isfinite(self.energy)]
        return float(np.min(e[1:] / e[:-1]))


def explicit_euler_growth(max_steps: int = 100_000) -> GrowthResult:
    """Forward Euler on a tumbling intermediate-axis spin, ``w = (0.1, 5, 0.1)``, ``I = (1, 2,
    3)``, ``dt = 0.05``. Since ``grad E . f = w . (w x I w) = 0`` and ``E`` is quadratic,
    ``E(w + h f) = E(w) + h^2/2 f.I f``: the energy rises every step, and with ``|f| ~ |w|^2``
    the rise feeds itself until the numbers overflow and the guard raises."""
    world = torque_free_world(UNSTABLE_INERTIA, UNSTABLE_W0, "explicit_euler", UNSTABLE_DT)
    run = record(world, max_steps)
    with np.errstate(over="ignore", invalid="ignore"):
        e = energy(np.asarray(UNSTABLE_INERTIA), run.w[:, 0])
    last_finite = bool(np.isfinite(world.state.w).all() and np.isfinite(world.state.q).all())
    return GrowthResult(e, run.error, last_finite)


# --------------------------------------------------------------------------------------------
# Case: near the separatrix
# --------------------------------------------------------------------------------------------

SEPARATRIX_INERTIA = (10.0, 20.0, 26.0)
SEPARATRIX_W0 = (1.0, 15.0, 1.0)
SEPARATRIX_T_END = 10.0


def separatrix_margin(
    inertia: ArrayLike = SEPARATRIX_INERTIA, w0: ArrayLike = SEPARATRIX_W0
) -> float:
    """``(M^2 - 2 E I2) / M^2``: how far (relative) the motion is from the separatrix."""
    i = np.asarray(inertia, dtype=np.float64)
    w = np.asarray(w0, dtype=np.float64)
    m2 = float(np.sum((i * w) ** 2))
    return (m2 - float(np.sum(i * w * w)) * float(np.sort(i)[1])) / m2


@dataclass(frozen=True)
class SeparatrixResult:
    """One integrator at one step size near the separatrix."""

    integrator: str
    dt: float
    steps: int
    error: str | None
    max_w_error: float
    max_rel_energy_error: float
    margin: float
    invariant_flipped: bool

    @property
    def crosses(self) -> bool:
        """The issue's criterion: a relative energy error above the margin crosses."""
        return not (self.max_rel_energy_error <= self.margin)


def separatrix(integrator: str, dt: float, t_end: float = SEPARATRIX_T_END) -> SeparatrixResult:
    """Inertia (10, 20, 26), ``w = (1, 15, 1)``: ``M^2 - 2 E I2`` is 6.2e-4 of ``M^2``, so the
    body circulates about the major axis just outside the separatrix. Records the largest
    ``|w - w_exact|`` [rad/s], the largest relative energy error, and whether the sign of
    ``M^2 - 2 E I2`` (the side of the separatrix) ever changed."""
    steps = round(t_end / dt)
    inertia = np.asarray(SEPARATRIX_INERTIA)
    world = torque_free_world(inertia, SEPARATRIX_W0, integrator, dt)
    run = record(world, steps)
    t = dt * np.arange(run.steps + 1)
    w = run.w[:, 0]
    exact = exact_body_rates(inertia, SEPARATRIX_W0, t)
    with np.errstate(over="ignore", invalid="ignore"):
        e = energy(inertia, w)
        m2 = np.sum((inertia * w) ** 2, axis=-1)
        gap = m2 - 2.0 * e * inertia[1]
        side = np.sign(gap[np.isfinite(gap)])
        w_err = float(np.max(np.linalg.norm(w - exact, axis=-1)))
        e_err = float(np.max(np.abs(e - e[0])) / e[0])
    if run.error is not None:
        w_err, e_err = float("inf"), float("inf")
    return SeparatrixResult(
        integrator,
        dt,
        run.steps,
        run.error,
        w_err,
        e_err,
        separatrix_margin(),
        bool(np.any(side != side[0])),
    )


# --------------------------------------------------------------------------------------------
# Case: orientation at speed (exponential map against the seed's linear update)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class LagResult:
    """Orientation after ``steps`` steps of constant ``w``."""

    h_w: float
    lag_per_step: float
    predicted_lag: float
    exact_lag_per_step: float
    exp_error: float
    linear_error: float


def orientation_lag(speed: float = 50.0, rate: float = 60.0, steps: int = 60) -> LagResult:
    """Constant ``w`` of ``speed`` [rad/s] about a skew axis, stepped at ``rate`` [Hz]: the
    exponential map against the exact rotation, and the linear update's lag, measured per step
    and compared with ``h|w| - 2 atan(h|w|/2) ~ (h|w|)^3 / 12``."""
    h = 1.0 / rate
    axis = np.array([1.0, -2.0, 2.0]) / 3.0
    w = speed * axis
    q0 = quat_from_rotvec(np.array([0.3, -0.2, 0.9]))
    q_exp = q0.copy()
    q_lin = q0.copy()
    for _ in range(steps):
        q_exp = quat_integrate_exp(q_exp, w, h)
        q_lin = quat_integrate_linear(q_lin, w, h)
    exact = quat_mul(q0, quat_from_rotvec(steps * h * w))
    one_lin = quat_integrate_linear(q0, w, h)
    turned = float(quat_angle_between(q0, one_lin))
    hw = h * speed
    return LagResult(
        hw,
        hw - turned,
        hw**3 / 12.0,
        hw - 2.0 * np.arctan(hw / 2.0),
        float(quat_angle_between(q_exp, exact)),
        float(quat_angle_between(q_lin, exact)),
    )


# --------------------------------------------------------------------------------------------
# Case: long horizon
# --------------------------------------------------------------------------------------------

LONG_DT = 0.01
LONG_INERTIA = ((1.0, 2.0, 3.0), (1.0, 2.0, 3.0), (0.3, 1.0, 1.2), (2.0, 2.5, 4.0))
LONG_W0 = ((1.0, 0.5, 2.0), (0.2, 3.0, 0.2), (4.0, 0.3, -1.0), (-1.5, 2.0, 1.0))


@dataclass(frozen=True)
class LongResult:
    """Unit-quaternion and energy figures of a long run."""

    integrator: str
    steps: int
    max_unit_q_error: float
    first_tenth_energy_error: float
    last_tenth_energy_error: float

    @property
    def drift_ratio(self) -> float:
        """Largest energy error of the last 10 % over that of the first 10 %."""
        return self.last_tenth_energy_error / self.first_tenth_energy_error


def long_horizon(steps: int, integrator: str = "splitting") -> LongResult:
    """Four torque-free bodies (:data:`LONG_INERTIA`, :data:`LONG_W0`: around both stable axes
    and across the separatrix) for ``steps`` steps of ``dt = 0.01`` (``h |w|`` up to 0.04).
    The figures are the worst over the bodies."""
    world = torque_free_world(LONG_INERTIA, LONG_W0, integrator, LONG_DT)
    run = record(world, steps)
    unit = float(np.max(np.abs(quat_norm(run.q) - 1.0)))
    e = energy(np.asarray(LONG_INERTIA), run.w)
    rel = np.abs(e - e[0]) / e[0]
    tenth = max(1, steps // 10)
    first = np.max(rel[1 : tenth + 1], axis=0)
    last = np.max(rel[-tenth:], axis=0)
    k = int(np.argmax(last / first))
    return LongResult(integrator, run.steps, unit, float(first[k]), float(last[k]))


# --------------------------------------------------------------------------------------------
# Case: scale invariance
# --------------------------------------------------------------------------------------------

SCALES = ((1.0e-6, 1.0), (1.0e6, 1.0), (1.0, 1.0e-3), (1.0, 1.0e3))
"""(mass factor c, length factor b) pairs compared against (1, 1)."""


def scaled_world(integrator: str, mass_scale: float, length_scale: float) -> World:
    """A body with thrusters, gravity and off-centre quadratic drag, all in units scaled by
    ``c`` (mass) and ``b`` (length): mass ``x c``, inertia ``x c b^2``, points ``x b``, forces
    ``x c b``, ``g x b``, drag ``1/2 rho cd A`` ``x c / b``, positions and velocities ``x b``.
    Every term of the equations of motion then scales so that ``q(t)`` and ``w(t)`` are the
    same and ``x(t)`` is ``b`` times the unscaled one."""
    c, b = mass_scale, length_scale
    model = BodyModel.single(2.0 * c, np.array([0.02, 0.03, 0.04]) * c * b * b)
    effects: list[ForceEffect | StepMap] = [
        Gravity(np.array([0.0, 0.0, -9.81]) * b),
        QuadraticDrag(
            rho=1.225, cd=1.05, area=0.06 * c / b, center_of_pressure=np.array([0.0, 0.0, 0.05]) * b
        ),
        Thrusters(
            points=np.array([[0.2, 0.0, 0.0], [0.0, 0.15, 0.0]]) * b,
            directions=np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
            max_force=np.array([0.1, 0.1]) * c * b,
        ),
    ]
    state = State.from_arrays(
        np.array([0.1, -0.2, 1.0]) * b,
        np.array([0.5, 0.0, 2.0]) * b,
        quat_from_rotvec(np.array([0.2, 0.1, -0.3])),
        [0.3, 2.0, 0.1],
    )
    return World(model, effects, integrator=integrator, dt=0.01, state=state)


@dataclass(frozen=True)
class ScaleResult:
    """Worst relative differences to the unscaled run over :data:`SCALES`."""

    integrator: str
    rotation: float
    rate: float
    position: float

    @property
    def worst(self) -> float:
        """Largest of the three."""
        return max(self.rotation, self.rate, self.position)


SCALE_COMMAND = np.array([0.7, -0.4])


def scale_invariance(integrator: str, steps: int) -> ScaleResult:
    """Run :func:`scaled_world` at every scale of :data:`SCALES` and at (1, 1) with the same
    command; compare rotation angle [rad] (the rotations are O(1) rad, so this is relative),
    ``|w - w_ref| / |w_ref|`` and ``|x / b - x_ref| / |x_ref|`` after every step."""
    ref = record(scaled_world(integrator, 1.0, 1.0), steps, SCALE_COMMAND)
    ref_x = ref.x[:, 0]
    rot = rate = pos = 0.0
    for c, b in SCALES:
        run = record(scaled_world(integrator, c, b), steps, SCALE_COMMAND)
        x = run.x[:, 0] / b
        rot = max(rot, float(np.max(quat_angle_between(run.q, ref.q))))
        rate = max(
            rate,
            float(np.max(np.linalg.norm(run.w - ref.w, axis=-1) / np.linalg.norm(ref.w, axis=-1))),
        )
        pos = max(
            pos, float(np.max(np.linalg.norm(x - ref_x, axis=-1) / np.linalg.norm(ref_x, axis=-1)))
        )
    return ScaleResult(integrator, rot, rate, pos)
