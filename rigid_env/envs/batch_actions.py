"""A task batch's actions: the number of envs and an action as the compiled clip reads it
(module functions), each env's command from its action (faults and thrust scale applied) and
the thrust noise drawn for a step (:class:`Actions`, a part of
:class:`rigid_env.envs.batch.TaskBatch`)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_env.envs import kernels as K
from rigid_env.envs.hardware import apply_faults
from rigid_env.envs.sensors import RowNormals

FloatArray = NDArray[np.float64]

_NON_FINITE_ACTION = "action: contains NaN or inf; send finite commands in [-1, 1]"


def as_num_envs(value: Any) -> int:
    """``value`` as a number of envs (an integer >= 1, NumPy's included), or a one-line
    ``ValueError``."""
    integral = isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)
    if not integral or value < 1:
        raise ValueError(f"num_envs: must be an integer >= 1, got {value!r}")
    return int(value)


_COMPILED_DTYPES = frozenset(map(np.dtype, (np.float64, np.float32)))  # read as they are


def as_actions(action: ArrayLike) -> NDArray[Any]:
    """``action`` as an array of a real dtype the compiled clip reads (float64, float32, or
    integers as they are; float16, long double and byte-swapped floats converted to float64,
    which holds them exactly or, for long double, as NumPy casts), or a one-line ValueError."""
    act = action if isinstance(action, np.ndarray) else _array_of(action)
    if act.dtype in _COMPILED_DTYPES:
        return act
    kind = act.dtype.kind
    if kind not in "fiu" or (act.dtype.itemsize > 8 and kind != "f"):
        raise ValueError(
            f"action: expected real numbers (float32 or float64), got dtype {act.dtype}"
        )
    native = act.dtype.isnative and act.dtype.itemsize <= 8
    if kind == "f" and not (native and act.dtype.itemsize >= 4):
        act = act.astype(np.float64)
    elif not native:
        act = act.astype(act.dtype.newbyteorder("="))
    return act


def _array_of(action: Any) -> NDArray[Any]:
    """A NumPy array of ``action``; a tensor (torch: one that requires grad, on a GPU or in
    bfloat16, which NumPy cannot take as it is) detached to the CPU first, bfloat16 as the
    float32 that holds it exactly."""
    if hasattr(action, "detach") and hasattr(action, "cpu"):
        action = action.detach().cpu()
        if str(getattr(action, "dtype", "")) == "torch.bfloat16":
            action = action.float()
    try:
        return np.asarray(action)
    except (TypeError, ValueError, RuntimeError) as exc:
        reason = " ".join(str(exc).split())
        raise ValueError(
            f"action: expected an array of real numbers, got a {type(action).__name__} NumPy "
            f"cannot read ({reason})"
        ) from None


class Actions:
    """The part of :class:`~rigid_env.envs.batch.TaskBatch` this module names (its attributes
    are the batch's)."""

    def check_action(self, action: ArrayLike) -> FloatArray:
        """Validate and clip a command to (N, A) in [-1, 1] (into :attr:`last_action`; the
        bodies' command, thrust randomisation included, into :attr:`command`).

        Raises:
            ValueError: a dtype that is not real, a wrong shape, or a NaN/inf entry (never
                silently simulated).
        """
        act = as_actions(action)
        if act.shape not in self._action_shapes:
            raise ValueError(
                f"action: expected shape ({self.n}, {self.action_dim})"
                f"{' or (' + str(self.action_dim) + ',)' if self.n == 1 else ''}, "
                f"got {act.shape}"
            )
        if K.clip_commands(np.ascontiguousarray(act), self.last_action) < 0:
            raise ValueError(_NON_FINITE_ACTION)
        if self._commands_apart:
            self._make_command()
        return self.last_action

    def _make_command(self) -> None:
        """The bodies' :attr:`command` (an array apart from :attr:`last_action`) from the
        clipped :attr:`last_action`: the task's :meth:`demand`, times the thrust scales once
        thrust is randomised, then the faults."""
        demand = self.demand(self.last_action)  # may be :attr:`command` itself, written
        if self.thrust_scale is not None:
            np.multiply(demand, self.thrust_scale, out=self.command)
        elif demand is not self.command:
            self.command[:] = demand
        if self._faulty:
            apply_faults(self.command, self.steps, self.fault_rows)

    def _draw_thrust_factors(self, skip: NDArray[np.bool_] | None = None) -> None:
        """Each env's thrust noise factors for this step from its own generator (factor 1,
        nothing drawn, for envs about to restart: as a single env's generator sees it), all
        drawn in one compiled pass (:attr:`streams`, following the step's generators)."""
        rows = None if skip is None or not skip.any() else np.flatnonzero(~skip)
        if rows is not None:
            self.world.thrust_factors[skip] = 1.0
        normals = self.streams.standard_normals(rows, self.action_dim)
        self.world.draw_thrust_factors(RowNormals(normals), rows=rows)
