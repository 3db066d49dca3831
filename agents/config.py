"""Training configuration: YAML -> validated frozen dataclasses (unknown keys are errors)."""

from __future__ import annotations

import dataclasses
import inspect
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

ALGOS = ("ppo", "sac", "td3", "tqc")


class ConfigError(ValueError):
    """A training configuration is wrong; the message names the file, the field and the fix."""


@dataclass(frozen=True)
class NormalizeConfig:
    """``VecNormalize`` settings."""

    obs: bool = True
    """Normalise observations by running mean and variance."""
    reward: bool = True
    """Scale rewards by the running std of the discounted return."""
    clip_obs: float = 10.0
    """Clip normalised observations to +- this."""


@dataclass(frozen=True)
class EvalConfig:
    """Periodic evaluation (``EvalCallback``) on seeds disjoint from training."""

    freq: int = 25_000
    """Environment steps between evaluations (summed over the training envs)."""
    episodes: int = 20
    """Episodes per evaluation."""
    seed: int = 1_000_000
    """Seed of the evaluation env (training uses ``seed`` .. ``seed + n_envs - 1``)."""


@dataclass(frozen=True)
class TrainConfig:
    """One training run: algorithm x task x seed."""

    env_id: str
    """Registered id, e.g. ``RigidEnv/Detumble-v0``."""
    algo: str
    """One of ppo, sac, td3, tqc (tqc needs sb3-contrib)."""
    total_timesteps: int
    """Environment steps to train for (summed over envs)."""
    seed: int = 0
    """Seed of the policy, the algorithm and the training envs."""
    n_envs: int = 8
    """Parallel environments in the native SB3 adapter."""
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    """Keyword arguments of the environment (as for ``gym.make``)."""
    policy: str = "MlpPolicy"
    """SB3 policy class name."""
    policy_kwargs: dict[str, Any] = field(default_factory=dict)
    """Policy keyword arguments (``net_arch``, ``log_std_init``, ...); ``activation_fn`` by
    name: ``tanh`` or ``relu``."""
    hyperparams: dict[str, Any] = field(default_factory=dict)
    """Keyword arguments of the SB3 algorithm, checked against its signature."""
    normalize: NormalizeConfig = field(default_factory=NormalizeConfig)
    """Observation/reward normalisation."""
    eval: EvalConfig = field(default_factory=EvalConfig)
    """Evaluation during training."""
    checkpoint_freq: int = 100_000
    """Environment steps between checkpoints (model, VecNormalize, replay buffer)."""
    device: str = "cpu"
    """Torch device."""

    @property
    def task(self) -> str:
        """Task name without namespace and version, e.g. ``Detumble``."""
        return self.env_id.split("/")[-1].split("-v")[0]

    @property
    def run_name(self) -> str:
        """``<task>__<algo>__<seed>``."""
        return f"{self.task}__{self.algo}__{self.seed}"

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (YAML-ready)."""
        return dataclasses.asdict(self)


def _err(source: str, path: str, problem: str) -> ConfigError:
    return ConfigError(f"{source}: {path}: {problem}")


def _build(cls: type, data: Any, source: str, path: str) -> Any:
    if not isinstance(data, dict):
        raise _err(source, path or "(top level)", f"expected a mapping, got {type(data).__name__}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - set(fields))
    if unknown:
        raise _err(
            source,
            f"{path + '.' if path else ''}{unknown[0]}",
            f"unknown key; allowed keys: {', '.join(fields)}",
        )
    kwargs: dict[str, Any] = {}
    hints = {f.name: f.type for f in dataclasses.fields(cls)}
    for name, value in data.items():
        where = f"{path + '.' if path else ''}{name}"
        hint = str(hints[name])
        if hint in ("NormalizeConfig", "EvalConfig"):
            kwargs[name] = _build(
                {"NormalizeConfig": NormalizeConfig, "EvalConfig": EvalConfig}[hint],
                value,
                source,
                where,
            )
            continue
        expected = {"str": str, "int": int, "float": (int, float), "bool": bool}.get(hint)
        if hint.startswith("dict"):
            expected = dict
        if expected is not None and (
            not isinstance(value, expected) or (expected is int and isinstance(value, bool))
        ):
            hint_txt = (
                " (write floats as 1.0e-4: YAML reads 1e-4 as a string)"
                if isinstance(value, str)
                else ""
            )
            raise _err(source, where, f"expected {hint}, got {value!r}{hint_txt}")
        kwargs[name] = value
    missing = [
        n
        for n, f in fields.items()
        if n not in kwargs
        and f.default is dataclasses.MISSING
        and f.default_factory is dataclasses.MISSING
    ]
    if missing:
        raise _err(source, f"{path + '.' if path else ''}{missing[0]}", "required key is missing")
    return cls(**kwargs)


def validate(cfg: TrainConfig, source: str) -> None:
    """Check values that types alone do not (ranges, names, algorithm keyword arguments)."""
    if cfg.algo not in ALGOS:
        raise _err(source, "algo", f"unknown {cfg.algo!r}; choose one of {', '.join(ALGOS)}")
    import gymnasium as gym

    import rigid_env  # noqa: F401

    if cfg.env_id not in gym.registry:
        known = ", ".join(k for k in gym.registry if k.startswith("RigidEnv/"))
        raise _err(source, "env_id", f"unknown id {cfg.env_id!r}; known: {known}")
    for name in ("total_timesteps", "n_envs", "checkpoint_freq"):
        if getattr(cfg, name) < 1:
            raise _err(source, name, f"must be >= 1, got {getattr(cfg, name)}")
    if cfg.eval.freq < 1 or cfg.eval.episodes < 1:
        raise _err(source, "eval", "freq and episodes must be >= 1")
    algo_cls = algorithm_class(cfg.algo)
    params = inspect.signature(algo_cls.__init__).parameters
    reserved = {"policy", "env", "seed", "device", "policy_kwargs", "verbose", "tensorboard_log"}
    for key in cfg.hyperparams:
        if key in reserved:
            raise _err(source, f"hyperparams.{key}", "is set by the trainer; use the top-level key")
        if key not in params:
            raise _err(
                source,
                f"hyperparams.{key}",
                f"not a {algo_cls.__name__} argument; see its documentation",
            )
    act = cfg.policy_kwargs.get("activation_fn")
    if act is not None and act not in ("tanh", "relu"):
        raise _err(source, "policy_kwargs.activation_fn", f"use 'tanh' or 'relu', got {act!r}")


def algorithm_class(algo: str) -> type:
    """The SB3 algorithm class for a config name."""
    if algo == "tqc":
        try:
            from sb3_contrib import TQC
        except ImportError as exc:
            raise ConfigError("algo: tqc needs sb3-contrib; pip install sb3-contrib") from exc
        return TQC
    import stable_baselines3 as sb3

    return {"ppo": sb3.PPO, "sac": sb3.SAC, "td3": sb3.TD3}[algo]


def load_config(
    source: str | os.PathLike[str] | dict[str, Any], overrides: dict[str, Any] | None = None
) -> TrainConfig:
    """Read, merge ``overrides`` (top-level keys), build and validate a :class:`TrainConfig`.

    Raises:
        ConfigError: one line naming the file, the field and the fix.
    """
    if isinstance(source, dict):
        name, data = "<config>", dict(source)
    else:
        name = str(source)
        path = Path(source)
        if not path.is_file():
            raise ConfigError(f"{name}: file not found; give the path of a YAML training config")
        try:
            data = yaml.safe_load(path.read_text())
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            where = f" at line {mark.line + 1}" if mark is not None else ""
            raise ConfigError(f"{name}: YAML syntax error{where}; fix the file") from None
    data = dict(data or {})
    data.update(overrides or {})
    cfg = _build(TrainConfig, data, name, "")
    validate(cfg, name)
    return cfg
