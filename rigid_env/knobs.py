"""The knobs a user sets that the scene file, the env keywords, the fault model and the command
line share, each declared once: its type, unit, physical range and doc. The pydantic models
(:mod:`rigid_env.scene`, :mod:`rigid_env.envs.params`, :mod:`rigid_env.envs.hardware`,
:mod:`agents.config`) put these types on their fields; the command line's values reach them
through the scene (``--dt``, ``--rtol`` ...) or the env keywords.

Everywhere: text is not a number (``"0.02"``, ``"1e-6"``), a boolean is not a number nor an
integer, NaN and inf are refused, NumPy scalars count as the Python numbers they hold.
"""

from __future__ import annotations

import math
from typing import Annotated, Any

import numpy as np
from pydantic import BeforeValidator, Field

from rigid_env.config_files import describe, number

RTOL_MIN = 100.0 * float(np.finfo(np.float64).eps)
"""The smallest relative tolerance of an error-controlled integrator, about 2.2e-14: a
substep's error estimate is itself rounded at ``eps |y|`` per stage, so below ~100 ulps no step
size meets the tolerance and every step ends at the substep limit (SciPy's ``solve_ivp``
raises its ``rtol`` to the same floor, with a warning)."""
ATOL_MIN = 1.0e-100
"""The smallest absolute tolerance: the scene's smallest non-zero magnitude
(:data:`rigid_env.scene_sections.MIN_MAGNITUDE`); below, ``atol + rtol |y|`` is rounding."""
MAX_WITHIN_STEPS = 10**9
"""The latest control step a fault may start from: a billion steps, far beyond any episode
(and within the int64 a generator draws)."""
MAX_ACTION_REPEAT = 100_000
"""The most world steps one action is held for: at a few microseconds per world step and task
pass, one ``env.step`` then stays under a second."""
MAX_ENV_STEP_SUBSTEPS = 10_000_000
"""The most integrator steps one env step may take (``action_repeat`` times ``substeps``): about
a few seconds of one core at the cost of the dearest integrators."""


def _plain(value: Any) -> Any:
    """A NumPy scalar as the Python value it holds (a NumPy bool as a bool, to be refused)."""
    return value.item() if isinstance(value, np.generic) else value


def _integer(value: Any) -> Any:
    """An int (or an integral float such as YAML's ``1e5``); text and booleans refused."""
    value = _plain(value)
    if isinstance(value, bool) or not isinstance(value, int | float):
        fix = "write it without quotes" if isinstance(value, str) else "give a whole number"
        raise ValueError(f"expected an integer, got {describe(value)}; {fix}")
    if isinstance(value, float) and not (math.isfinite(value) and value.is_integer()):
        raise ValueError(f"expected an integer, got {value!r}; give a whole number")
    return int(value)


def real(unit: str = "", **bounds: float) -> Any:
    """A finite real number in ``unit`` with ``bounds`` (``gt``, ``ge``, ``lt``, ``le``) on the
    field; text and booleans refused, naming the unit; a NumPy scalar taken as its value."""
    return Annotated[
        float, BeforeValidator(number(unit).func), Field(allow_inf_nan=False, **bounds),
        BeforeValidator(_plain),
    ]  # fmt: skip


def integer(**bounds: int) -> Any:
    """An integer with ``bounds`` (``ge``, ``le``, ...); text, booleans and fractions refused."""
    return Annotated[int, Field(strict=True, **bounds), BeforeValidator(_integer)]


Flag = Annotated[bool, Field(strict=True), BeforeValidator(_plain)]
"""true or false (YAML) / True or False (a NumPy bool as the bool it holds): not 1, 0, "yes" or
"true" in quotes."""


def plain_tree(value: Any) -> Any:
    """``value`` with every NumPy scalar in it (through dicts, lists and tuples) as the Python
    value it holds: what a mapping given in place of a file (a scene dict) is read as, so a
    ``np.float32`` dt counts as the number it holds, and a ``np.bool_`` as a bool (refused as a
    number, as ``True`` is)."""
    if isinstance(value, dict):
        return {key: plain_tree(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return type(value)(plain_tree(item) for item in value)
    return _plain(value)


Unit = real("", ge=0.0, le=1.0)
"""A fraction of a whole [-] in [0, 1] (a valve's command level, a thrust fraction)."""
Probability = real("", ge=0.0, le=1.0)
"""A probability in [0, 1]."""
Rtol = real("", ge=RTOL_MIN, lt=1.0)
"""An error-controlled integrator's relative tolerance, RTOL_MIN (about 2.2e-14) <= rtol < 1
(float64 cannot meet a tighter one)."""
Atol = real("", ge=ATOL_MIN)
"""Its absolute tolerance, >= 1e-100 (a smaller one is rounding beside rtol |y|)."""
WithinSteps = integer(ge=1, le=MAX_WITHIN_STEPS)
"""A count of control steps, 1 to 1e9."""
