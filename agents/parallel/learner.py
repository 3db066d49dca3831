"""rsl-rl's PPO built from a training config, and its networks as an SB3 ``PPO``.

A config's ``hyperparams`` keep SB3's names and meanings (they are checked against SB3's PPO):
``n_steps`` steps per env and rollout, ``batch_size`` samples per minibatch (it must divide
``n_envs * n_steps``), ``n_epochs`` passes, and SB3's defaults for what is not given. rsl-rl then
runs with SB3's choices where the two differ: a fixed learning rate (unless the config's
``rsl_rl.schedule`` asks for rsl-rl's KL-adaptive one),
advantages normalised per minibatch, the value loss unclipped. Its networks start from PyTorch's
default initialisation (SB3's is orthogonal), and it bootstraps a time-limited episode on the
value of the step's own observation (SB3: of the last observation).

:func:`to_sb3` copies the actor and critic into an SB3 ``MlpPolicy`` of the same layout, layer by
layer: SB3's deterministic action is then the learner's (the actor's mean, clipped to the action
space) to float32 rounding, and its ``VecNormalize`` is the one the learner trained under.
"""

from __future__ import annotations

import contextlib
import inspect
import io
from typing import Any

import torch

from ..activations import use_fast_tanh
from ..config import ConfigError, TrainConfig
from .vec import OBS_GROUP, RslVecEnv

TAKEN = ("learning_rate", "n_steps", "batch_size", "n_epochs", "gamma", "gae_lambda",
         "clip_range", "ent_coef", "vf_coef", "max_grad_norm")  # fmt: skip
"""SB3 PPO arguments the rsl-rl learner takes (others are refused, not ignored)."""
POLICY_TAKEN = ("net_arch", "activation_fn", "log_std_init")


def ppo_arguments(cfg: TrainConfig) -> dict[str, Any]:
    """The config's PPO arguments, SB3's defaults filled in.

    Raises:
        ConfigError: an argument rsl-rl's PPO has no counterpart for, or a ``batch_size`` that
            does not divide ``n_envs * n_steps``.
    """
    from stable_baselines3 import PPO

    given = cfg.hyperparams.model_dump(exclude_none=True)
    given_policy = cfg.policy_kwargs.model_dump(exclude_none=True)
    for section, keys, taken in (("hyperparams", given, TAKEN),
                                 ("policy_kwargs", given_policy, POLICY_TAKEN)):  # fmt: skip
        other = sorted(set(keys) - set(taken))
        if other:
            raise ConfigError(cfg.run_name, f"{section}.{other[0]}", "not taken by learner "
                              "rsl_rl", f"remove it (it takes {', '.join(taken)})")  # fmt: skip
    defaults = {
        k: p.default for k, p in inspect.signature(PPO.__init__).parameters.items() if k in TAKEN
    }
    args = {**defaults, **given}
    samples = cfg.n_envs * args["n_steps"]
    if samples % args["batch_size"]:
        raise ConfigError(cfg.run_name, "hyperparams.batch_size", f"{args['batch_size']} does "
                          f"not divide n_envs * n_steps = {samples}", "choose a divisor "
                          "(rsl-rl splits each rollout into equal minibatches)")  # fmt: skip
    return args


def hidden_layers(cfg: TrainConfig) -> tuple[list[int], list[int]]:
    """Hidden widths of the actor and the critic (SB3's default [64, 64] for both)."""
    arch = cfg.policy_kwargs.net_arch
    if arch is None:
        return [64, 64], [64, 64]
    if isinstance(arch, dict):
        return list(arch.get("pi", [64, 64])), list(arch.get("vf", [64, 64]))
    return list(arch), list(arch)


