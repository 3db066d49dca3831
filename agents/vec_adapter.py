"""SB3 ``VecEnv`` over our batched task layer (SB3 cannot take a Gymnasium ``VectorEnv``).

SB3's semantics, as its ``DummyVecEnv`` over single envs gives them:

* ``reset()`` seeds sub-env ``i`` with ``seed + i`` after ``seed(seed)`` (else continues each
  env's generator), and returns the first observations;
* ``step_wait()`` returns ``done = terminated or truncated``; a done env is reset in the same
  call: its returned observation is the new episode's first, the last one is in
  ``infos[i]["terminal_observation"]``, and ``infos[i]["TimeLimit.truncated"]`` says whether the
  episode was cut by the time limit (or a numerical failure) rather than ended by the task.

All sub-envs step in one compiled call; only the few envs that finished are reset one by one
(each from its own generator, which is what makes it match ``DummyVecEnv`` bit for bit).

With ``render_mode="rgb_array"``, :meth:`~RigidBodySB3VecEnv.get_images` draws every sub-env
(SB3's ``render()`` tiles them, and ``VecVideoRecorder`` records that).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvStepReturn

from rigid_env.envs import variant_kwargs
from rigid_env.envs.batch import TaskBatch
from rigid_env.envs.environments import render_fps

RENDER_MODES = (None, "rgb_array")


def episode_limit(value: Any) -> int:
    """``max_episode_steps`` as an int >= 1 (an integral NumPy integer too); anything else
    (0, -1, 2.5, True, "400") raises a one-line ``ValueError`` rather than being bent."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        raise ValueError(
            f"max_episode_steps: expected an integer >= 1 (steps per episode), got {value!r}; "
            "pass None for the registry's limit"
        )
    return int(value)


