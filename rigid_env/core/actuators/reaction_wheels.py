"""Reaction wheels (:mod:`rigid_env.core.wheels`): wheel ``k``'s motor torque ``u_k
max_torque_k`` about its axis; their momenta are state rows riding through the integrator's flow
(the gyrostat's rates), their numbers a block of :class:`rigid_env.core.layout.Wheel` rows packed
last. The torque is internal: the body and wheels keep their total angular momentum."""

from __future__ import annotations

from dataclasses import dataclass, field
from dataclasses import field as dataclass_field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.actuator import Actuator, Command
from rigid_env.core.effects import LinearActuator, _per_unit, _unit_axes
from rigid_env.core.layout import MAX_WHEELS, WHEEL_WIDTH, Wheel

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ReactionWheels(LinearActuator):
    """Reaction wheels (:mod:`rigid_env.core.wheels`): wheel ``k`` spins about the body axis
    ``axes[k]``; command component ``u_k`` in [-1, 1] drives it with the motor torque ``u_k
    max_torque[k]``, none beyond ``max_speed[k]``, against the bearing's friction ``-viscous
    Omega - coulomb sign(Omega)``. The body feels ``-sum_k a_k h_k'`` and ``-w x h``: momentum
    moves between body and wheels, the total stays. No force, no torque map: the wheels' torque
    is internal, evaluated in the dynamics at every stage.

    Attributes:
        axes: (K, 3) each wheel's spin axis, body frame (normalised here), 1 to 4 wheels.
        inertia: (K,) or one axial inertia ``J`` [kg m^2] (a CubeSat's: 1e-6 to 1e-4).
        max_torque: (K,) or one motor torque at ``|u| = 1`` [N m] (a CubeSat's: 1e-3 to 1e-2).
        max_speed: (K,) or one speed limit relative to the body [rad/s] (6000 rpm: 628).
        viscous: (K,) or one viscous friction coefficient [N m s/rad], >= 0.
        coulomb: (K,) or one Coulomb friction torque [N m], >= 0.
        pre_fix: True: the law before issue 44 (a stage's start cuts the motor at the speed
            limit, friction's sign read at each stage), kept only for WheelPointing-v0's
            bit-for-bit history; False (the default): the limit and friction laws that hold
            inside a step (:func:`rigid_env.core.wheels.wheel_laws`).
    """

    axes: FloatArray = field(default_factory=lambda: np.eye(3))
    inertia: FloatArray | float = 1.0e-5
    max_torque: FloatArray | float = 2.0e-3
    max_speed: FloatArray | float = 628.0
    viscous: FloatArray | float = 0.0
    coulomb: FloatArray | float = 0.0
    pre_fix: bool = False
    name: ClassVar[str] = "reaction_wheels"
    force_map: FloatArray = dataclass_field(init=False, repr=False)
    torque_map: FloatArray = dataclass_field(init=False, repr=False)

    def __post_init__(self) -> None:
        most = MAX_WHEELS
        axes = _unit_axes(
            "reaction_wheels.axes", self.axes, f"1 to {most}", "wheel's spin axis", most
        )
        k = axes.shape[0]
        object.__setattr__(self, "axes", axes)
        for name, unit, positive in (
            ("inertia", "kg m^2", True), ("max_torque", "N m", False),
            ("max_speed", "rad/s", True), ("viscous", "N m s/rad", False),
            ("coulomb", "N m", False),
        ):  # fmt: skip
            value = _per_unit(f"reaction_wheels.{name}", getattr(self, name), k, "value", "wheel",
                              (unit, positive))  # fmt: skip
            object.__setattr__(self, name, value)
        object.__setattr__(self, "force_map", np.zeros((k, 3)))
        object.__setattr__(self, "torque_map", np.zeros((k, 3)))

    def rows(self, first: int) -> FloatArray:
        """(K, WHEEL_WIDTH) the wheels' rows of the parameters, their command components
        ``first``, ``first + 1``, ..."""
        out = np.column_stack([
            self.axes, self.inertia, self.max_torque, self.max_speed, self.viscous, self.coulomb,
            first + np.arange(self.axes.shape[0], dtype=np.float64),
            np.full(self.axes.shape[0], 1.0 if self.pre_fix else 0.0),
        ])  # fmt: skip
        assert out.shape[1] == WHEEL_WIDTH
        return out

    def parameters(self) -> dict[str, float]:
        """The wheels' flag and count, and whether they couple (:attr:`coupled`); their rows
        go last in the parameters (:func:`pack`)."""
        return {
            "wheels": 1.0,
            "wheel_count": float(self.axes.shape[0]),
            "wheels_coupled": 1.0 if self.coupled else 0.0,
        }

    @property
    def coupled(self) -> bool:
        """Whether one wheel's internal impulse moves another's relative speed: wheel ``j``'s
        speed moves by ``a_j . I^-1 a_k dh_k`` (:func:`rigid_env.core.wheels.wheel_laws`), zero
        for every principal inertia ``I`` exactly where no two axes share a nonzero component
        (three wheels along the body's axes; not a pyramid)."""
        shared = (self.axes != 0.0).astype(int)
        overlap = shared @ shared.T
        return bool(np.any(overlap[~np.eye(len(shared), dtype=bool)] > 0))


