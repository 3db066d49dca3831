"""The SB3 algorithms by name, and their keyword arguments as frozen pydantic models.

A training config's ``hyperparams`` and ``policy_kwargs`` load into :class:`Hyperparams` and
:class:`PolicyKwargs`; :func:`argument_problems` then holds every key given against the chosen
algorithm's and policy's signatures, so a key SB3 would reject (or silently ignore) is an error
in the config file rather than in the middle of a run.
"""

from __future__ import annotations

import difflib
import inspect
from collections.abc import Iterable
from typing import Literal

from pydantic import BaseModel, ConfigDict

from rigid_env.config_files import (
    FieldError,
    Finite,
    Fraction,
    NonNegativeFloat,
    NonNegativeInt,
    PositiveFloat,
    PositiveInt,
)
from rigid_env.knobs import Flag

_RESERVED = {"policy", "env", "seed", "device", "policy_kwargs", "verbose", "tensorboard_log"}
"""Arguments the trainer sets itself (from the config's top-level keys)."""


class PolicyKwargs(BaseModel):
    """Policy keyword arguments; the trainer passes only those given."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)
    net_arch: list[PositiveInt] | dict[Literal["pi", "vf", "qf"], list[PositiveInt]] | None = None
    """Hidden layer widths, e.g. [64, 64] (or {pi: [64, 64], vf: [64, 64]} for two networks)."""
    activation_fn: Literal["tanh", "relu"] | None = None
    """Activation between hidden layers, by name."""
    log_std_init: Finite | None = None
    """Initial log standard deviation of a Gaussian policy (PPO, SAC)."""
    ortho_init: Flag | None = None
    """Orthogonal initialisation of the weights (PPO)."""
    n_critics: PositiveInt | None = None
    """Number of Q networks (SAC, TD3), >= 1."""
    share_features_extractor: Flag | None = None
    """One features extractor for actor and critic."""


class Hyperparams(BaseModel):
    """Keyword arguments of the SB3 algorithm: the common ones typed and bounded here, any
    other checked by name against the algorithm's signature (SB3 checks its value)."""

    model_config = ConfigDict(frozen=True, extra="allow", use_attribute_docstrings=True)
    learning_rate: PositiveFloat | None = None
    """Learning rate of the optimiser, > 0."""
    gamma: Fraction | None = None
    """Discount factor, in (0, 1]."""
    gae_lambda: Fraction | None = None
    """GAE's bias-variance factor, in (0, 1]."""
    clip_range: PositiveFloat | None = None
    """PPO's clipping of the probability ratio, > 0."""
    vf_coef: NonNegativeFloat | None = None
    """Weight of the value loss, >= 0."""
    max_grad_norm: PositiveFloat | None = None
    """Gradient-norm clip, > 0."""
    tau: Fraction | None = None
    """Soft target-update factor, in (0, 1]."""
    n_steps: PositiveInt | None = None
    """Steps per env and rollout (PPO), >= 1."""
    batch_size: PositiveInt | None = None
    """Minibatch size, >= 1."""
    n_epochs: PositiveInt | None = None
    """Passes over each rollout (PPO), >= 1."""
    buffer_size: PositiveInt | None = None
    """Replay buffer capacity in transitions, >= 1."""
    learning_starts: NonNegativeInt | None = None
    """Steps collected before the first gradient step, >= 0."""


def algorithm_class(algo: str) -> type:
    """The SB3 algorithm class for a config name (ppo, sac, td3; tqc from sb3-contrib)."""
    if algo == "tqc":
        try:
            from sb3_contrib import TQC
        except ImportError:
            raise FieldError("algo", "tqc needs sb3-contrib", "pip install sb3-contrib") from None
        return TQC
    import stable_baselines3 as sb3

    return {"ppo": sb3.PPO, "sac": sb3.SAC, "td3": sb3.TD3}[algo]


def argument_problems(algo: str, policy: str, section: str, keys: list[str]) -> list[FieldError]:
    """The keys of ``section`` (``hyperparams`` or ``policy_kwargs``) that the algorithm (or
    its ``policy``) does not take, one :class:`FieldError` each."""
    algo_cls = algorithm_class(algo)
    if section == "hyperparams":
        taken = inspect.signature(algo_cls.__init__).parameters
        return [
            FieldError(key, "is set by the trainer", "use the top-level key", unknown=True)
            if key in _RESERVED
            else FieldError(
                key,
                f"not a {algo_cls.__name__} argument",
                _near(key, taken, "see its documentation"),
                unknown=True,
            )
            for key in keys
            if key in _RESERVED or key not in taken
        ]
    taken = inspect.signature(algo_cls.policy_aliases[policy].__init__).parameters
    return [
        FieldError(
            key,
            f"not taken by {algo_cls.__name__}'s policy",
            _near(key, taken, "remove it"),
            unknown=True,
        )
        for key in keys
        if key not in taken
    ]


def _near(key: str, names: Iterable[str], otherwise: str) -> str:
    near = difflib.get_close_matches(
        key, [n for n in names if n not in _RESERVED], n=1, cutoff=0.75
    )
    return f"did you mean {near[0]}?" if near else otherwise
