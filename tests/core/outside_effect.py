"""An effect the core has never seen, registered from outside (``RIGID_ENV_EFFECTS=
outside_effect``; :mod:`rigid_env.core.effect`): a linear spring pulling the centre of mass to
an anchor, ``F = -k (x - a)``. It imports only what a declaration needs (not the core's
layout, which it extends)."""

from __future__ import annotations

import math

from rigid_env.core.effect import Effect
from rigid_env.core.jit import kernel


@kernel
def spring(x, v, q, w, m, c, f, tau):
    """``F = -k (x - a)`` [N], world frame, no torque."""
    k = c.spring_k
    force = (-k * (x[0] - c.anchor_x), -k * (x[1] - c.anchor_y), -k * (x[2] - c.anchor_z))
    return (f[0] + force[0], f[1] + force[1], f[2] + force[2]), tau


@kernel
def spring_bound(x, m, c):
    """``sqrt(V(x))``, ``V = k/2 |x - a|^2``: a spring releases at most its stored energy."""
    d2 = (x[0] - c.anchor_x) ** 2 + (x[1] - c.anchor_y) ** 2 + (x[2] - c.anchor_z) ** 2
    return math.sqrt(0.5 * c.spring_k * d2)


EFFECTS = (
    Effect(
        "spring",
        ("spring_k", "anchor_x", "anchor_y", "anchor_z"),  # k [N/m]; anchor, world frame [m]
        spring,
        potential_bound=spring_bound,
    ),
)