"""The reaction wheels' declaration."""


def _accepts(integrator: str) -> bool:
    from rigid_env.core.integrators import NO_WHEELS

    return integrator not in NO_WHEELS


def _why_not(integrator: str) -> str:
    from rigid_env.core.integrators import NO_WHEELS

    return NO_WHEELS[integrator]


def _alone(found: list) -> None:
    """Refuse thrusters with hardware beside the wheels (their per-component rows and lagged
    levels are stepped by the per-body hardware path, the wheels by the integrators' flows)."""
    for a, spec in found:
        if a.state_rows is not None and a.table is not None and a.table.needed(spec):
            raise ValueError(
                f"reaction_wheels: {a.name} with a hardware model (lag, min_impulse, on_off, "
                f"noise) do not step with wheels; make the {a.name} ideal or leave the wheels out"
            )


def _momentum(world) -> np.ndarray:
    """(N, 3) ``h = sum_k h_k a_k``, body frame [N m s], each body's row alone (no matrix
    product, whose blocking would round a batch's rows otherwise than a single body's)."""
    return np.sum(world.wheel_momentum[:, :, None] * world.wheels.axes[None], axis=1)


def _bound(spec, field=None) -> tuple[float, float]:
    """The motors' and friction's torque at the speed limit (:func:`rigid_env.core.wheels.
    wheel_reach`, whose relative speed is at least the limit)."""
    each = spec.max_torque + spec.coulomb + 2.0 * spec.viscous * spec.max_speed
    return 0.0, float(np.sum(each))


REACTION_WHEELS = Actuator(
    name="reaction_wheels",
    noun="reaction wheel",
    spec=ReactionWheels,
    command=Command("motor torque", "N m"),
    wrench="rigid_env.core.wheels:motor_torques",
    example=lambda: ReactionWheels(
        np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0]]),
        inertia=2.0e-3,
        max_torque=1.0e-2,
        max_speed=600.0,
        viscous=1.0e-6,
        coulomb=1.0e-5,
    ),
    record=Wheel,
    unit_rows=lambda spec, first: spec.rows(first),
    rows_at="wheel_rows",
    flags=("wheels", "wheel_count", "wheel_rows", "wheels_coupled"),
    single=True,
    bound=_bound,
    torque_at=lambda spec, u, field=None: np.zeros(3),  # internal: no external torque
    full_scale=lambda spec: spec.max_torque,
    draw=lambda spec: (np.zeros_like(spec.axes), spec.axes),
    meaning=lambda spec: {"motor torque [N m]": spec.axes * np.asarray(spec.max_torque)[:, None]},
    scene_keys=("axes", "max_torque"),
    state_rows=lambda specs, actions: MAX_WHEELS,
    check_world=_alone,
    rates="rigid_env.core.wheels:gyrostat",
    internal_momentum=_momentum,
    accepts=_accepts,
    why_not=_why_not,
)
