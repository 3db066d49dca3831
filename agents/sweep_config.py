"""The sweep file: a grid of training runs as a frozen pydantic model, and the trials it gives.

    sweep = load_sweep("configs/sweeps/detumble_seeds.yaml")
    for point in grid_points(sweep): cfg = trial_config(sweep, point)

Reading and the one-line errors are :mod:`rigid_env.config_files`' (as for the training config,
:mod:`agents.config`). Loading builds every trial's training config, so a grid point that makes
a bad config (an unknown integrator, a typo in a hyperparameter) fails here, naming the sweep
file, and never in a trial. See :mod:`agents.sweep` for the file's keys.
"""

from __future__ import annotations

import copy
import itertools
import json
import os
import re
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, field_validator, model_validator

from rigid_env.config_files import (
    ConfigFileError,
    FieldError,
    NonNegativeInt,
    PositiveInt,
    read_yaml,
    validate,
)

from .config import load_config

METRICS: dict[str, str] = {
    "success_rate": "max",
    "mean_return": "max",
    "mean_final_angular_speed": "min",
    "mean_fuel": "min",
}
"""Metrics a sweep can optimise, with their direction."""

AXES = ("seed", "env_id")
AXIS_PREFIXES = ("hyperparams.", "env_kwargs.", "policy_kwargs.")
"""Grid axes: exact names, and prefixes of keys inside a training-config mapping."""

_MAPPING_KEYS = ("env_kwargs", "policy_kwargs", "hyperparams", "normalize", "eval")
"""Training-config keys whose values are mappings: overrides merge into them."""

_FROZEN = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)


class SweepEvalConfig(BaseModel):
    """The episodes every report evaluates the policy on (``agents.evaluate.rollout``)."""

    model_config = _FROZEN
    episodes: PositiveInt = 100
    """Episodes, run at once, >= 1; episode k resets with seed + k, the same for every trial and
    every report."""
    seed: NonNegativeInt = 12345
    """First episode seed, >= 0."""


