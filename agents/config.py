"""Training configuration: YAML -> frozen pydantic models (unknown keys and bad values are errors).

Reading and the one-line errors (``file: field.path: problem; fix``) are
:mod:`rigid_env.config_files`'; the algorithm's keyword arguments are :mod:`agents.algorithms`'.
"""

from __future__ import annotations

import os
import re
from typing import Annotated, Any, Literal

import gymnasium as gym
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
    ValidatorFunctionWrapHandler,
    field_validator,
)

from rigid_env.config_files import (
    ConfigFileError,
    FieldError,
    NonNegativeInt,
    PositiveFloat,
    PositiveInt,
    load_model,
)
from rigid_env.knobs import Flag

from .algorithms import Hyperparams, PolicyKwargs, argument_problems
from .algorithms import algorithm_class as algorithm_class  # re-exported
from .env_kwargs import check_env_kwargs

MAX_ENVS = 65_536
"""The most training envs: the largest batch the core's benchmarks measure (DESIGN.md)."""
ConfigError = ConfigFileError
"""A training configuration is wrong; the message names the file, the field and the fix."""
_FROZEN = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)


class NormalizeConfig(BaseModel):
    """``VecNormalize`` settings."""

    model_config = _FROZEN
    obs: Flag = True
    """Normalise observations by running mean and variance."""
    reward: Flag = True
    """Scale rewards by the running std of the discounted return."""
    clip_obs: PositiveFloat = 10.0
    """Clip normalised observations to +- this, > 0."""


class EvalConfig(BaseModel):
    """Periodic evaluation on seeds disjoint from training: the same ``episodes`` episodes
    (episode ``k`` resets with ``seed + k``) every time, all at once in the native vector env,
    on the task without the training randomisation, beside the PD controller's fuel."""

    model_config = _FROZEN
    freq: PositiveInt = 25_000
    """Environment steps between evaluations (summed over the training envs), >= 1."""
    episodes: PositiveInt = 100
    """Episodes per evaluation, >= 1."""
    seed: NonNegativeInt = 1_000_000
    """Seed of the evaluation env, >= 0 (training uses seed .. seed + n_envs - 1)."""


class RslRlConfig(BaseModel):
    """Settings of rsl-rl's PPO that SB3's PPO has no argument for (``learner: rsl_rl``)."""

    model_config = _FROZEN
    schedule: Literal["fixed", "adaptive"] = "fixed"
    """The learning rate: fixed, or adapted after each minibatch to keep the KL divergence
    between the rollout's policy and the updated one near ``desired_kl`` (divided by 1.5 above
    twice it, multiplied by 1.5 below half of it, within [1e-5, 1e-2])."""
    desired_kl: PositiveFloat = 0.01
    """The KL divergence the adaptive schedule aims at, > 0."""