class RigidBodySB3VecEnv(VecEnv):
    """``num_envs`` copies of a registered ``RigidEnv`` task as one SB3 ``VecEnv``.

    Args:
        env_id: registered id, e.g. ``"RigidEnv/Detumble-v0"``.
        num_envs: number of sub-environments.
        max_episode_steps: time limit in steps, an integer >= 1; the registry's value if None.
        render_mode: None or ``"rgb_array"`` (:meth:`get_images` draws every sub-env).
        step_infos: True: every env's info dict every step (as ``DummyVecEnv``); False: only
            an env whose episode ended in this step gets its info, the others an empty dict.
            SB3 reads infos only at an episode's end (``terminal_observation``,
            ``TimeLimit.truncated``, ``is_success``, ``VecMonitor``'s ``episode``), and
            building dicts for every env is most of the adapter's own time per step (see
            ``agents.train``, which trains with False).
        **kwargs: passed to the task, as to ``gym.make(env_id, **kwargs)``.

    Raises:
        ValueError: an id that is not ours, a ``max_episode_steps`` that is not an integer
            >= 1, or a ``render_mode`` other than those above.
    """

    def __init__(
        self,
        env_id: str,
        num_envs: int = 1,
        max_episode_steps: int | None = None,
        render_mode: str | None = None,
        step_infos: bool = True,
        **kwargs: Any,
    ) -> None:
        import rigid_env  # noqa: F401  (registers the ids)

        if render_mode not in RENDER_MODES:
            raise ValueError(
                f"render_mode: {render_mode!r} is not one of {RENDER_MODES}; "
                "SB3 shows or records the rgb_array frames"
            )
        spec = gym.spec(env_id)
        entry = spec.vector_entry_point
        if not isinstance(entry, str) or not entry.startswith("rigid_env."):
            raise ValueError(f"env_id: {env_id!r} is not a rigid_env environment")
        vec_cls = gym.envs.registration.load_env_creator(entry)
        self.env_id = env_id
        # The id's registered kwargs first (a task version: RigidEnv/Reorient-v1 is version=1),
        # the caller's over them, as gym.make merges them (a variant merges them into its own).
        self.task: TaskBatch = vec_cls.task_cls(
            num_envs, **variant_kwargs({**spec.kwargs, **kwargs})
        )
        self.max_episode_steps = (
            spec.max_episode_steps
            if max_episode_steps is None
            else episode_limit(max_episode_steps)
        )
        self.render_mode = render_mode
        self.step_infos = step_infos
        self._renderer: Any = None
        super().__init__(
            num_envs, self.task.single_observation_space, self.task.single_action_space
        )
        self.metadata = {**self.metadata, "render_fps": render_fps(self.task.dt)}  # the env's
        self._rngs: list[np.random.Generator] = [
            seeding.np_random(None)[0] for _ in range(num_envs)
        ]
        self._actions: np.ndarray | None = None

    # ---- SB3 VecEnv API ------------------------------------------------------------------
    def reset(self) -> np.ndarray:
        """Reset all sub-envs, seeding those given by :meth:`seed`."""
        for i, s in enumerate(self._seeds):
            if s is not None:
                self._rngs[i] = seeding.np_random(s)[0]
        self._reset_seeds()
        self._reset_options()
        self.task.reset_envs(np.arange(self.num_envs), self._rngs)
        return self.task.observe()

    def step_async(self, actions: np.ndarray) -> None:
        """Take the commands, (num_envs, A) real numbers (one row per sub-env, as SB3's
        policies give them); any other shape or complex numbers raise a one-line
        ``ValueError`` (never reshaped or cast silently)."""
        act = np.asarray(actions)
        if np.iscomplexobj(act):
            raise ValueError(
                "actions: complex numbers; send real commands in [-1, 1] "
                "(the imaginary part would be dropped)"
            )
        expected = (self.num_envs, self.task.action_dim)
        if act.shape != expected:
            raise ValueError(
                f"actions: expected shape {expected} (num_envs, actuators), got {act.shape}"
            )
        self._actions = act

    def step_wait(self) -> VecEnvStepReturn:
        self.task.check_action(self._actions)
        reward, terminated, failed = self.task.step(self._rngs)
        reward = reward.astype(np.float32)
        truncated = failed.copy()
        if self.max_episode_steps is not None:
            truncated |= self.task.steps >= self.max_episode_steps
        done = terminated | truncated
        obs = self.task.observe()
        infos = self._infos(done)
        if done.any():
            idx = np.flatnonzero(done)
            for i in idx:
                infos[i]["terminal_observation"] = obs[i].copy()
                infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            rngs = [self._rngs[i] for i in idx]
            self.task.reset_envs(idx, rngs)
            obs[idx] = self.task.observe(idx)
        return obs, reward, done, infos

    def _infos(self, done: np.ndarray) -> list[dict[str, Any]]:
        """Every env's info dict (``step_infos``), or only the done envs' (others empty)."""
        raw = self.task.infos()
        if not self.step_infos:
            infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
            for i in np.flatnonzero(done).tolist():
                infos[i] = {k: v[i] if v.ndim > 1 else v[i].item() for k, v in raw.items()}
            return infos
        # One conversion per key (not per env and key): Python scalars from ``tolist``, rows of
        # the (fresh, per-step) vector arrays as they are.
        columns = {k: (list(v) if v.ndim > 1 else v.tolist()) for k, v in raw.items()}
        return [dict(zip(columns, row, strict=True)) for row in zip(*columns.values(), strict=True)]

    def close(self) -> None:
        """Close the renderer, if any."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The attribute of the task (shared by every sub-env), once per index."""
        value = getattr(self.task, attr_name, getattr(self, attr_name, None))
        return [value for _ in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set ``max_episode_steps`` (checked as in the constructor). The task's own attributes
        are fixed when it is built (``dt``, the scene, the randomisation: others derive from
        them), so setting one raises ``ValueError`` naming the constructor argument instead."""
        if attr_name == "max_episode_steps":
            self.max_episode_steps = episode_limit(value)
            return
        raise ValueError(
            f"set_attr: {attr_name!r} cannot be changed on a built env (the task derives other "
            f"values from its arguments); build a new one: "
            f"RigidBodySB3VecEnv({self.env_id!r}, num_envs, {attr_name}=...) as for gym.make"
        )

    def env_method(
        self,
        method_name: str,
        *method_args: Any,
        indices: VecEnvIndices = None,
        **method_kwargs: Any,
    ) -> list[Any]:
        """Call a task method once (the task is shared); result repeated per index."""
        result = getattr(self.task, method_name)(*method_args, **method_kwargs)
        return [result for _ in self._indices(indices)]

    def env_is_wrapped(
        self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None
    ) -> list[bool]:
        """Sub-envs are never wrapped by Gymnasium wrappers."""
        return [False for _ in self._indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        """An RGB frame (H, W, 3) uint8 of every sub-env (``render_mode="rgb_array"``)."""
        if self.render_mode != "rgb_array":
            warnings.warn(
                f"get_images: render_mode is {self.render_mode!r}; pass render_mode='rgb_array'",
                stacklevel=2,
            )
            return [None] * self.num_envs
        if self._renderer is None:
            from rigid_env.render import TaskRenderer

            self._renderer = TaskRenderer(
                self.task.view(), mode="rgb_array", fps=self.metadata["render_fps"]
            )
        return [self._renderer.render(self.task.frame(i)) for i in range(self.num_envs)]

    def _indices(self, indices: VecEnvIndices) -> Iterable[int]:
        if indices is None:
            return range(self.num_envs)
        if isinstance(indices, int):
            return [indices]
        return indices