class SweepConfig(BaseModel):
    """A grid of training runs and how to schedule them."""

    model_config = _FROZEN
    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9_.-]+$")]
    """Sweep name, the folder under storage: letters, digits, _ . -."""
    base: Path
    """Training config (YAML) every trial starts from, relative to the sweep file."""
    grid: dict[str, list[Any]]
    """Axis -> non-empty list of values: seed, env_id, hyperparams.<name>, env_kwargs.<name>,
    policy_kwargs.<name>. Trials are the cartesian product."""
    total_timesteps: PositiveInt | None = None
    """Override of the base config's total_timesteps, >= 1."""
    overrides: dict[str, Any] = {}
    """Top-level training-config keys; mappings (eval, hyperparams, ...) merge."""
    cpus_per_trial: PositiveInt = 1
    """CPUs Ray reserves for a trial, >= 1; also its torch thread count."""
    max_concurrent: NonNegativeInt = 0
    """Trials running at once, >= 0; 0 leaves it to the free CPUs."""
    metric: Literal["success_rate", "mean_return", "mean_final_angular_speed", "mean_fuel"] = (
        "success_rate"
    )
    """Metric (of the final evaluation, mean over seeds) that picks the best setting."""
    evaluation: SweepEvalConfig = SweepEvalConfig()
    """Episodes of the evaluations reported to Tune (during training and at the end)."""
    storage: Path = Path("runs/sweeps")
    """Parent folder of the sweep's folder (relative to the working directory)."""
    _source: str = PrivateAttr("<sweep>")

    @field_validator("name")
    @classmethod
    def _folder_name(cls, name: str) -> str:
        if name in (".", ".."):
            raise ValueError(f"{name!r} is not a folder name; use letters, digits, _ . -")
        return name

    @field_validator("base")
    @classmethod
    def _exists(cls, base: Path) -> Path:
        if not base.is_file():
            raise ValueError(
                f"{base} not found; the path is relative to the sweep file, e.g. "
                "../agents/ppo_detumble.yaml"
            )
        return base

    @field_validator("grid")
    @classmethod
    def _axes(cls, grid: dict[str, list[Any]]) -> dict[str, list[Any]]:
        if not grid:
            raise ValueError("is empty; give at least one axis, e.g. seed: [0, 1, 2]")
        for axis, values in grid.items():
            nested = axis.startswith(AXIS_PREFIXES) and axis.count(".") == 1
            if axis not in AXES and not (nested and not axis.endswith(".")):
                raise FieldError(
                    axis,
                    "unknown axis",
                    "use seed, env_id, hyperparams.<name>, env_kwargs.<name> or "
                    "policy_kwargs.<name>",
                )
            if not values:
                raise FieldError(axis, "is an empty list", "give at least one value")
            kind = {"seed": int, "env_id": str}.get(axis)
            if kind is not None and not all(
                isinstance(v, kind) and not isinstance(v, bool) for v in values
            ):
                raise FieldError(
                    axis, f"expected a list of {kind.__name__}, got {values!r}", "fix the values"
                )
            texts = [json.dumps(v, sort_keys=True, default=str) for v in values]
            for v, text in zip(values, texts, strict=True):
                if texts.count(text) > 1:
                    raise FieldError(axis, f"value {v!r} appears twice", "keep one")
        return grid

    @field_validator("overrides")
    @classmethod
    def _not_an_axis(cls, overrides: dict[str, Any]) -> dict[str, Any]:
        for key in ("seed", "env_id", "total_timesteps"):
            if key in overrides:
                where = "the top-level key" if key == "total_timesteps" else f"grid.{key}"
                raise FieldError(key, "is not an override", f"set it with {where}")
        return overrides

    @model_validator(mode="after")
    def _every_trial_is_a_config(self) -> SweepConfig:
        """Build the base config with the overrides, then every trial's config."""
        try:
            base = base_data(self)
            load_config(base)
        except ConfigFileError as exc:
            raise FieldError("overrides", f"{exc.path}: {exc.problem}", exc.fix) from None
        folders: dict[str, str] = {}
        for point in grid_points(self):
            label = setting_label(self.varying, point)
            setting = json.dumps({a: v for a, v in point.items() if a != "seed"}, default=str)
            if folders.setdefault(setting_folder(label), setting) != setting:
                raise FieldError(
                    "grid",
                    f"two settings share the folder name {setting_folder(label)!r}",
                    "make their values differ more",
                )
            try:
                load_config(trial_data(base, point))
            except ConfigFileError as exc:
                where = ", ".join(f"{a}={v!r}" for a, v in point.items()) or "the base config"
                raise FieldError(
                    "grid", f"{where} gives {exc.path}: {exc.problem}", exc.fix
                ) from None
        return self

    @property
    def source(self) -> str:
        """Where the sweep was read from (for messages)."""
        return self._source

    @property
    def mode(self) -> str:
        """``max`` or ``min``: the direction of :attr:`metric`."""
        return METRICS[self.metric]

    @property
    def directory(self) -> Path:
        """``<storage>/<name>``."""
        return self.storage / self.name

    @property
    def varying(self) -> list[str]:
        """Axes other than ``seed`` with more than one value: they tell settings apart."""
        return [k for k, v in self.grid.items() if k != "seed" and len(v) > 1]

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (YAML-ready), ``base`` and ``storage`` as strings."""
        return self.model_dump(mode="json")


def load_sweep(path: str | os.PathLike[str], storage: Path | None = None) -> SweepConfig:
    """Read and validate a sweep file, down to every trial's training config; ``storage``
    overrides the file's.

    Raises:
        ConfigFileError: one line naming the file, the key and the fix.
    """
    source = str(path)
    data = read_yaml(path)
    if isinstance(data, dict):
        if isinstance(data.get("base"), str):
            data["base"] = str((Path(path).resolve().parent / data["base"]).resolve())
        if storage is not None:
            data["storage"] = str(storage)
    sweep = validate(SweepConfig, data, source)
    sweep._source = source
    return sweep


def _merge(data: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    """``data`` with ``overrides`` applied; mapping-valued training keys merge one level."""
    out = copy.deepcopy(data)
    for k, v in overrides.items():
        if k in _MAPPING_KEYS and isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = {**out[k], **copy.deepcopy(v)}
        else:
            out[k] = copy.deepcopy(v)
    return out


def base_data(sweep: SweepConfig) -> dict[str, Any]:
    """The base training config with the sweep's overrides and budget, as a plain dict."""
    data = _merge(load_config(sweep.base).to_dict(), sweep.overrides)
    if sweep.total_timesteps is not None:
        data["total_timesteps"] = sweep.total_timesteps
    return data


def trial_data(base: dict[str, Any], point: dict[str, Any]) -> dict[str, Any]:
    """Training-config dict of one grid point (``{axis: value}``)."""
    nested: dict[str, Any] = {}
    for axis, value in point.items():
        group, dot, key = axis.partition(".")
        if dot:
            nested.setdefault(group, {})[key] = value
        else:
            nested[axis] = value
    return _merge(base, nested)


def grid_points(sweep: SweepConfig) -> list[dict[str, Any]]:
    """Every trial's ``{axis: value}``, settings in file order and seeds innermost."""
    axes = [a for a in sweep.grid if a != "seed"] + (["seed"] if "seed" in sweep.grid else [])
    return [
        dict(zip(axes, combo, strict=True))
        for combo in itertools.product(*(sweep.grid[a] for a in axes))
    ]


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, list | dict):
        return json.dumps(value, separators=(",", ":"))
    return str(value)


def setting_label(varying: list[str], point: dict[str, Any]) -> str:
    """Human label of a setting, e.g. ``learning_rate=0.0003, integrator=rk4`` (``base``
    when only the seed varies)."""
    short = {a: a.split(".")[-1] for a in varying}
    if len(set(short.values())) < len(short):
        short = {a: a for a in varying}
    parts = []
    for a in varying:
        v = str(point[a]).split("/")[-1] if a == "env_id" else point[a]
        parts.append(f"{short[a]}={_fmt(v)}")
    return ", ".join(parts) or "base"


def setting_folder(label: str) -> str:
    """A folder name for a setting label."""
    return re.sub(r"[^A-Za-z0-9_.=+-]+", "_", label.replace(", ", ",")).strip("_") or "base"