def runner_config(cfg: TrainConfig) -> dict[str, Any]:
    """rsl-rl's ``OnPolicyRunner`` configuration for ``cfg``."""
    import math

    from ..config import RslRlConfig

    a = ppo_arguments(cfg)
    rsl = cfg.rsl_rl or RslRlConfig()
    pi, vf = hidden_layers(cfg)
    activation = cfg.policy_kwargs.activation_fn or "tanh"
    log_std = 0.0 if cfg.policy_kwargs.log_std_init is None else cfg.policy_kwargs.log_std_init
    distribution = {"class_name": "GaussianDistribution", "init_std": math.exp(log_std),
                    "std_type": "log"}  # fmt: skip
    return {
        "num_steps_per_env": a["n_steps"],
        "save_interval": 10**9,
        "check_for_nan": False,  # the task raises on a non-finite state itself
        "obs_groups": {"actor": [OBS_GROUP], "critic": [OBS_GROUP]},
        "actor": {
            "class_name": "MLPModel",
            "hidden_dims": pi,
            "activation": activation,
            "obs_normalization": False,
            "distribution_cfg": distribution,
        },
        "critic": {
            "class_name": "MLPModel",
            "hidden_dims": vf,
            "activation": activation,
            "obs_normalization": False,
        },
        "algorithm": {
            "class_name": "PPO",
            "num_learning_epochs": a["n_epochs"],
            "num_mini_batches": cfg.n_envs * a["n_steps"] // a["batch_size"],
            "clip_param": a["clip_range"],
            "gamma": a["gamma"],
            "lam": a["gae_lambda"],
            "value_loss_coef": a["vf_coef"],
            "entropy_coef": a["ent_coef"],
            "learning_rate": a["learning_rate"],
            "max_grad_norm": a["max_grad_norm"],
            "use_clipped_value_loss": False,
            "schedule": rsl.schedule,
            "desired_kl": rsl.desired_kl,
            "normalize_advantage_per_mini_batch": True,
        },
    }


def make_runner(cfg: TrainConfig, venv: Any, max_episode_steps: int) -> Any:
    """rsl-rl's ``OnPolicyRunner`` on ``venv`` (SB3 ``VecEnv``), seeded by ``cfg.seed``, its
    networks' tanh NumPy's (:mod:`agents.activations`); it logs nothing and writes nothing (the
    run folder is :mod:`agents.parallel.train`'s)."""
    from rsl_rl.runners import OnPolicyRunner

    torch.manual_seed(cfg.seed)
    env = RslVecEnv(venv, max_episode_steps)
    with contextlib.redirect_stdout(io.StringIO()):  # it prints the networks
        runner = OnPolicyRunner(env, runner_config(cfg), log_dir=None, device="cpu")
    use_fast_tanh(runner.alg.actor)
    use_fast_tanh(runner.alg.critic)
    return runner


def _linears(module: torch.nn.Module) -> list[torch.nn.Linear]:
    return [m for m in module.modules() if isinstance(m, torch.nn.Linear)]


def _pairs(runner: Any, policy: Any) -> list[tuple[torch.nn.Linear, torch.nn.Linear]]:
    """(rsl-rl layer, SB3 layer) for every linear layer of actor and critic, in order."""
    actor, critic = runner.alg.get_policy(), runner.alg._raw_critic
    sb3_pi = [*_linears(policy.mlp_extractor.policy_net), policy.action_net]
    sb3_vf = [*_linears(policy.mlp_extractor.value_net), policy.value_net]
    ours = [*_linears(actor.mlp), *_linears(critic.mlp)]
    theirs = [*sb3_pi, *sb3_vf]
    if [m.weight.shape for m in ours] != [m.weight.shape for m in theirs]:
        raise ValueError("the SB3 policy's layers differ from the learner's (net_arch?)")
    return list(zip(ours, theirs, strict=True))


@torch.no_grad()
def to_sb3(runner: Any, model: Any) -> None:
    """Copy the learner's actor, critic and log-std into the SB3 ``PPO`` ``model``."""
    for src, dst in _pairs(runner, model.policy):
        dst.weight.copy_(src.weight)
        dst.bias.copy_(src.bias)
    model.policy.log_std.copy_(runner.alg.get_policy().distribution.log_std_param)


@torch.no_grad()
def from_sb3(model: Any, runner: Any) -> None:
    """The inverse of :func:`to_sb3` (a resumed run's networks)."""
    for dst, src in _pairs(runner, model.policy):
        dst.weight.copy_(src.weight)
        dst.bias.copy_(src.bias)
    runner.alg.get_policy().distribution.log_std_param.copy_(model.policy.log_std)
