"""The B-dot detumbling law for magnetorquers, the analytic baseline of magnetic detumbling.

A coil's dipole ``m`` in the field ``B_b`` (body frame) makes the torque ``m x B_b``. With ``m =
-k dB_b/dt`` and, for a field fixed in inertial space, ``dB_b/dt = -w x B_b``, the law is ``m =
k (w x B_b)`` and the kinetic energy ``V = 1/2 w . I w`` falls as

    dV/dt = w . (m x B_b) = -k |w x B_b|^2 <= 0,

with equality only for a spin about the field (which no magnetic torque can change: its
torque is across ``B``). A per-axis saturation keeps each component's sign, so ``dV/dt <= 0``
still holds term by term (Stickler and Alfriend, "Elementary magnetic attitude control
system", J. Spacecraft and Rockets 13(5), 1976; Avanzini and Giulietti, "Magnetic Detumbling
of a Rigid Spacecraft", J. Guidance, Control, and Dynamics 35(4), 2012).

Two forms: :func:`bdot_rate` from a gyro's ``w`` and a magnetometer's ``B_b``, and
:func:`bdot_measured`, as flown, from two magnetometer samples ``dt`` apart (a finite
difference of ``B_b``: no gyro needed).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def avanzini_gain(mean_motion: float, inclination: float, least_inertia: float) -> float:
    """The gain ``k = 2 n (1 + sin(i_m)) I_min`` [kg m^2/s] that Avanzini and Giulietti (2012,
    above) show makes B-dot detumble fastest, for an orbit of mean motion ``n`` [rad/s] at the
    geomagnetic inclination ``i_m`` [rad]; the law's ``m = k (w x B_b) / |B_b|^2`` then scales
    out the field's size (:func:`bdot_rate` with ``normalise=True``)."""
    return 2.0 * mean_motion * (1.0 + np.sin(inclination)) * least_inertia


def bdot_rate(
    w_body: ArrayLike,
    field_body: ArrayLike,
    gain: float,
    max_dipole: ArrayLike,
    normalise: bool = True,
) -> FloatArray:
    """(N, 3) coil commands in [-1, 1] of ``m = k (w x B_b)`` (divided by ``|B_b|^2`` where
    ``normalise``), each axis saturated at its ``max_dipole`` [A m^2] (coils along the body
    axes).

    Args:
        w_body: (N, 3) angular velocity, body frame [rad/s].
        field_body: (N, 3) the field, body frame [T].
        gain: ``k`` [kg m^2/s] (normalised) or [A m^2 s / T] (not).
        max_dipole: (3,) or one dipole at ``|u| = 1`` [A m^2].
    """
    w, b = np.atleast_2d(w_body), np.atleast_2d(field_body)
    return _commands(gain * np.cross(w, b), b, max_dipole, normalise)


def bdot_torque(w_body: ArrayLike, field_body: ArrayLike, gain: float, unit: float) -> FloatArray:
    """(N, 3) torque commands in [-1, 1] for a task whose actions are wanted torques over
    ``unit |B_b|`` (BdotDetumble's ``command="torque"``): B-dot's torque ``-k w_perp`` (the
    normalised law's ``m x B_b`` for ``m = k (w x B_b) / |B_b|^2``) as ``-k w / (unit
    |B_b|)``, whose part along the field the cross-product law removes; a command past 1
    scales the whole vector down, keeping its direction.

    Args:
        w_body: (N, 3) angular velocity, body frame [rad/s].
        field_body: (N, 3) the field, body frame [T].
        gain: ``k`` [kg m^2/s].
        unit: the dipole of a unit torque command [A m^2].
    """
    w, b = np.atleast_2d(w_body), np.atleast_2d(field_body)
    size = np.maximum(np.linalg.norm(b, axis=1, keepdims=True), np.finfo(float).tiny)
    u = -gain * w / (unit * size)
    return u / np.maximum(1.0, np.abs(u).max(axis=1, keepdims=True))


def bdot_measured(
    field_body: ArrayLike,
    previous: ArrayLike,
    dt: float,
    gain: float,
    max_dipole: ArrayLike,
    normalise: bool = True,
) -> FloatArray:
    """(N, 3) coil commands of ``m = -k (B_b(t) - B_b(t - dt)) / dt``, the flown form: two
    magnetometer samples ``dt`` [s] apart, no gyro; equal to :func:`bdot_rate` as ``dt -> 0``
    (the difference quotient is ``-w x B_b`` to ``O(dt |w|^2 |B|)``)."""
    b, b0 = np.atleast_2d(field_body), np.atleast_2d(previous)
    return _commands(-gain * (b - b0) / dt, b, max_dipole, normalise)


def _commands(m: FloatArray, b: FloatArray, max_dipole: ArrayLike, normalise: bool) -> FloatArray:
    """The coils' commands in [-1, 1] for the dipoles ``m`` (N, 3) [A m^2], divided by
    ``|B_b|^2`` first where ``normalise``."""
    if normalise:
        m = m / np.maximum(np.sum(b * b, axis=1, keepdims=True), np.finfo(float).tiny)
    return np.clip(m / np.asarray(max_dipole, dtype=np.float64), -1.0, 1.0)
