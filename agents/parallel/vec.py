"""The batched task as rsl-rl's ``VecEnv``: torch tensors in, torch tensors out.

Underneath is the SB3 path's own env, :class:`agents.vec_adapter.RigidBodySB3VecEnv` (all N
bodies in one compiled step, a done env reset in the same call) under SB3's ``VecNormalize``: the
observation and reward scaling are SB3's code and statistics, so the learner's policy saved as an
SB3 zip with that ``VecNormalize`` pickle acts exactly as it did in training. rsl-rl's runner
reads ``extras["time_outs"]`` (episodes cut by the time limit, which it bootstraps) and nothing
else; SB3's per-env info dicts are built only for the envs whose episode ended.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch
from rsl_rl.env import VecEnv
from tensordict import TensorDict

OBS_GROUP = "policy"
"""The one observation group: actor and critic both read the flat observation."""


class RslVecEnv(VecEnv):
    """``venv`` (an SB3 ``VecEnv``, normalised or not) as an rsl-rl ``VecEnv`` on the CPU.

    Actions are clipped to the action space before they reach the task (as SB3's PPO clips
    them); the policy's unclipped samples are what PPO stores.
    """

    def __init__(self, venv: Any, max_episode_steps: int) -> None:
        self.venv = venv
        self.num_envs = venv.num_envs
        self.num_actions = int(np.prod(venv.action_space.shape))
        self.max_episode_length = max_episode_steps
        self.episode_length_buf = torch.zeros(self.num_envs, dtype=torch.long)
        self.device = "cpu"
        self.cfg: dict[str, Any] = {}
        self._low = torch.as_tensor(venv.action_space.low, dtype=torch.float32)
        self._high = torch.as_tensor(venv.action_space.high, dtype=torch.float32)
        self._obs = self._wrap(venv.reset())

    @staticmethod
    def _wrap(obs: np.ndarray) -> TensorDict:
        return TensorDict({OBS_GROUP: torch.from_numpy(np.asarray(obs, dtype=np.float32))},
                          batch_size=[obs.shape[0]])  # fmt: skip

    def get_observations(self) -> TensorDict:
        """The (normalised) observations of the current step."""
        return self._obs

    def step(self, actions: torch.Tensor) -> tuple[TensorDict, torch.Tensor, torch.Tensor, dict]:
        """Step every env once; done envs come back reset (their first observation)."""
        clipped = torch.clamp(actions, self._low, self._high).numpy()
        obs, reward, done, infos = self.venv.step(clipped)
        self._obs = self._wrap(obs)
        ended = np.flatnonzero(done)
        time_outs = np.zeros(self.num_envs, dtype=np.float32)
        for i in ended.tolist():
            time_outs[i] = float(infos[i].get("TimeLimit.truncated", False))
        self.episode_length_buf += 1
        self.episode_length_buf[torch.from_numpy(ended)] = 0
        extras = {"time_outs": torch.from_numpy(time_outs)}
        rewards = torch.from_numpy(np.asarray(reward, dtype=np.float32))
        return self._obs, rewards, torch.from_numpy(done.astype(np.float32)), extras
