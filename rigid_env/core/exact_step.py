"""The world step of the array integrator ``exact_free``: Strang splitting of the exact
torque-free flow (:mod:`rigid_env.core.exact`, NumPy arrays over all bodies) with the compiled
kicks, speed limit, maps and guard of :mod:`rigid_env.core.stepping`."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.exact import free_rotation_exact
from rigid_env.core.layout import BAD_COMMAND, Body, unpack
from rigid_env.core.rotation import quat_normalize
from rigid_env.core.stepping import (
    energy_roots,
    finish_pass,
    kicks,
    limit_speed_pass,
    segment_kicks,
    segments_pass,
)

FloatArray = NDArray[np.float64]


_INERTIA = slice(Body._fields.index("inertia_x"), Body._fields.index("inertia_z") + 1)
_ISOTROPIC = Body._fields.index("isotropic")


def exact_free(
    p: FloatArray,
    model: FloatArray,
    state: FloatArray,
    status: NDArray[np.uint8],
    wrenches: FloatArray,
    momenta: FloatArray,
    places: FloatArray,
    command: FloatArray,
) -> int:
    """The world step of ``exact_free``, arguments and result as a compiled entry's
    (:func:`rigid_env.core.stepping.advance`; ``wrenches`` a scratch of thrusters as hardware,
    :func:`_exact_free_hardware`; ``momenta`` the wheels' rows and ``places`` the orbit's
    scratch, both empty: it steps no wheels and no orbit): per substep the speed limit, then
    Strang splitting ``kick(h/2) -> [x += h v ; exact torque-free flow] -> kick(h/2)`` with
    the compiled kicks of ``splitting`` and the Jacobi elliptic flow
    (:func:`rigid_env.core.exact.free_rotation_exact`), after the last the same maps and guard
    as the compiled step (:func:`rigid_env.core.stepping.finish_pass`)."""
    if not np.all(np.isfinite(command)):
        return BAD_COMMAND
    c = unpack(p)
    before = state.copy()
    inertia = np.ascontiguousarray(model[_INERTIA].T)
    isotropic = bool(np.all(model[_ISOTROPIC] != 0.0))
    x, v, q, w = state[0:3].T, state[3:6].T, state[6:10].T, state[10:13].T
    if c.hardware != 0.0:
        with np.errstate(all="ignore"):
            roots = _exact_free_hardware(p, model, state, wrenches, command, inertia, isotropic)
        return finish_pass(p, model, state, before, status, roots)
    with np.errstate(all="ignore"):
        roots = energy_roots(p, model, state, command, c.h * c.substeps)
        for _ in range(int(c.substeps)):
            limit_speed_pass(p, state)
            if c.any_force != 0.0:
                kicks(p, model, state, command, 0.5 * c.h)
            x += c.h * v
            q[:], w[:] = free_rotation_exact(q, w, inertia, c.h, isotropic)
            if c.any_force != 0.0:
                kicks(p, model, state, command, 0.5 * c.h)
            q[:] = quat_normalize(q)
    return finish_pass(p, model, state, before, status, roots)


def _exact_free_hardware(
    p: FloatArray,
    model: FloatArray,
    state: FloatArray,
    wrenches: FloatArray,
    command: FloatArray,
    inertia: FloatArray,
    isotropic: bool,
) -> FloatArray:
    """``exact_free``'s substeps with thrusters as hardware (:mod:`rigid_env.core.thrusters`):
    each substep cut at every body's switch times into segments of per-body lengths ``s``
    (:func:`rigid_env.core.stepping.segments_pass`), each segment one Strang step ``kick(s/2)
    -> [x += s v ; exact torque-free flow for s] -> kick(s/2)`` under the wrench held over it;
    a body whose substep has no further segment is left as it is (a select, not a flow by 0).
    Returns each body's reach for the guard (:func:`rigid_env.core.stepping.segments_pass`)."""
    c = unpack(p)
    n = state.shape[1]
    x, v, q, w = state[0:3].T, state[3:6].T, state[6:10].T, state[10:13].T
    lengths, t = np.zeros(n), np.zeros(n)
    substeps = int(c.substeps)
    roots = None
    for k in range(substeps):
        limit_speed_pass(p, state)
        if roots is None:  # sqrt(E) at the start, then the reach s B of every segment
            roots = energy_roots(p, model, state, command, 0.0)
        t[:] = k * c.h
        t1 = c.dt if k == substeps - 1 else (k + 1) * c.h
        while segments_pass(p, model, state, command, (t, t1), (lengths, wrenches, roots)):
            moving = lengths > 0.0
            segment_kicks(p, model, state, wrenches, lengths, 0.5)
            x += np.where(moving[:, None], lengths[:, None] * v, 0.0)
            q1, w1 = free_rotation_exact(q, w, inertia, lengths, isotropic)
            q[:], w[:] = np.where(moving[:, None], q1, q), np.where(moving[:, None], w1, w)
            segment_kicks(p, model, state, wrenches, lengths, 0.5)
            q[:] = np.where(moving[:, None], quat_normalize(q), q)
    return roots