class TrainConfig(BaseModel):
    """One training run: algorithm x task x seed."""

    model_config = _FROZEN
    env_id: str
    """Registered id, e.g. RigidEnv/Detumble-v0."""
    algo: Literal["ppo", "sac", "td3", "tqc"]
    """The algorithm (tqc needs sb3-contrib)."""
    learner: Literal["sb3", "rsl_rl"] | None = None
    """Who runs it: SB3 (left out, or sb3) or rsl-rl's PPO over the whole batch of envs
    (rsl_rl: algo ppo only, ``pip install 'rigid_env[learner]'``; see agents.parallel)."""
    rsl_rl: RslRlConfig | None = None
    """Settings of learner rsl_rl beyond SB3's PPO arguments (only with that learner)."""
    total_timesteps: PositiveInt
    """Environment steps to train for (summed over envs), >= 1."""
    seed: Annotated[NonNegativeInt, Field(le=2**32 - 1)] = 0
    """Seed of the policy, the algorithm and the training envs, 0 .. 2**32 - 1 (SB3 seeds
    NumPy's global generator with it, which takes no more)."""
    n_envs: Annotated[PositiveInt, Field(le=MAX_ENVS)] = 8
    """Parallel environments in the native SB3 adapter, 1 .. 65536 (the batch the core is
    built and measured for)."""
    env_kwargs: dict[str, Any] = Field(default_factory=dict)
    """Keyword arguments of the environment (as for gym.make); checked by building it once."""
    train_max_episode_steps: PositiveInt | None = None
    """Time limit of the training episodes in control steps, >= 1 (left out: the registered
    one). Evaluations always run the registered, full-length episodes: a task whose episode is
    long (SunAcquisition's orbit, 2840 steps) may train on shorter segments, which start
    anywhere its reset draws (an episode's start is drawn on the orbit), and the bar is still
    judged on the task as registered. A truncated training episode bootstraps from the value
    of its last observation (SB3's ``TimeLimit.truncated``), as at the registered limit."""
    policy: Literal["MlpPolicy"] = "MlpPolicy"
    """SB3 policy class name (the observations are flat vectors)."""
    policy_kwargs: PolicyKwargs = Field(default_factory=PolicyKwargs)
    """Policy keyword arguments."""
    hyperparams: Hyperparams = Field(default_factory=Hyperparams)
    """Keyword arguments of the SB3 algorithm, checked against its signature."""
    normalize: NormalizeConfig = Field(default_factory=NormalizeConfig)
    """Observation/reward normalisation."""
    eval: EvalConfig = Field(default_factory=EvalConfig)
    """Evaluation during training."""
    checkpoint_freq: PositiveInt = 100_000
    """Environment steps between checkpoints (model, VecNormalize, replay buffer), >= 1."""
    device: str = "cpu"
    """Torch device: cpu, cuda, cuda:N, mps or auto."""
    threads: PositiveInt = 1
    """CPU threads of the run (torch's and Numba's), >= 1: one per run, so that two seeds train
    at once on two cores (each run then as fast as alone, where two runs of two threads each
    fight over the cores and take many times longer)."""

    @field_validator("env_id")
    @classmethod
    def _registered(cls, env_id: str) -> str:
        if env_id not in gym.registry:
            known = ", ".join(k for k in gym.registry if k.startswith("RigidEnv/"))
            raise ValueError(f"unknown id {env_id!r}; known: {known}")
        return env_id

    @field_validator("device")
    @classmethod
    def _known_device(cls, name: str) -> str:
        if not re.fullmatch(r"cpu|auto|mps|cuda(:\d+)?", name):
            raise ValueError(f"unknown device {name!r}; use cpu, cuda, cuda:N, mps or auto")
        if name.startswith("cuda"):
            import torch

            index = int(name.partition(":")[2] or 0)
            if index >= torch.cuda.device_count():
                raise ValueError(f"no CUDA device {index} on this machine; use cpu or auto")
        return name

    @field_validator("algo")
    @classmethod
    def _installed(cls, algo: str) -> str:
        try:
            algorithm_class(algo)
        except FieldError as exc:
            raise ValueError(f"{exc.problem}; {exc.fix}") from None
        return algo

    @field_validator("learner")
    @classmethod
    def _learner_runs_algo(cls, learner: str | None, info: ValidationInfo) -> str | None:
        if learner == "rsl_rl":
            if info.data.get("algo") not in (None, "ppo"):
                raise ValueError("rsl_rl runs algo ppo only; use learner sb3 for the others")
            try:
                import rsl_rl  # noqa: F401
            except ImportError:
                raise ValueError(
                    "rsl_rl is not installed; pip install 'rigid_env[learner]'"
                ) from None
        return learner

    @field_validator("rsl_rl")
    @classmethod
    def _only_with_rsl_rl(cls, value: RslRlConfig | None, info: ValidationInfo) -> Any:
        if value is not None and info.data.get("learner") != "rsl_rl":
            raise ValueError("applies to learner rsl_rl only; remove it or set learner: rsl_rl")
        return value

    @field_validator("policy_kwargs", "hyperparams", mode="wrap")
    @classmethod
    def _taken_by_algorithm(
        cls, value: Any, handler: ValidatorFunctionWrapHandler, info: ValidationInfo
    ) -> Any:
        """Every key given is one the algorithm (or its policy) takes; the first key that is
        not is named before the section's typed problems, and all are counted."""
        algo, policy = info.data.get("algo"), info.data.get("policy")
        keys = [k for k, v in value.items() if v is not None] if isinstance(value, dict) else []
        if info.field_name == "policy_kwargs":  # other keys are PolicyKwargs' unknown keys
            keys = [k for k in keys if k in PolicyKwargs.model_fields]
        keys = [k for k in keys if isinstance(k, str)]
        found = []
        if algo is not None and policy is not None and keys:
            found = argument_problems(algo, policy, str(info.field_name), keys)
        typed = 0
        try:
            checked = handler(value)
        except ValidationError as exc:
            if not found:
                raise
            typed = len(exc.errors())
        if found:
            first = found[0]
            raise FieldError(first.path, first.problem, first.fix, len(found) - 1 + typed, True)
        return checked

    @field_validator("env_kwargs")
    @classmethod
    def _env_builds(cls, env_kwargs: dict[str, Any], info: ValidationInfo) -> dict[str, Any]:
        env_id = info.data.get("env_id")
        if env_id is None:
            return env_kwargs
        try:
            check_env_kwargs(env_id, env_kwargs).close()
        except ValueError as exc:
            field, _, text = str(exc).partition(": ")
            problem, _, fix = text.partition("; ")
            raise FieldError(field, problem, fix or "fix the value") from None
        return env_kwargs

    @property
    def task(self) -> str:
        """Task name without namespace and version, e.g. ``Detumble``."""
        return self.env_id.split("/")[-1].split("-v")[0]

    @property
    def run_name(self) -> str:
        """``<task>__<algo>__<seed>`` (``<algo>_rsl`` for learner rsl_rl)."""
        algo = f"{self.algo}_rsl" if self.learner == "rsl_rl" else self.algo
        return f"{self.task}__{algo}__{self.seed}"

    @property
    def gamma(self) -> float:
        """The discount factor the algorithm uses (SB3's default 0.99 unless given)."""
        return 0.99 if self.hyperparams.gamma is None else self.hyperparams.gamma

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (YAML-ready), without the keys left to SB3's defaults."""
        return self.model_dump(mode="json", exclude_none=True)


def load_config(
    source: str | os.PathLike[str] | dict[str, Any], overrides: dict[str, Any] | None = None
) -> TrainConfig:
    """Read, merge ``overrides`` (top-level keys) and validate a :class:`TrainConfig`.

    Raises:
        ConfigError: one line naming the file, the field and the fix.
    """
    return load_model(TrainConfig, source, overrides)
