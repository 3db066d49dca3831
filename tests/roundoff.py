"""Rounding-error estimates that the tests' tolerances are derived from.

A tolerance on a computed value is an error *bound*, not the error one machine happened to
show: BLAS libraries (OpenBLAS's Haswell, SkylakeX, Zen and Neoverse kernels, MKL, Accelerate)
add the terms of a dot product or a matrix product in different orders, blocks and threads,
with or without fused multiply-adds, and NumPy's transcendental functions come from different
implementations on different CPUs. The estimates below hold for all of them, because they
assume nothing about the order of operations (Higham, *Accuracy and Stability of Numerical
Algorithms*, 2nd ed., SIAM 2002, cited as [Higham]).

Model: every IEEE-754 double operation ``+ - * / sqrt`` (and an FMA) returns the exact result
times ``1 + d`` with ``|d| <= U`` [Higham, (2.4)].
"""

from __future__ import annotations

import math

U = 2.0**-53
"""Unit roundoff of float64: half the spacing of doubles at 1 (1.1e-16)."""
EPS = 2.0 * U
"""Spacing of doubles at 1 (2.2e-16), one ulp of a number in [1, 2)."""

FUNC_ULPS = 4.0
"""Error of one transcendental function call (sin, cos, exp, log, atan2, ...), in ulps of its
result. glibc and Python's ``math`` are within 1 ulp; NumPy's AVX-512 paths (SVML) are
documented to 4 ulp; 4 covers both."""
FUNC_RTOL = FUNC_ULPS * EPS
"""Relative error of one transcendental function call (8.9e-16)."""


def gamma(n: float) -> float:
    """``n U / (1 - n U)``: the relative error bound of ``n`` rounded operations in sequence
    [Higham, Lemma 3.1].

    A sum or dot product of ``n`` terms computed in *any* order (any BLAS blocking, threading,
    FMA or pairwise scheme) has ``|error| <= gamma(n - 1) * sum |terms|`` [Higham, (3.4)-(3.5)],
    so ``gamma(n)`` bounds a sum of ``n`` rounded products.
    """
    if n * U >= 1.0:
        raise ValueError(f"gamma: n = {n} is too large for a bound (n U >= 1)")
    return n * U / (1.0 - n * U)


def dot_atol(n: int, abs_terms_sum: float) -> float:
    """Bound on the absolute error of a dot product or sum of ``n`` terms whose magnitudes add
    up to ``abs_terms_sum``, any order: ``gamma(n) * sum |x_i y_i|``."""
    return gamma(n) * abs_terms_sum


EIG_P3 = 90.0
"""``p(3)`` of a backward-stable symmetric eigensolver on a 3 x 3 matrix: LAPACK's ``dsyevd``
(NumPy's ``eigh``) returns the exact eigenvalues of ``A + E`` with ``||E||_2 <= p(n) U ||A||_2``
(LAPACK Users' Guide, 3rd ed., section 4.7.1; Demmel, *Applied Numerical Linear Algebra*, 1997,
section 5.2), with ``p(n)`` a modest function of ``n`` that LAPACK leaves unstated (its own
error bounds take ``p(n) = 1``). One Householder reflection and a few QL rotations per
eigenvalue for n = 3; we take ``p(3) = 10 n^2 = 90``."""


def eigenvalue_atol(norm2: float) -> float:
    """Bound on ``|computed - exact|`` of every eigenvalue of a symmetric 3 x 3 matrix of
    2-norm ``norm2`` (Weyl's inequality on the backward error, see :data:`EIG_P3`)."""
    return EIG_P3 * U * norm2


def eigenvector_atol(norm2: float, gap: float) -> float:
    """Bound on the angle [rad] between a computed and the exact eigenvector whose eigenvalue is
    ``gap`` from the others (Davis-Kahan sin(theta) theorem on the backward error)."""
    return EIG_P3 * U * norm2 / gap


def random_walk(steps: int, per_step: float) -> float:
    """Typical size of ``steps`` independent rounding errors of size ``per_step``: their
    square-root growth, ``sqrt(steps) * per_step`` (Higham, section 2.8). A *typical* value, not
    a bound: a test using it multiplies it by its own stated margin."""
    return math.sqrt(steps) * per_step


def flow_growth(flow, y0, t, rel: float = 1.0e-8) -> float:
    """How much the flow ``flow(y0, t) -> (T, n)`` amplifies a perturbation of ``y0``: the
    largest ``|flow(y0 + d) - flow(y0)| / |d|`` over ``t``, ``d`` of relative size ``rel`` in a
    fixed generic direction (the fastest-growing direction dominates any generic one after a
    short while, up to a factor that the tests' margins cover)."""
    y0 = [float(v) for v in y0]
    direction = [0.6, -0.48, 0.64, 0.0, 0.0, 0.0][: len(y0)]
    size = rel * math.sqrt(sum(v * v for v in y0))
    kicked = [v + size * d for v, d in zip(y0, direction, strict=True)]
    base, moved = flow(y0, t), flow(kicked, t)
    return float(abs(moved - base).max()) / size


def ivp_global_atol(steps: float, rtol: float, atol: float, y_scale: float, growth: float) -> float:
    """Bound on the global error of an adaptive solver (``solve_ivp``'s DOP853) that took
    ``steps`` steps at tolerances ``rtol``, ``atol`` on a solution of size ``y_scale``: each step
    keeps its local error estimate below ``atol + rtol |y|``; a local error grows at most as a
    perturbation of the initial value does (``growth``, :func:`flow_growth`); the steps' errors
    add up at most linearly; a factor 10 covers the local estimate being an estimate (DOP853's
    embedded error estimator, Hairer, Norsett & Wanner, *Solving ODEs I*, section II.10).

    This is what a BLAS changes here: the solver's error norms go through it, so a step that
    one machine accepts another may reject; the bound holds for any such sequence of steps.
    """
    return 10.0 * steps * (atol + rtol * y_scale) * growth
