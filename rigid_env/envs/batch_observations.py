"""A task batch's observations: their space and layout (where each observed quantity lies),
the observed control period, the check of a task's extra observations, and handing the
observation buffer over (:class:`Observations`, a part of
:class:`rigid_env.envs.batch.TaskBatch`)."""

from __future__ import annotations

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from rigid_env.envs import kernels as K

FloatArray = NDArray[np.float64]

PERIOD_BOUND = 10.0
"""[s] the observed control period (``observe_control_period``) is clipped into [0, this]."""


class Observations:
    """The part of :class:`~rigid_env.envs.batch.TaskBatch` this module names (its attributes
    are the batch's)."""

    def _observation_space(self) -> spaces.Box:
        """One env's observation space: the bounds of :attr:`obs_slices`' parts in order."""
        period = self.settings.observe_control_period
        bound = np.concatenate(
            [
                np.ones(4 if self.rotation_repr == "quaternion" else 6),
                np.full(3, K.W_OBS_BOUND),
                np.ones(3),
                np.full(len(self.extra_observations), self.extra_bound),
                np.array([b for _, b in self._sensor_columns]),
                np.full(int(period), PERIOD_BOUND),
            ]
        ).astype(np.float32)
        low = -bound
        if period:
            low[-1] = 0.0
        return spaces.Box(low, bound, dtype=np.float32)

    def _observation_slices(self) -> dict[str, slice]:
        rot = 4 if self.rotation_repr == "quaternion" else 6
        out = {"orientation": slice(0, rot), "w": slice(rot, rot + 3)}
        out["fine_w"] = slice(rot + 3, rot + 6)
        names = [*self.extra_observations, *(name for name, _ in self._sensor_columns)]
        for k, name in enumerate(names):
            out[name] = slice(rot + 6 + k, rot + 7 + k)
        if self.settings.observe_control_period:
            end = rot + 6 + len(names)
            out["control_period"] = slice(end, end + 1)
        return out

    def _observe_period(self, idx: NDArray[np.int64] | None = None) -> None:
        """Write the control period ``k dt`` [s] of the envs ``idx`` (default all) into their
        last observation column, where it is observed (after the task's pass, which knows
        nothing of it)."""
        if self._observes_period:
            rows = slice(None) if idx is None else idx
            period = np.minimum(self.repeats[rows] * self.dt, PERIOD_BOUND)
            self.obs[rows, -1] = period.astype(np.float32)

    def _check_extra_observations(self) -> None:
        """Run the compiled pass once on a scratch env (compiling it, or loading it from the
        cache) and check that ``evaluate`` gives every extra observation the task names."""
        state = np.zeros((13, 1))
        state[6] = 1.0  # the identity orientation
        arrays = (state, self.world.model_columns[:, :1].copy(), np.zeros((1, self.action_dim)),
                  np.zeros((1, K.TARGET_WIDTH)), np.zeros((1, K.WORLD_WIDTH)), self._no_noise,
                  np.zeros(1, K.RECORD),
                  np.zeros((1, self.obs_dim), np.float32), self.max_force)  # fmt: skip
        given = type(self).task_pass((self.numbers, arrays, False, K.EVERY_ENV), 1)
        if given < len(self.extra_observations):
            raise ValueError(
                f"{type(self).__name__}: evaluate returns {given} extra observation(s), the task "
                f"names {len(self.extra_observations)} ({', '.join(self.extra_observations)}); "
                "return them all in Outcome.extra"
            )

    def observe(self, idx: NDArray[np.int64] | None = None) -> NDArray[np.float32]:
        """The latest observations, the caller's to keep: (N, obs_dim) (the buffer itself,
        which no later step or reset writes into), or a copy of the rows ``idx``."""
        if idx is not None:
            return self.obs[idx]
        self._obs_given = True
        return self.obs

    def _own_obs(self, keep: bool) -> None:
        """If :meth:`observe` gave :attr:`obs` away, write into a new buffer from now on (with
        the same rows if ``keep``, for a reset of some envs): what a caller got stays as it
        was, with no copy per step."""
        if self._obs_given:
            self.obs = self.obs.copy() if keep else np.empty_like(self.obs)
            self._obs_given = False
