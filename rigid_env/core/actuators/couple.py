"""Thruster couples: two opposed thrusters fired as one command, a reaction-control system's
usual layout. Couple ``k`` has a thruster at ``points[k]`` pushing along ``directions[k]`` and
its partner at ``partners[k]`` pushing along ``-directions[k]``, both with ``u_k max_force[k]``:
the forces cancel, the torque is

    tau_body = (r_k - r'_k) x (u_k max_force_k d_k)

whatever the centre of mass (a pure couple), so the body turns without its centre of mass
moving. Spent: both thrusters fire, so a couple spends the impulse ``2 |u_k| max_force_k dt``
[N s] per step (its :attr:`~rigid_env.core.actuator.Actuator.fuel`, ``2 max_force`` [N]).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.actuator import Actuator, Command
from rigid_env.core.actuators.linear import map_bound, map_torque
from rigid_env.core.effects import LinearActuator
from rigid_env.core.rotation import cross

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ThrusterCouples(LinearActuator):
    """Thruster couples, one command component each, in [-1, 1].

    Attributes:
        points: (K, 3) each couple's first thruster, body frame [m].
        partners: (K, 3) its partner, body frame [m] (apart from ``points``: else no couple).
        directions: (K, 3) the first thruster's thrust direction, body frame (normalised
            here); the partner's is its opposite.
        max_force: (K,) or one force of each thruster at ``|u| = 1`` [N], >= 0.
    """

    points: FloatArray
    partners: FloatArray
    directions: FloatArray
    max_force: FloatArray | float = 1.0
    name: ClassVar[str] = "thruster_couples"
    force_map: FloatArray = field(init=False, repr=False)
    torque_map: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        points = _rows("thruster_couples.points", self.points)
        k = points.shape[0]
        partners = _rows("thruster_couples.partners", self.partners, k)
        dirs = _rows("thruster_couples.directions", self.directions, k)
        fmax = np.broadcast_to(np.asarray(self.max_force, dtype=np.float64), (k,)).copy()
        bad = np.flatnonzero(~(np.isfinite(fmax) & (fmax >= 0.0)))
        if bad.size:
            j = int(bad[0])
            raise ValueError(
                f"thruster_couples[{j}].max_force: must be finite and >= 0 [N], got {fmax[j]}"
            )
        norms = np.linalg.norm(dirs, axis=1)
        arms = np.linalg.norm(points - partners, axis=1)
        for j in range(k):
            if norms[j] == 0.0:
                raise ValueError(
                    f"thruster_couples[{j}].direction: is zero; give a non-zero direction vector"
                )
            if arms[j] == 0.0:
                raise ValueError(
                    f"thruster_couples[{j}]: both thrusters sit at one point (no couple); give "
                    "the partner another point"
                )
        dirs = dirs / norms[:, None]
        force = dirs * fmax[:, None]
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "partners", partners)
        object.__setattr__(self, "directions", dirs)
        object.__setattr__(self, "max_force", fmax)
        object.__setattr__(self, "force_map", np.zeros((k, 3)))
        object.__setattr__(self, "torque_map", cross(points - partners, force))


def _rows(where: str, value: object, k: int | None = None) -> FloatArray:
    """(K, 3) finite numbers from ``value`` (``k`` rows if given), or a one-line
    ``ValueError`` naming ``where``."""
    try:
        rows = np.asarray(value, dtype=np.float64).reshape(-1, 3)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: expected [[x, y, z], ...] [m], got {value!r}") from None
    if rows.shape[0] == 0 or (k is not None and rows.shape[0] != k):
        want = "at least one" if k is None else f"{k} (one per couple)"
        raise ValueError(f"{where}: expected {want} rows [x, y, z], got {rows.shape[0]}")
    if not np.all(np.isfinite(rows)):
        raise ValueError(f"{where}: every number must be finite")
    return rows


def _draw(spec: ThrusterCouples) -> tuple[FloatArray, FloatArray]:
    """Each couple at its first thruster, along its thrust."""
    return spec.points, spec.directions


def _example() -> ThrusterCouples:
    """Two couples of an RCS quad: a roll couple about body x and a yaw couple about body z,
    whose thrusters sit off the centre of mass."""
    return ThrusterCouples(
        np.array([[0.0, 0.3, 0.1], [0.4, 0.0, 0.0]]),
        np.array([[0.0, -0.3, 0.1], [-0.4, 0.0, 0.0]]),
        np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]),
        np.array([0.5, 0.25]),
    )


COUPLES = Actuator(
    name="thruster_couples",
    noun="thruster couple",
    spec=ThrusterCouples,
    command=Command("force of each thruster", "N"),
    wrench="rigid_env.core.layout:map_row",
    example=_example,
    section="rigid_env.scene_sections:ThrusterCoupleSpec",
    bound=map_bound,
    torque_at=map_torque,
    full_scale=lambda spec: spec.max_force,
    # both thrusters fire: 2 |u| max_force of impulse per second
    fuel=lambda spec: 2.0 * spec.max_force,
    fuel_unit="N s",
    draw=_draw,
    meaning=lambda spec: {"torque [N m]": spec.torque_map, "thrust [N]": spec.max_force[:, None]},
    scene_keys=("points", "direction", "max_force"),
)
"""The thruster couples' declaration."""
