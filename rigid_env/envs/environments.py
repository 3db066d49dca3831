"""The Gymnasium classes of every task, thin shells over a :class:`~rigid_env.envs.batch.TaskBatch`.

:class:`RigidBodyEnv` (a ``gymnasium.Env``) is the ``N = 1`` case of the task batch and
:class:`RigidBodyVectorEnv` (a native ``gymnasium.vector.VectorEnv``) the ``N`` case: there is
no second copy of anything. Randomness comes only from per-environment generators
(``np_random`` of the single env; one generator per sub-environment, seeded ``seed + i``, in
the vector env), so sub-environment ``i`` of a vector env reset with ``seed`` replays a single
env reset with ``seed + i`` bit for bit.
"""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import ArrayLike, NDArray

from rigid_env.envs import variant_kwargs
from rigid_env.envs.batch import TaskBatch
from rigid_env.render import TaskRenderer

VECTOR_RESET_OPTIONS = ("reset_mask",)
"""The reset options a vector env reads (a single env reads none)."""


def as_seed(seed: Any) -> int | None:
    """``seed`` as a Python int (NumPy integers included, as Gymnasium takes them) or None, or
    a one-line ``ValueError``."""
    if seed is None:
        return None
    if isinstance(seed, int | np.integer) and not isinstance(seed, bool | np.bool_) and seed >= 0:
        return int(seed)
    raise ValueError(f"seed: must be an integer >= 0 or None, got {seed!r}")


def check_options(options: Any, known: tuple[str, ...]) -> dict[str, Any]:
    """Reset ``options`` as a dict of the ``known`` keys, or a one-line ``ValueError``."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise ValueError(f"options: expected a dict or None, got {type(options).__name__}")
    unknown = [k for k in options if k not in known]
    if unknown:
        reads = f"reads only {', '.join(known)}" if known else "reads none"
        raise ValueError(f"options[{unknown[0]!r}]: unknown reset option; this env {reads}")
    return options


def task_class(env: Any, task: type[TaskBatch] | None) -> type[TaskBatch]:
    """The task class of ``env``: ``task`` if given, else its class's ``task_cls``."""
    if task is None:
        task = getattr(type(env), "task_cls", None)
    if not (isinstance(task, type) and issubclass(task, TaskBatch)):
        raise ValueError(
            f"task: expected a TaskBatch subclass (or a subclass of {type(env).__name__} that "
            f"sets task_cls), got {task!r}"
        )
    return task


def _masked(value: NDArray[Any], mask: NDArray[np.bool_]) -> NDArray[Any]:
    """(N, ...) ``value`` with the rows outside ``mask`` set to 0 (False for bools)."""
    out = np.zeros_like(value)
    out[mask] = value[mask]
    return out


def render_fps(dt: float) -> int:
    """Frames per second of a rendering, one frame per control step ``dt`` [s]: ``1 / dt``
    rounded, at least 1 (a 5 s step plays at 1 frame per second, not 0, which video writers
    divide by)."""
    return max(1, round(1.0 / dt))


