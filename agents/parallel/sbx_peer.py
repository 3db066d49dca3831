"""sbx-rl's PPO (Stable Baselines Jax) on the batched task: the JIT-compiled peer (issue 45).

``rigid-env bench learn --rates-only`` measures it beside the SB3 path, rsl-rl and skrl; it is
not a training command (no run folder, no snapshots). Its update is one ``jax.jit``-compiled
function per minibatch (forward, backward and Adam of actor and critic fused by XLA), where
torch dispatches every operation of a small [64, 64] layer from Python; its rollout is SB3's
loop with one compiled call per step (sample, log-probability and value together).

Same env stack as the other learners (SB3's ``VecNormalize`` over the batched task, a done env
reset in the same call: sbx-rl's PPO *is* SB3's ``OnPolicyAlgorithm`` and takes the SB3
``VecEnv`` as it is), same networks (two tanh MLPs, a state-independent log-std), the config's
PPO arguments under SB3's own names, and ``rsl_rl.schedule: adaptive`` as sbx-rl's
``target_kl`` (the same KL-adaptive rule as rsl-rl's: the learning rate divided or multiplied
by 1.5 when an update's KL leaves [desired/2, 2 desired]). What is ours is only the bootstrap
of episodes cut by the time limit: sbx-rl calls the critic once per such env, on one
observation (512 envs whose episodes end together: 215 ms on the loaded development machine);
here it is one compiled critic pass over all N terminal observations of the step (18 ms).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from flax import linen as nn
from sbx import PPO
from stable_baselines3.common.vec_env import VecEnvWrapper

from ..config import TrainConfig
from .learner import hidden_layers, ppo_arguments

ACTIVATIONS = {"tanh": nn.tanh, "relu": nn.relu, "elu": nn.elu}
"""The config's ``activation_fn`` names as flax functions."""


class _Bootstrap(VecEnvWrapper):
    """The env as sbx-rl's rollout sees it: a time-limited episode's reward already carries
    gamma times the critic's value of its terminal observation, and its info no
    ``terminal_observation`` (so that sbx-rl's per-env loop adds nothing twice)."""

    def __init__(self, venv: Any, model: PPO) -> None:
        super().__init__(venv)
        self.model = model
        self._terminal = np.zeros((venv.num_envs, *venv.observation_space.shape), np.float32)
        self._values = jax.jit(lambda params, obs: model.vf.apply(params, obs).flatten())

    def reset(self) -> Any:
        return self.venv.reset()

    def step_wait(self) -> tuple[Any, ...]:
        obs, rewards, dones, infos = self.venv.step_wait()
        cut = [i for i in np.flatnonzero(dones).tolist()
               if infos[i].get("TimeLimit.truncated", False)
               and infos[i].get("terminal_observation") is not None]  # fmt: skip
        if cut:
            for i in cut:
                self._terminal[i] = infos[i]["terminal_observation"]
                infos[i] = {k: v for k, v in infos[i].items() if k != "terminal_observation"}
            values = np.asarray(self._values(self.model.policy.vf_state.params, self._terminal))
            rewards = np.asarray(rewards, np.float32).copy()
            rewards[cut] += self.model.gamma * values[cut]
        return obs, rewards, dones, infos


class BatchedPPO(PPO):
    """sbx-rl's PPO with the time-limit bootstrap in one compiled pass per step."""

    def collect_rollouts(self, env: Any, *args: Any, **kwargs: Any) -> bool:
        if getattr(self, "_bootstrap", None) is None or self._bootstrap.venv is not env:
            self._bootstrap = _Bootstrap(env, self)
        return super().collect_rollouts(self._bootstrap, *args, **kwargs)


def make_sbx(cfg: TrainConfig, venv: Any) -> BatchedPPO:
    """sbx-rl's PPO for ``cfg`` (its rsl-rl-style config) on ``venv`` (an SB3 ``VecEnv``)."""
    a = ppo_arguments(cfg)
    pi, vf = hidden_layers(cfg)
    policy_kwargs = {
        "net_arch": {"pi": pi, "vf": vf},
        "activation_fn": ACTIVATIONS[cfg.policy_kwargs.activation_fn or "tanh"],
        "log_std_init": cfg.policy_kwargs.log_std_init or 0.0,
        # The action layer starts as SB3's does (orthogonal, gain 0.01: mean actions near 0);
        # flax's default (LeCun normal) starts them at order 1, and on SB3's own Detumble config
        # seed 0 then ended at 0.56 success and 5.2x PD's fuel after 500k steps.
        "ortho_init": True,
    }
    target_kl = None
    if cfg.rsl_rl is not None and cfg.rsl_rl.schedule == "adaptive":
        target_kl = cfg.rsl_rl.desired_kl
    return BatchedPPO(
        "MlpPolicy",
        venv,
        learning_rate=a["learning_rate"],
        n_steps=a["n_steps"],
        batch_size=a["batch_size"],
        n_epochs=a["n_epochs"],
        gamma=a["gamma"],
        gae_lambda=a["gae_lambda"],
        clip_range=a["clip_range"],
        ent_coef=a["ent_coef"],
        vf_coef=a["vf_coef"],
        max_grad_norm=a["max_grad_norm"],
        target_kl=target_kl,
        policy_kwargs=policy_kwargs,
        seed=cfg.seed,
        verbose=0,
    )


def sample(model: BatchedPPO, obs: np.ndarray) -> tuple[np.ndarray, Any]:
    """One rollout step's forward pass (actions, log-probabilities, values), as sbx-rl's
    rollout calls it; returns the actions clipped to the action space and the outputs."""
    model.policy.reset_noise()
    actions, log_probs, values = model.policy.predict_all(jnp.asarray(obs), model.policy.noise_key)
    low, high = model.action_space.low, model.action_space.high
    return np.clip(np.asarray(actions), low, high), (log_probs, values)
