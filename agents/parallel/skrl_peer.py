"""skrl's PPO on the same batched task: the peer the learner was chosen against (issue 45).

``rigid-env bench learn --rates`` measures it beside rsl-rl's PPO and the SB3 path; it is not a
training command (no run folder, no snapshots). Same env stack as the learner (SB3's
``VecNormalize`` over the batched task, a done env reset in the same call), same networks (two
tanh MLPs, a state-independent log-std) and the config's PPO arguments in skrl's names.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import torch
from skrl.agents.torch.ppo import PPO
from skrl.envs.wrappers.torch.base import Wrapper
from skrl.memories.torch import RandomMemory
from skrl.models.torch import DeterministicMixin, GaussianMixin, Model

from ..config import TrainConfig
from .learner import hidden_layers, ppo_arguments


class SkrlVecEnv(Wrapper):
    """An SB3 ``VecEnv`` as an skrl environment (tensors of shape (N, ...), (N, 1))."""

    def __init__(self, venv: Any) -> None:
        super().__init__(venv)
        self._venv = venv

    @property
    def num_envs(self) -> int:
        return self._venv.num_envs

    @property
    def observation_space(self) -> Any:
        return self._venv.observation_space

    @property
    def action_space(self) -> Any:
        return self._venv.action_space

    def reset(self) -> tuple[torch.Tensor, dict[str, Any]]:
        return torch.from_numpy(np.asarray(self._venv.reset(), np.float32)), {}

    def step(self, actions: torch.Tensor) -> tuple[Any, ...]:
        obs, reward, done, infos = self._venv.step(np.clip(actions.numpy(), -1.0, 1.0))
        truncated = np.zeros_like(done)
        for i in np.flatnonzero(done).tolist():
            truncated[i] = infos[i].get("TimeLimit.truncated", False)
        column = lambda a, t: torch.from_numpy(np.asarray(a, t)).view(-1, 1)  # noqa: E731
        return (torch.from_numpy(np.asarray(obs, np.float32)), column(reward, np.float32),
                column(done & ~truncated, bool), column(truncated, bool), {})  # fmt: skip

    def state(self) -> None:
        return None

    def render(self, *args: Any, **kwargs: Any) -> None:
        return None

    def close(self) -> None:
        self._venv.close()


def _mlp(sizes: list[int]) -> torch.nn.Sequential:
    layers: list[torch.nn.Module] = []
    for a, b in itertools.pairwise(sizes[:-1]):
        layers += [torch.nn.Linear(a, b), torch.nn.Tanh()]
    return torch.nn.Sequential(*layers, torch.nn.Linear(sizes[-2], sizes[-1]))


class _Policy(GaussianMixin, Model):
    def __init__(self, env: SkrlVecEnv, hidden: list[int], log_std: float) -> None:
        Model.__init__(self, observation_space=env.observation_space,
                       action_space=env.action_space, device="cpu")  # fmt: skip
        GaussianMixin.__init__(self, clip_actions=False)
        self.net = _mlp([self.num_observations, *hidden, self.num_actions])
        self.log_std = torch.nn.Parameter(torch.full((self.num_actions,), log_std))

    def compute(self, inputs: dict[str, Any], role: str = "") -> tuple[Any, dict[str, Any]]:
        return self.net(inputs["observations"]), {"log_std": self.log_std}


class _Value(DeterministicMixin, Model):
    def __init__(self, env: SkrlVecEnv, hidden: list[int]) -> None:
        Model.__init__(self, observation_space=env.observation_space,
                       action_space=env.action_space, device="cpu")  # fmt: skip
        DeterministicMixin.__init__(self)
        self.net = _mlp([self.num_observations, *hidden, 1])

    def compute(self, inputs: dict[str, Any], role: str = "") -> tuple[Any, dict[str, Any]]:
        return self.net(inputs["observations"]), {}


def make_skrl(cfg: TrainConfig, venv: Any) -> tuple[PPO, SkrlVecEnv]:
    """skrl's PPO agent for ``cfg`` on ``venv`` (an SB3 ``VecEnv``), and the wrapped env."""
    torch.manual_seed(cfg.seed)
    env = SkrlVecEnv(venv)
    a = ppo_arguments(cfg)
    pi, vf = hidden_layers(cfg)
    log_std = cfg.policy_kwargs.log_std_init or 0.0
    adaptive = {}
    if cfg.rsl_rl is not None and cfg.rsl_rl.schedule == "adaptive":  # skrl's own KL rule
        from skrl.resources.schedulers.torch import KLAdaptiveLR

        limits = {"kl_threshold": cfg.rsl_rl.desired_kl, "min_lr": 1e-5, "max_lr": 1e-2}
        adaptive = {"learning_rate_scheduler": KLAdaptiveLR,
                    "learning_rate_scheduler_kwargs": limits}  # fmt: skip
    memory = RandomMemory(memory_size=a["n_steps"], num_envs=env.num_envs, device="cpu")
    agent = PPO(
        models={"policy": _Policy(env, pi, log_std), "value": _Value(env, vf)},
        memory=memory,
        observation_space=env.observation_space,
        action_space=env.action_space,
        device="cpu",
        cfg={
            "rollouts": a["n_steps"],
            "learning_epochs": a["n_epochs"],
            "mini_batches": cfg.n_envs * a["n_steps"] // a["batch_size"],
            "discount_factor": a["gamma"],
            "gae_lambda": a["gae_lambda"],
            "learning_rate": a["learning_rate"],
            "grad_norm_clip": a["max_grad_norm"],
            "ratio_clip": a["clip_range"],
            "value_clip": 0.0,
            "entropy_loss_scale": a["ent_coef"],
            "value_loss_scale": a["vf_coef"],
            "time_limit_bootstrap": True,
            **adaptive,
        },
    )
    agent.init()
    return agent, env


def train_steps(agent: PPO, env: SkrlVecEnv, vector_steps: int, obs: torch.Tensor) -> Any:
    """``vector_steps`` steps of all envs through skrl's own loop (act, step, record, update
    every ``rollouts`` steps: :class:`skrl.trainers.torch.SequentialTrainer`'s body); returns
    the last observations."""
    agent.enable_training_mode(True)
    for t in range(vector_steps):
        agent.pre_interaction(timestep=t, timesteps=vector_steps)
        with torch.no_grad():
            actions, _ = agent.act(obs, None, timestep=t, timesteps=vector_steps)
            nxt, reward, terminated, truncated, infos = env.step(actions)
            agent.record_transition(observations=obs, states=None, actions=actions,
                                    rewards=reward, next_observations=nxt, next_states=None,
                                    terminated=terminated, truncated=truncated, infos=infos,
                                    timestep=t, timesteps=vector_steps)  # fmt: skip
        agent.post_interaction(timestep=t, timesteps=vector_steps)
        obs = nxt
    return obs