class RigidBodyEnv(gym.Env[NDArray[np.float32], NDArray[np.float32]]):
    """Base of the single environments: a :class:`TaskBatch` of one body.

    Keyword arguments go to the task (see its class); ``render_mode`` is ``None``,
    ``"rgb_array"`` or ``"human"``; ``task`` is the task class where a subclass does not set
    :attr:`task_cls` (``gym.register(..., kwargs={"task": MyTask})``). ``reset`` reads no
    ``options``.
    """

    task_cls: ClassVar[type[TaskBatch]]
    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array", "human"], "render_fps": 20}

    def __init__(
        self, render_mode: str | None = None, task: type[TaskBatch] | None = None, **kwargs: Any
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode: {render_mode!r} is not one of {self.metadata['render_modes']}"
            )
        self.task = task_class(self, task)(1, **variant_kwargs(kwargs))
        self.observation_space = self.task.single_observation_space
        self.action_space = self.task.single_action_space
        self.metadata = {**self.metadata, "render_fps": render_fps(self.task.dt)}
        self.render_mode = render_mode
        self._renderer: Any = None
        self._has_reset = False

    @property
    def dt(self) -> float:
        """The simulated time of one :meth:`step` in seconds, the world's ``dt`` times the
        episode's action repeat (``randomization={"action_repeat": [...]}`` draws it at each
        reset; 1 without), as ``dt`` of Gymnasium's MuJoCo envs is the model's step times
        ``frame_skip``. Through ``gym.make``'s wrappers, read ``env.unwrapped.dt``."""
        return float(self.task.dt * self.task.repeats[0])

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """Start an episode; ``seed`` reseeds :attr:`np_random`."""
        check_options(options, ())
        super().reset(seed=as_seed(seed))
        self.task.reset_envs([0], [self.np_random])
        self._rngs = [self.np_random]
        self._has_reset = True
        if self.render_mode == "human":
            self.render()
        return self.task.obs[0].copy(), self.task.info_one()

    def step(self, action: ArrayLike):
        """One control step of ``dt``; see the task class for reward and episode end."""
        if not self._has_reset:
            raise RuntimeError("Call reset before using step method.")
        task = self.task
        task.check_action(action)
        r, failed = task.step_one(self._rngs[0])
        info = task.info_one(r, failed)
        if self.render_mode == "human":
            self.render()
        return task.obs[0].copy(), r.reward, r.terminated, failed, info

    def render(self):
        """An RGB frame (H, W, 3) uint8 in ``"rgb_array"`` mode; draws a window in ``"human"``."""
        if self.render_mode is None:
            gym.logger.warn(
                "render: no render_mode was given; pass render_mode='rgb_array' to gym.make"
            )
            return None
        if self._renderer is None:
            self._renderer = TaskRenderer(
                self.task.view(), mode=self.render_mode, fps=self.metadata["render_fps"]
            )
        return self._renderer.render(self.task.frame(0))

    def close(self) -> None:
        """Close the window, if any."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


class RigidBodyVectorEnv(VectorEnv):
    """Base of the native vector environments: all ``num_envs`` bodies in one NumPy call.

    Autoreset mode ``NEXT_STEP``: an env that terminates or truncates in one ``step`` is reset
    by the next ``step`` (its action then is ignored, its reward is 0, and the returned
    observation is the first of the new episode).

    Args:
        num_envs: number of sub-environments.
        max_episode_steps: truncation length (given by ``gym.make_vec`` from the registry).
        render_mode: ``None`` or ``"rgb_array"`` (renders sub-environment 0).
        task: the task class where a subclass does not set :attr:`task_cls`.
        **kwargs: passed to the task (see the single env's class).
    """

    task_cls: ClassVar[type[TaskBatch]]
    metadata: ClassVar[dict[str, Any]] = {
        "render_modes": ["rgb_array"],
        "render_fps": 20,
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }

    def __init__(
        self,
        num_envs: int = 1,
        max_episode_steps: int | None = None,
        render_mode: str | None = None,
        task: type[TaskBatch] | None = None,
        **kwargs: Any,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode: {render_mode!r} is not one of {self.metadata['render_modes']} "
                "(a vector env renders sub-environment 0 as an RGB array)"
            )
        self.task = task_class(self, task)(num_envs, **variant_kwargs(kwargs))
        self.num_envs = self.task.n
        self.max_episode_steps = max_episode_steps
        self.single_observation_space = self.task.single_observation_space
        self.single_action_space = self.task.single_action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.metadata = {**self.metadata, "render_fps": render_fps(self.task.dt)}
        self.render_mode = render_mode
        self._renderer: Any = None
        self._rngs: list[np.random.Generator] = []
        self._autoreset = np.zeros(self.num_envs, dtype=bool)

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ):
        """Reset every sub-environment, or only those of ``options["reset_mask"]`` (the only
        option read; another key is an error).

        An int ``seed`` (NumPy's included) seeds sub-env ``i`` with ``seed + i``, a list with
        ``seed[i]``; None continues each env's generator. With a ``reset_mask`` ((N,) bool
        array, at least one True; Gymnasium's ``SyncVectorEnv`` semantics) only the masked envs
        are reset (and seeded); the others keep their state, generator and pending autoreset,
        their rows of the observation are those last returned, and the infos hold the masked
        envs only (``info["_key"]`` is the mask, the other entries 0).
        """
        options = check_options(options, VECTOR_RESET_OPTIONS)
        if isinstance(seed, list | tuple):
            if len(seed) != self.num_envs:
                raise ValueError(f"seed: expected {self.num_envs} seeds, got {len(seed)}")
            seeds = [as_seed(s) for s in seed]
            super().reset(seed=None)
        else:
            first = as_seed(seed)
            super().reset(seed=first)
            seeds = [None if first is None else first + i for i in range(self.num_envs)]
        mask = self._reset_mask(options)
        if mask is not None:
            return self._reset_masked(mask, seeds)
        if not self._rngs or seed is not None:
            self._rngs = [seeding.np_random(s)[0] for s in seeds]
        self.task.reset_envs(np.arange(self.num_envs), self._rngs)
        self._autoreset[:] = False
        return self.task.observe(), self._vector_info(self.task.infos())

    @property
    def dt(self) -> float | NDArray[np.float64]:
        """The simulated time of one :meth:`step` of each sub-environment in seconds, the
        world's ``dt`` times its episode's action repeat. A float while every sub-environment
        has the same period (always, unless ``randomization["action_repeat"]`` lists several),
        else an (N,) array, sub-environment ``i``'s period in row ``i``."""
        periods = self.task.dt * self.task.repeats.astype(np.float64)
        return float(periods[0]) if bool((periods == periods[0]).all()) else periods

    def _reset_mask(self, options: dict[str, Any]) -> NDArray[np.bool_] | None:
        """``options["reset_mask"]`` checked as ``SyncVectorEnv`` checks it (same errors)."""
        if "reset_mask" not in options:
            return None
        mask = options["reset_mask"]
        key = "options['reset_mask']"
        if not isinstance(mask, np.ndarray):
            raise TypeError(f"{key}: must be a numpy array, got {type(mask).__name__}")
        if mask.shape != (self.num_envs,):
            raise ValueError(f"{key}: must have shape ({self.num_envs},), got {mask.shape}")
        if mask.dtype != np.bool_:
            raise TypeError(f"{key}: must have dtype bool, got {mask.dtype}")
        if not mask.any():
            raise ValueError(f"{key}: must have at least one True entry (the envs to reset)")
        if not self._rngs:
            raise ValueError(f"{key}: reset every sub-environment first (reset without a mask)")
        return mask

    def _reset_masked(self, mask: NDArray[np.bool_], seeds: list[int | None]):
        """:meth:`reset` of the envs in ``mask`` only (the other rows of the observation are
        the ones last returned: the task's observation buffer keeps them)."""
        idx = np.flatnonzero(mask)
        for i in idx:
            if seeds[i] is not None:
                self._rngs[i] = seeding.np_random(seeds[i])[0]
        self.task.reset_envs(idx, [self._rngs[i] for i in idx])
        self._autoreset[idx] = False
        return self.task.observe(), self._vector_info(self.task.infos(), mask)

    def step(self, actions: ArrayLike):
        """Step all sub-environments; see the class docstring for autoreset."""
        if not self._rngs:
            raise RuntimeError("Call reset before using step method.")
        self.task.check_action(actions)
        reward, terminated, failed = self.task.step(self._rngs, self._autoreset)
        reward = reward.copy()
        truncated = failed.copy()
        if self.max_episode_steps is not None:
            truncated |= self.task.steps >= self.max_episode_steps
        restarting = self._autoreset
        if restarting.any():
            idx = np.flatnonzero(restarting)
            self.task.reset_envs(idx, [self._rngs[i] for i in idx])
            reward[idx] = 0.0
            terminated[idx] = False
            truncated[idx] = False
        self._autoreset = terminated | truncated
        obs = self.task.observe()
        return obs, reward, terminated, truncated, self._vector_info(self.task.infos())

    def _vector_info(
        self, info: dict[str, NDArray[Any]], mask: NDArray[np.bool_] | None = None
    ) -> dict[str, Any]:
        """Gymnasium's vector infos: each key with its ``_key`` mask (all envs, or ``mask``
        with the other entries set to 0, as ``SyncVectorEnv`` leaves them)."""
        out: dict[str, Any] = {}
        if mask is None:
            mask = np.ones(self.num_envs, dtype=bool)
        else:
            info = {k: _masked(v, mask) for k, v in info.items()}
        for k, v in info.items():
            out[k] = v
            out[f"_{k}"] = mask
        return out

    def render(self):
        """RGB frame of sub-environment 0."""
        if self.render_mode is None:
            return None
        if self._renderer is None:
            self._renderer = TaskRenderer(
                self.task.view(), mode=self.render_mode, fps=self.metadata["render_fps"]
            )
        return self._renderer.render(self.task.frame(0))

    def close_extras(self, **kwargs: Any) -> None:
        """Close the renderer."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
