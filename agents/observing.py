"""Reading a rigid_env environment from a controller: its task, and the parts of an
observation by the names the task gives them."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def task_of(env: Any) -> Any:
    """The :class:`~rigid_env.envs.batch.TaskBatch` behind a (wrapped) single or vector env."""
    inner = getattr(env, "unwrapped", env)
    if not hasattr(inner, "task"):
        raise TypeError(f"env: {type(inner).__name__} is not a rigid_env environment")
    return inner.task


def observed(task: Any, obs: FloatArray, first: str, last: str | None = None) -> FloatArray:
    """(N, k) the columns of ``obs`` that the task names ``first`` to ``last`` (inclusive; the
    task's :attr:`~rigid_env.envs.batch.TaskBatch.obs_slices`), as float64."""
    slices = task.obs_slices
    for name in (first, last or first):
        if name not in slices:
            raise KeyError(
                f"{type(task).__name__} observes no {name!r}; it observes {', '.join(slices)}"
            )
    return obs[:, slices[first].start : slices[last or first].stop].astype(np.float64)
