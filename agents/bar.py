"""The bar a trained policy must meet, and the evaluation that checks it during training.

The bar (issue 24): at least :data:`SUCCESS_BAR` of held-out episodes end in success, and the
policy's mean fuel is at most :data:`FUEL_RATIO_BAR` times the PD controller's on the same
episodes. :class:`BarEvaluation` runs a live model on the same ``episodes`` episodes each time
(episode ``k`` resets with ``seed + k``), all at once in the native vector env, so an
evaluation of 100 episodes costs about one policy forward per control step rather than one per
episode and step.

The env of an evaluation is the model's task without its training randomisation
(:func:`evaluation_env_kwargs`): the rule ``agents.evaluate`` applies to every sidecar.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

SUCCESS_BAR = 0.95
"""Fraction of held-out episodes that must end in success."""
FUEL_RATIO_BAR = 1.5
"""Most mean fuel allowed, as a multiple of the PD controller's on the same episodes."""
TRAINING_ONLY = ("randomization",)
"""Env kwargs that shape training only; an evaluation leaves them out unless asked for."""


def evaluation_env_kwargs(env_kwargs: dict[str, Any]) -> dict[str, Any]:
    """The env kwargs a model is evaluated with by default: those it was trained with, less
    :data:`TRAINING_ONLY` (a policy trained under randomisation is judged on the task)."""
    return {k: v for k, v in env_kwargs.items() if k not in TRAINING_ONLY}


def live_policy(model: Any) -> Callable[[np.ndarray], np.ndarray]:
    """The model's deterministic policy on raw observations, normalised as in training (the
    ``VecNormalize`` statistics of its env as they are at each call)."""
    from stable_baselines3.common.vec_env import VecNormalize

    env = model.get_env()

    def policy(obs: np.ndarray) -> np.ndarray:
        if isinstance(env, VecNormalize) and env.norm_obs:
            obs = env.normalize_obs(obs)
        return model.predict(obs, deterministic=True)[0]

    return policy


@dataclass
class BarEvaluation:
    """Held-out episodes of a task, with the PD controller's fuel on them as the reference.

    Args:
        env_id: the registered id.
        env_kwargs: the env's kwargs (the training ones: :data:`TRAINING_ONLY` are left out).
        episodes: episodes per evaluation, >= 1.
        seed: episode ``k`` resets with ``seed + k``.
    """

    env_id: str
    env_kwargs: dict[str, Any]
    episodes: int
    seed: int
    _pd_fuel: float | None = field(default=None, repr=False)

    @property
    def kwargs(self) -> dict[str, Any]:
        """The kwargs the episodes run with."""
        return evaluation_env_kwargs(self.env_kwargs)

    @property
    def pd_fuel(self) -> float:
        """The PD controller's mean fuel [N s] on the episodes (computed once)."""
        if self._pd_fuel is None:
            import gymnasium as gym

            from .controllers import CONTROLLERS
            from .evaluate import run_episodes

            probe = gym.make_vec(
                self.env_id, num_envs=1, vectorization_mode="vector_entry_point", **self.kwargs
            )
            pd = CONTROLLERS["pd"](probe)
            probe.close()
            ep = run_episodes(self.env_id, pd, self.episodes, self.seed, self.kwargs)
            self._pd_fuel = float(ep["fuel"].mean())
        return self._pd_fuel

    def __call__(self, policy: Callable[[np.ndarray], np.ndarray]) -> dict[str, Any]:
        """Run ``policy`` on the episodes: :func:`agents.evaluate.run_episodes`' arrays plus
        ``success_rate``, ``fuel_ratio`` (mean fuel / PD's; inf when PD spends none and the
        policy some) and ``met`` (both within the bar)."""
        from .evaluate import run_episodes

        ep = run_episodes(self.env_id, policy, self.episodes, self.seed, self.kwargs)
        success = float(ep["success"].mean())
        ratio = fuel_ratio(float(ep["fuel"].mean()), self.pd_fuel)
        return {
            **ep,
            "success_rate": success,
            "fuel_ratio": ratio,
            "met": meets_bar(success, ratio),
        }


def fuel_ratio(fuel: float, pd_fuel: float) -> float:
    """``fuel / pd_fuel``; 1 when both are 0, inf when only PD's is."""
    if pd_fuel > 0:
        return fuel / pd_fuel
    return 1.0 if fuel == 0 else float("inf")


def meets_bar(success_rate: float, ratio: float) -> bool:
    """Whether a success rate and fuel ratio meet the bar."""
    return success_rate >= SUCCESS_BAR and ratio <= FUEL_RATIO_BAR
