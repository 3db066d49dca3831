"""Sweep a training config over seeds x hyperparameters x tasks x integrators as Ray Tune trials.

    python -m agents.sweep configs/sweeps/detumble_seeds.yaml [--address ray://HOST:10001]
                           [--resume] [--storage DIR] [--num-cpus N] [--verbose]

Without ``--address`` (or ``RAY_ADDRESS``) the command starts a local Ray instance and stops it
at the end. With ``--address ray://HEAD:10001`` (Ray Client), ``HEAD:6379`` or ``auto`` it joins
a running cluster, shipping this checkout (code and ``configs/``) as the trials' working
directory; the nodes need the same Ray and Python and the package's dependencies, and
``storage`` must be a folder every node can write (run folders are written where trials run).
An address where nothing answers fails within ``--connect-timeout`` seconds.

Each trial calls :func:`agents.train.train` (the same job as ``agents.train``) and writes the
same run folder, under ``<storage>/<name>/runs/<setting>/<task>__<algo>__<seed>/``.
After each of the job's periodic evaluations (every ``eval.freq`` steps) and at the end, it
evaluates the policy on the sweep's fixed episodes (``evaluation``: the same for every trial
and every report, as ``python -m agents.evaluate`` runs them) and reports success rate,
return, final angular speed and fuel to Tune; the final model's metrics go to
``final_eval.json`` in the run folder.

At the end ``<storage>/<name>/`` holds ``summary.md`` and ``summary.csv`` (per setting: mean and
spread over seeds; per trial), ``summary.png`` (the figure) and ``best_config.yaml`` (the
training config of the best setting, ready for ``python -m agents.train``). Ray Tune's own
state is in ``<storage>/<name>/tune/``; ``--resume`` continues an interrupted sweep from it
without re-running finished trials (an unfinished trial continues from its newest checkpoint).

Sweep file (unknown keys are errors; relative ``base`` is relative to the sweep file,
``storage`` to the working directory)::

    name: detumble_seeds                  # folder name under storage
    base: ../agents/ppo_detumble.yaml     # training config the grid starts from
    total_timesteps: 150000               # optional override of the base's budget
    overrides: {eval: {episodes: 5}}      # optional top-level training-config keys (merged)
    grid:                                 # cartesian product; every axis a non-empty list
      seed: [0, 1, 2]
      hyperparams.learning_rate: [3.0e-4, 1.0e-3]
      env_id: [RigidEnv/Detumble-v0]
      env_kwargs.integrator: [rk4, splitting]
    cpus_per_trial: 1                     # Ray CPUs (and torch threads) per trial
    max_concurrent: 2                     # trials at once (0: as many as the CPUs allow)
    metric: success_rate                  # success_rate | mean_return (max),
                                          # mean_final_angular_speed | mean_fuel (min)
    evaluation: {episodes: 100, seed: 12345}  # episode k resets with seed + k
    storage: runs/sweeps
"""

from __future__ import annotations

import argparse
import copy
import csv
import dataclasses
import io
import itertools
import json
import logging
import math
import os
import re
import shutil
import signal
import socket
import sys
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .config import ConfigError, TrainConfig, load_config

#: Metrics a sweep can optimise, with their direction.
METRICS: dict[str, str] = {
    "success_rate": "max",
    "mean_return": "max",
    "mean_final_angular_speed": "min",
    "mean_fuel": "min",
}

#: Grid axes: exact names, and prefixes of keys inside a training-config mapping.
AXES = ("seed", "env_id")
AXIS_PREFIXES = ("hyperparams.", "env_kwargs.", "policy_kwargs.")

#: Training-config keys whose values are mappings: overrides merge into them.
_MAPPING_KEYS = ("env_kwargs", "policy_kwargs", "hyperparams", "normalize", "eval")

_TUNE_DIR = "tune"


class SweepError(RuntimeError):
    """The sweep cannot run (no cluster at the address, nothing to resume); one line."""


@dataclass(frozen=True)
class SweepEvalConfig:
    """The episodes every report evaluates the policy on (``agents.evaluate.rollout``)."""

    episodes: int = 100
    """Episodes, run at once; episode ``k`` resets with seed ``seed + k``, the same for every
    trial and every report."""
    seed: int = 12345
    """First episode seed."""


@dataclass(frozen=True)
class SweepConfig:
    """A grid of training runs and how to schedule them."""

    name: str
    """Sweep name: the folder under ``storage`` (letters, digits, ``_ . -``)."""
    base: Path
    """Training config (YAML) every trial starts from; absolute once loaded."""
    grid: dict[str, list[Any]]
    """Axis -> values: ``seed``, ``env_id``, ``hyperparams.<name>``, ``env_kwargs.<name>``,
    ``policy_kwargs.<name>``. Trials are the cartesian product."""
    total_timesteps: int | None = None
    """Override of the base config's ``total_timesteps``."""
    overrides: dict[str, Any] = field(default_factory=dict)
    """Top-level training-config keys; mappings (``eval``, ``hyperparams``, ...) merge."""
    cpus_per_trial: int = 1
    """CPUs Ray reserves for a trial; also its torch thread count."""
    max_concurrent: int = 0
    """Trials running at once; 0 leaves it to the free CPUs."""
    metric: str = "success_rate"
    """Metric (of the final evaluation, mean over seeds) that picks the best setting."""
    evaluation: SweepEvalConfig = field(default_factory=SweepEvalConfig)
    """Episodes of the evaluations reported to Tune (during training and at the end)."""
    storage: Path = Path("runs/sweeps")
    """Parent folder of the sweep's folder."""
    source: str = "<sweep>"
    """Where the sweep was read from (for messages); not a file key."""

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
        d = dataclasses.asdict(self)
        d.pop("source")
        d["base"], d["storage"] = str(self.base), str(self.storage)
        return d


# --------------------------------------------------------------------------- sweep file


def _err(source: str, where: str, problem: str) -> ConfigError:
    return ConfigError(f"{source}: {where}: {problem}")


def _check_type(
    source: str, where: str, value: Any, kind: type | tuple[type, ...], name: str
) -> None:
    if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
        hint = (
            " (write floats as 1.0e-4: YAML reads 1e-4 as a string)"
            if isinstance(value, str)
            else ""
        )
        raise _err(source, where, f"expected {name}, got {value!r}{hint}")


def load_sweep(path: str | os.PathLike[str], storage: Path | None = None) -> SweepConfig:
    """Read and validate a sweep file, down to every trial's training config.

    Raises:
        ConfigError: one line naming the file, the key and the fix.
    """
    source = str(path)
    p = Path(path)
    if not p.is_file():
        raise ConfigError(
            f"{source}: file not found; give the path of a sweep YAML (configs/sweeps/*.yaml)"
        )
    try:
        data = yaml.safe_load(p.read_text())
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        raise ConfigError(f"{source}: YAML syntax error{where}; fix the file") from None
    if not isinstance(data, dict):
        raise _err(source, "(top level)", f"expected a mapping, got {type(data).__name__}")
    allowed = [f.name for f in dataclasses.fields(SweepConfig) if f.name != "source"]
    unknown = sorted(set(data) - set(allowed))
    if unknown:
        raise _err(source, unknown[0], f"unknown key; allowed keys: {', '.join(allowed)}")
    for key in ("name", "base", "grid"):
        if key not in data:
            raise _err(source, key, "required key is missing")
    kw: dict[str, Any] = {"source": source}

    _check_type(source, "name", data["name"], str, "str")
    if not re.fullmatch(r"[A-Za-z0-9_.-]+", data["name"]) or data["name"] in (".", ".."):
        raise _err(
            source, "name", f"{data['name']!r} is not a folder name; use letters, digits, _ . -"
        )
    kw["name"] = data["name"]

    _check_type(source, "base", data["base"], str, "str (path of a training config)")
    base = Path(data["base"])
    kw["base"] = (base if base.is_absolute() else p.resolve().parent / base).resolve()
    if not kw["base"].is_file():
        raise _err(
            source,
            "base",
            f"{kw['base']} not found; the path is relative to the "
            "sweep file, e.g. ../agents/ppo_detumble.yaml",
        )

    for key in ("total_timesteps", "cpus_per_trial", "max_concurrent"):
        if data.get(key) is not None:
            _check_type(source, key, data[key], int, "int")
            low = 0 if key == "max_concurrent" else 1
            if data[key] < low:
                raise _err(source, key, f"must be >= {low}, got {data[key]}")
            kw[key] = data[key]

    if "metric" in data:
        if data["metric"] not in METRICS:
            raise _err(
                source, "metric", f"unknown {data['metric']!r}; choose one of {', '.join(METRICS)}"
            )
        kw["metric"] = data["metric"]

    if "evaluation" in data:
        ev = data["evaluation"]
        _check_type(source, "evaluation", ev, dict, "a mapping")
        names = [f.name for f in dataclasses.fields(SweepEvalConfig)]
        for k, v in ev.items():
            if k not in names:
                raise _err(
                    source, f"evaluation.{k}", f"unknown key; allowed keys: {', '.join(names)}"
                )
            _check_type(source, f"evaluation.{k}", v, int, "int")
        if ev.get("episodes", 1) < 1:
            raise _err(source, "evaluation.episodes", "must be >= 1")
        kw["evaluation"] = SweepEvalConfig(**ev)

    if "overrides" in data:
        _check_type(source, "overrides", data["overrides"], dict, "a mapping")
        for k in ("seed", "env_id", "total_timesteps"):
            if k in data["overrides"]:
                raise _err(
                    source,
                    f"overrides.{k}",
                    "set it with "
                    + (
                        "the top-level total_timesteps key"
                        if k == "total_timesteps"
                        else f"grid.{k}"
                    ),
                )
        kw["overrides"] = data["overrides"]

    if "storage" in data:
        _check_type(source, "storage", data["storage"], str, "str (a folder)")
        kw["storage"] = Path(data["storage"])
    if storage is not None:
        kw["storage"] = storage

    grid = data["grid"]
    _check_type(source, "grid", grid, dict, "a mapping of axis -> list of values")
    if not grid:
        raise _err(source, "grid", "empty; give at least one axis, e.g. seed: [0, 1, 2]")
    kw["grid"] = {}
    for axis, values in grid.items():
        where = f"grid.{axis}"
        if axis not in AXES and not (
            isinstance(axis, str)
            and axis.startswith(AXIS_PREFIXES)
            and axis.count(".") == 1
            and not axis.endswith(".")
        ):
            raise _err(
                source,
                where,
                "unknown axis; use seed, env_id, hyperparams.<name>, "
                "env_kwargs.<name> or policy_kwargs.<name>",
            )
        if not isinstance(values, list) or not values:
            raise _err(source, where, f"expected a non-empty list of values, got {values!r}")
        if axis == "seed":
            for v in values:
                _check_type(source, where, v, int, "a list of int seeds")
        if axis == "env_id":
            for v in values:
                _check_type(source, where, v, str, "a list of environment ids")
        reprs = [json.dumps(v, sort_keys=True, default=str) for v in values]
        if len(set(reprs)) != len(reprs):
            dup = next(v for v, r in zip(values, reprs, strict=True) if reprs.count(r) > 1)
            raise _err(source, where, f"value {dup!r} appears twice")
        kw["grid"][axis] = values

    sweep = SweepConfig(**kw)
    _validate_trials(sweep)
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
    data = load_config(sweep.base).to_dict()
    data = _merge(data, sweep.overrides)
    if sweep.total_timesteps is not None:
        data["total_timesteps"] = sweep.total_timesteps
    return data


def trial_data(base: dict[str, Any], point: dict[str, Any]) -> dict[str, Any]:
    """Training-config dict of one grid point (``{axis: value}``)."""
    nested: dict[str, Any] = {}
    for axis, value in point.items():
        if "." in axis:
            group, key = axis.split(".", 1)
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


def _validate_trials(sweep: SweepConfig) -> None:
    import gymnasium as gym

    import rigid_env  # noqa: F401

    try:
        base = base_data(sweep)
    except ConfigError as exc:
        msg = str(exc).replace("<config>: ", "")
        raise ConfigError(f"{sweep.source}: overrides: {msg}") from None
    made: set[str] = set()
    settings: dict[str, str] = {}
    for point in grid_points(sweep):
        label = setting_label(sweep.varying, point)
        key = json.dumps(
            {a: v for a, v in point.items() if a != "seed"}, sort_keys=True, default=str
        )
        if settings.setdefault(setting_folder(label), key) != key:
            raise ConfigError(
                f"{sweep.source}: grid: two settings share the folder name "
                f"{setting_folder(label)!r}; make their values differ more"
            )
        try:
            cfg = load_config(trial_data(base, point))
        except ConfigError as exc:
            where = ", ".join(f"grid.{a}={v!r}" for a, v in point.items() if a != "seed")
            msg = str(exc).replace("<config>: ", "")
            raise ConfigError(f"{sweep.source}: {where or 'base'}: {msg}") from None
        key = json.dumps([cfg.env_id, cfg.env_kwargs], sort_keys=True, default=str)
        if key in made:
            continue
        made.add(key)
        try:  # bad env_kwargs (an unknown integrator, a typo) fail here, not in a trial
            gym.make(cfg.env_id, **cfg.env_kwargs).close()
        except Exception as exc:
            first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise ConfigError(
                f"{sweep.source}: grid: {cfg.env_id} with env_kwargs {cfg.env_kwargs}: {first}"
            ) from None


# --------------------------------------------------------------------------- settings


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, (list, dict)):
        return json.dumps(value, separators=(",", ":"))
    return str(value)


def _short_names(axes: Sequence[str]) -> dict[str, str]:
    short = {a: a.split(".")[-1] for a in axes}
    if len(set(short.values())) < len(short):
        return {a: a for a in axes}
    return short


def setting_label(varying: Sequence[str], point: dict[str, Any]) -> str:
    """Human label of a setting, e.g. ``learning_rate=0.0003, integrator=rk4`` (``base``
    when only the seed varies)."""
    short = _short_names(varying)
    parts = []
    for a in varying:
        v = point[a]
        if a == "env_id":
            v = str(v).split("/")[-1]
        parts.append(f"{short[a]}={_fmt(v)}")
    return ", ".join(parts) or "base"


def setting_folder(label: str) -> str:
    """A folder name for a setting label."""
    return re.sub(r"[^A-Za-z0-9_.=+-]+", "_", label.replace(", ", ",")).strip("_") or "base"


def _flatten_point(params: dict[str, Any], axes: Sequence[str]) -> dict[str, Any]:
    """Tune's nested trial config back to ``{axis: value}``."""
    out = {}
    for a in axes:
        if "." in a:
            group, key = a.split(".", 1)
            out[a] = params[group][key]
        else:
            out[a] = params[a]
    return out


def _param_space(sweep: SweepConfig) -> dict[str, Any]:
    from ray import tune

    space: dict[str, Any] = {}
    for axis, values in sweep.grid.items():
        if "." in axis:
            group, key = axis.split(".", 1)
            space.setdefault(group, {})[key] = tune.grid_search(values)
        else:
            space[axis] = tune.grid_search(values)
    return space


# --------------------------------------------------------------------------- trials


def _clean(metrics: dict[str, Any]) -> dict[str, Any]:
    """Tune-friendly values (no ``None``)."""
    return {k: (math.nan if v is None else v) for k, v in metrics.items()}


def live_policy(model: Any) -> Callable[[np.ndarray], np.ndarray]:
    """The model's deterministic policy on raw observations, normalised as in training."""
    from stable_baselines3.common.vec_env import VecNormalize

    env = model.get_env()

    def policy(obs: np.ndarray) -> np.ndarray:
        if isinstance(env, VecNormalize) and env.norm_obs:
            obs = env.normalize_obs(obs)
        return model.predict(obs, deterministic=True)[0]

    return policy


def make_report_callback(
    cfg: TrainConfig,
    report: Callable[[dict[str, Any]], None],
    episodes: int,
    seed: int,
    extra: dict[str, Any] | None = None,
) -> Any:
    """An SB3 callback for :func:`agents.train.train`: right after each of its periodic
    evaluations (every ``eval.freq`` steps) it evaluates the current policy on ``episodes``
    episodes from ``seed`` with :func:`agents.evaluate.rollout` (all at once, in the native
    vector env) and passes the metrics, ``timesteps`` and ``extra`` to ``report``."""
    from stable_baselines3.common.callbacks import BaseCallback

    from .evaluate import rollout

    every = max(1, cfg.eval.freq // cfg.n_envs)  # EvalCallback's schedule

    class ReportEvaluation(BaseCallback):
        def _on_step(self) -> bool:
            if self.n_calls % every == 0:
                metrics = rollout(
                    cfg.env_id, live_policy(self.model), episodes, seed, cfg.env_kwargs
                )
                report(
                    _clean(
                        {
                            **metrics,
                            "timesteps": int(self.num_timesteps),
                            "final": False,
                            **(extra or {}),
                        }
                    )
                )
            return True

    return ReportEvaluation()


def run_trial(
    params: dict[str, Any],
    spec: dict[str, Any],
    report: Callable[[dict[str, Any]], None] | None = None,
) -> dict[str, Any]:
    """One trial: train (or resume, or skip when already trained), evaluate, report.

    Args:
        params: Tune's trial config (the grid point, nested like a training config).
        spec: ``base`` (training-config dict), ``axes``, ``varying``, ``sweep_dir``,
            ``evaluation`` (dict), ``threads``.
        report: where metrics go; ``ray.tune.report`` inside a Tune trial.

    Returns:
        The final metrics (also reported, with ``final: True``).
    """
    import torch

    from .evaluate import evaluate
    from .train import train

    if report is None:
        from ray import tune  # Ray >= 2.41: tune.report (ray.train.report is Ray Train's)

        report = tune.report
    torch.set_num_threads(int(spec["threads"]))
    point = _flatten_point(params, spec["axes"])
    cfg = load_config(trial_data(spec["base"], point))
    label = setting_label(spec["varying"], point)
    runs_dir = Path(spec["sweep_dir"]) / "runs" / setting_folder(label)
    run_dir = runs_dir / cfg.run_name
    extra = {"setting": label, "seed": cfg.seed, "run_dir": str(run_dir)}
    ev = spec["evaluation"]
    meta = run_dir / "model.json"
    trained = (
        meta.exists()
        and json.loads(meta.read_text()).get("num_timesteps", 0) >= cfg.total_timesteps
    )
    if not trained:
        resume = any((run_dir / "checkpoints").glob("model_*_steps.zip"))
        if not resume and run_dir.exists():
            shutil.rmtree(run_dir)  # stopped before its first checkpoint: start again
        train(
            cfg,
            runs_dir,
            resume=resume,
            progress=False,
            verbose=0,
            callbacks=[make_report_callback(cfg, report, ev["episodes"], ev["seed"], extra)],
        )
    metrics = evaluate(
        run_dir / "model.zip",
        cfg.env_id,
        ev["episodes"],
        ev["seed"],
        only=["model"],
        env_kwargs=cfg.env_kwargs,
    )["model"]
    num_timesteps = json.loads(meta.read_text())["num_timesteps"]
    final = _clean({**metrics, "timesteps": num_timesteps, "final": True, **extra})
    (run_dir / "final_eval.json").write_text(
        json.dumps({**metrics, "timesteps": num_timesteps, "episodes_seed": ev["seed"]}, indent=2)
    )
    report(final)
    return final


def _trainable(params: dict[str, Any], spec: dict[str, Any]) -> None:
    run_trial(params, spec)


# --------------------------------------------------------------------------- Ray


def _probe(address: str, timeout: float) -> None:
    """Fail fast when nothing listens at ``address`` (Ray's own client retries for ~1 min)."""
    m = re.fullmatch(r"(?:ray://)?\[?([^\]]+?)\]?:(\d+)", address)
    if m is None:
        raise SweepError(
            f"--address {address!r}: expected ray://HOST:PORT (Ray Client, "
            "port 10001 by default), HOST:PORT of a head node, or auto"
        )
    host, port = m.group(1), int(m.group(2))
    try:
        socket.create_connection((host, port), timeout=timeout).close()
    except OSError as exc:
        why = "timed out" if isinstance(exc, TimeoutError) else (exc.strerror or str(exc))
        raise SweepError(
            f"--address {address}: cannot reach {host}:{port} within "
            f"{timeout:g} s ({why}); check the head node's address and port, or "
            "start one with `ray start --head --ray-client-server-port 10001`"
        ) from None


def connect(
    address: str | None, num_cpus: int | None, verbose: bool, timeout: float = 5.0
) -> tuple[str, bool]:
    """Start a local Ray instance (``address`` None or ``local``) or join a cluster; in a
    program that has already called ``ray.init`` (and gives no address), use that.

    Returns:
        A description of where trials run, and whether the caller should shut Ray down.

    Raises:
        SweepError: the cluster cannot be reached (within ``timeout`` seconds).
    """
    import ray

    quiet = {"log_to_driver": verbose, "logging_level": logging.INFO if verbose else logging.ERROR}
    cpus = lambda: int(ray.cluster_resources().get("CPU", 0))  # noqa: E731
    if address in (None, "", "local"):
        if ray.is_initialized():
            return f"the running Ray instance ({cpus()} CPUs)", False
        n = num_cpus or os.cpu_count() or 1
        ray.init(address="local", num_cpus=n, include_dashboard=False, **quiet)
        return f"a local Ray instance ({n} CPUs)", True
    if address != "auto":
        _probe(address, timeout)
    runtime_env = {}
    checkout = Path(__file__).resolve().parents[1]
    if (checkout / "pyproject.toml").exists() and (checkout / "configs").is_dir():
        # Ship this checkout (code and configs/scenes; .gitignore'd paths stay here) as the
        # trials' working directory; the cluster's Python needs the dependencies.
        runtime_env = {"working_dir": str(checkout), "excludes": [".git", ".venv", "runs"]}
    try:
        with warnings.catch_warnings():  # Ray Client warns before it raises
            warnings.simplefilter("ignore")
            ray.init(address=address, runtime_env=runtime_env, **quiet)
    except Exception as exc:
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise SweepError(
            f"--address {address}: cannot connect ({first}); check the address, "
            "that the cluster runs the same Ray and Python versions, and, if it "
            "uses token authentication, RAY_AUTH_MODE=token and its token here"
        ) from None
    return f"the Ray cluster at {address} ({cpus()} CPUs)", True


# --------------------------------------------------------------------------- sweep


@dataclass
class TrialRow:
    """One finished trial's final evaluation."""

    setting: str
    seed: int
    metrics: dict[str, Any]
    run_dir: str
    curve: list[tuple[int, float, float]]
    """``(timesteps, success_rate, mean_return)`` of every report, final included."""


def _spec(sweep: SweepConfig, sweep_dir: Path) -> dict[str, Any]:
    axes = list(sweep.grid)
    return {
        "base": base_data(sweep),
        "axes": axes,
        "varying": sweep.varying,
        "sweep_dir": str(sweep_dir),
        "evaluation": dataclasses.asdict(sweep.evaluation),
        "threads": sweep.cpus_per_trial,
    }


def run_sweep(
    sweep: SweepConfig,
    *,
    address: str | None = None,
    resume: bool = False,
    num_cpus: int | None = None,
    verbose: bool = False,
    connect_timeout: float = 5.0,
    tune_callbacks: Sequence[Any] = (),
    log: Callable[[str], None] = print,
) -> list[TrialRow]:
    """Run (or resume) the sweep's trials with Ray Tune; returns the finished trials.

    Args:
        tune_callbacks: extra ``ray.tune.Callback`` objects (stored with the experiment).

    Raises:
        SweepError: no cluster at ``address``; nothing to resume; a sweep already there.
    """
    sweep_dir = sweep.directory.resolve()
    exp_dir = sweep_dir / _TUNE_DIR
    saved = sweep_dir / "sweep.yaml"
    resolved = yaml.safe_dump(sweep.to_dict(), sort_keys=False)
    if resume:
        if not (exp_dir / "tuner.pkl").exists():
            raise SweepError(f"{sweep_dir}: no sweep to resume; start it without --resume")
        if saved.exists() and saved.read_text() != resolved:
            raise SweepError(
                f"{sweep.source}: changed since the sweep in {sweep_dir} started; "
                f"resume with the same file (a copy is in {saved}) or use a new name"
            )
    elif exp_dir.exists():
        raise SweepError(
            f"{sweep_dir}: a sweep already exists; pass --resume to continue it, "
            "or choose another name or --storage"
        )
    if address is None and os.environ.get("RAY_ADDRESS"):
        address = os.environ["RAY_ADDRESS"]
    local_cpus = num_cpus or os.cpu_count() or 1
    if address in (None, "", "local") and sweep.cpus_per_trial > local_cpus:
        raise ConfigError(
            f"{sweep.source}: cpus_per_trial: {sweep.cpus_per_trial} is more than "
            f"the {local_cpus} CPUs here; lower it or use --address"
        )

    if not verbose:  # Tune's legacy reporter at verbose=0 prints nothing
        os.environ.setdefault("RAY_AIR_NEW_OUTPUT", "0")
    import ray
    from ray import tune

    where, owned = connect(address, num_cpus, verbose, connect_timeout)
    n_trials = len(grid_points(sweep))
    log(
        f"{'resuming' if resume else 'running'} sweep {sweep.name}: {n_trials} trials on "
        f"{where}, {sweep.cpus_per_trial} CPU(s) each"
        + (f", at most {sweep.max_concurrent} at once" if sweep.max_concurrent else "")
    )
    try:
        sweep_dir.mkdir(parents=True, exist_ok=True)
        saved.write_text(resolved)
        trainable = tune.with_resources(
            tune.with_parameters(_trainable, spec=_spec(sweep, sweep_dir)),
            {"cpu": sweep.cpus_per_trial},
        )
        if resume:
            tuner = tune.Tuner.restore(
                str(exp_dir), trainable, resume_unfinished=True, restart_errored=True
            )
        else:
            tuner = tune.Tuner(
                trainable,
                param_space=_param_space(sweep),
                tune_config=tune.TuneConfig(
                    max_concurrent_trials=sweep.max_concurrent or None,
                    trial_dirname_creator=_trial_dirname,
                ),
                run_config=tune.RunConfig(
                    name=_TUNE_DIR,
                    storage_path=str(sweep_dir),
                    verbose=1 if verbose else 0,
                    callbacks=list(tune_callbacks),
                ),
            )
        results = tuner.fit()
    finally:
        if owned:
            ray.shutdown()
    rows = []
    for r in results:
        m = r.metrics or {}
        if r.error is not None and r.config:
            point = _flatten_point(r.config, list(sweep.grid))
            first = (str(r.error).strip().splitlines() or ["error"])[-1]
            log(
                f"trial {setting_label(sweep.varying, point)}, seed {point.get('seed', '-')} "
                f"failed: {first} (log: {r.path})"
            )
        if r.error is not None or not m.get("final"):
            continue
        rows.append(
            TrialRow(
                setting=m["setting"],
                seed=int(m["seed"]),
                run_dir=m["run_dir"],
                metrics={
                    k: m.get(k)
                    for k in (
                        *METRICS,
                        "episodes",
                        "mean_time_to_success",
                        "numerical_errors",
                        "timesteps",
                    )
                },
                curve=_curve(r),
            )
        )
    order = {setting_label(sweep.varying, p): i for i, p in enumerate(grid_points(sweep))}
    rows.sort(key=lambda r: (order.get(r.setting, len(order)), r.seed))
    return rows


def _trial_dirname(trial: Any) -> str:
    return f"trial_{trial.trial_id}"


def _curve(result: Any) -> list[tuple[int, float, float]]:
    df = result.metrics_dataframe
    if df is None or "timesteps" not in df:
        return []
    return [
        (int(t), float(s), float(r))
        for t, s, r in zip(df["timesteps"], df["success_rate"], df["mean_return"], strict=True)
    ]


# --------------------------------------------------------------------------- summary


@dataclass
class SettingSummary:
    """Final metrics of one setting over its seeds."""

    setting: str
    seeds: list[int]
    values: dict[str, list[float]]

    def mean(self, metric: str) -> float:
        """Mean over seeds."""
        return float(np.mean(self.values[metric]))

    def std(self, metric: str) -> float:
        """Sample standard deviation over seeds (0 for one seed)."""
        v = self.values[metric]
        return float(np.std(v, ddof=1)) if len(v) > 1 else 0.0


def summarise(rows: Sequence[TrialRow]) -> list[SettingSummary]:
    """Group finished trials by setting, in the order they come."""
    groups: dict[str, SettingSummary] = {}
    for r in rows:
        s = groups.setdefault(r.setting, SettingSummary(r.setting, [], {m: [] for m in METRICS}))
        s.seeds.append(r.seed)
        for m in METRICS:
            s.values[m].append(float(r.metrics[m]))
    return list(groups.values())


def best_setting(summary: Sequence[SettingSummary], metric: str) -> SettingSummary:
    """The setting with the best mean ``metric`` (ties: the first)."""
    sign = 1.0 if METRICS[metric] == "max" else -1.0
    return max(summary, key=lambda s: sign * s.mean(metric))


def markdown_summary(sweep: SweepConfig, rows: Sequence[TrialRow]) -> str:
    """Per-setting table (mean +- sample std and min..max over seeds), best setting, and
    per-trial table."""
    summary = summarise(rows)
    ev = sweep.evaluation
    lines = [
        f"Sweep `{sweep.name}`: final models on {ev.episodes} fixed episodes (seeds "
        f"{ev.seed}..{ev.seed + ev.episodes - 1}); mean ± std (min..max) over training "
        "seeds.",
        "",
        "| setting | seeds | success rate | return | final \\|w\\| [rad/s] | fuel [N s] |",
        "|---|---|---|---|---|---|",
    ]
    for s in summary:

        def cell(m: str, f: str, s: SettingSummary = s) -> str:
            v = s.values[m]
            return f"{s.mean(m):{f}} ± {s.std(m):{f}} ({min(v):{f}}..{max(v):{f}})"

        lines.append(
            f"| {s.setting} | {len(s.seeds)} | {cell('success_rate', '.2f')} | "
            f"{cell('mean_return', '.1f')} | "
            f"{s.mean('mean_final_angular_speed'):.3f} | {s.mean('mean_fuel'):.2f} |"
        )
    if summary:
        b = best_setting(summary, sweep.metric)
        lines += [
            "",
            f"Best setting by mean {sweep.metric} ({sweep.mode}): **{b.setting}** "
            f"({b.mean(sweep.metric):.3f} ± {b.std(sweep.metric):.3f} over "
            f"{len(b.seeds)} seeds).",
        ]
    lines += [
        "",
        "| setting | seed | timesteps | success rate | return | final \\|w\\| | fuel |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        m = r.metrics
        lines.append(
            f"| {r.setting} | {r.seed} | {m['timesteps']} | {m['success_rate']:.2f} | "
            f"{m['mean_return']:.1f} | {m['mean_final_angular_speed']:.3f} | "
            f"{m['mean_fuel']:.2f} |"
        )
    return "\n".join(lines) + "\n"


def csv_rows(rows: Sequence[TrialRow]) -> str:
    """One CSV line per finished trial."""
    buf = io.StringIO()
    keys = ["setting", "seed", "timesteps", *METRICS, "mean_time_to_success", "run_dir"]
    w = csv.writer(buf)
    w.writerow(keys)
    for r in rows:
        w.writerow([r.setting, r.seed, *(r.metrics.get(k) for k in keys[2:-1]), r.run_dir])
    return buf.getvalue()


def plot_summary(sweep: SweepConfig, rows: Sequence[TrialRow], path: Path) -> bool:
    """Figure: final success rate and return per setting (seeds as dots, mean +- std), and
    the success rate during training (mean and min..max over seeds). False without
    matplotlib."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    summary = summarise(rows)
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2), constrained_layout=True)
    x = np.arange(len(summary))
    for ax, metric, title in (
        (axes[0], "success_rate", "final success rate"),
        (axes[1], "mean_return", "final mean return"),
    ):
        for i, s in enumerate(summary):
            v = s.values[metric]
            jitter = np.linspace(-0.12, 0.12, len(v)) if len(v) > 1 else np.zeros(1)
            ax.scatter(i + jitter, v, s=18, color="tab:blue", alpha=0.6, zorder=3)
            ax.errorbar(
                i + 0.25,
                s.mean(metric),
                yerr=s.std(metric),
                fmt="o",
                color="black",
                capsize=4,
                zorder=4,
            )
        ax.set_xticks(
            x,
            [s.setting for s in summary],
            rotation=20 if len(summary) > 3 else 0,
            ha="right" if len(summary) > 3 else "center",
        )
        ax.set_xlim(-0.6, len(summary) - 0.4)
        ax.set_title(f"{title}\n(dots: seeds; black: mean ± std)", fontsize=10)
        ax.grid(alpha=0.3)
    axes[0].set_ylim(-0.05, 1.05)
    ax = axes[2]
    for k, s in enumerate(summary):
        curves = [r.curve for r in rows if r.setting == s.setting and r.curve]
        steps = sorted({t for c in curves for t, _, _ in c})
        if not steps:
            continue
        table = np.full((len(curves), len(steps)), np.nan)
        for i, c in enumerate(curves):
            for t, succ, _ in c:
                table[i, steps.index(t)] = succ
        color = f"C{k % 10}"
        for row in table:
            ax.plot(steps, row, color=color, alpha=0.25, linewidth=0.8)
        ax.plot(
            steps, np.nanmean(table, axis=0), color=color, label=s.setting, marker=".", linewidth=2
        )
    ax.set_xlabel("environment steps")
    ax.set_ylabel("success rate")
    ax.set_ylim(-0.05, 1.05)
    ax.set_title("success rate during training\n(thin: seeds; thick: mean)", fontsize=10)
    ax.grid(alpha=0.3)
    if len(summary) > 1:
        ax.legend(fontsize=8)
    ev = sweep.evaluation
    fig.suptitle(
        f"sweep {sweep.name}: {len(rows)} trials of "
        f"{rows[0].metrics['timesteps'] if rows else 0} steps; each point evaluates "
        f"the policy on {ev.episodes} fixed episodes",
        fontsize=11,
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return True


def write_summary(sweep: SweepConfig, rows: Sequence[TrialRow]) -> dict[str, Path]:
    """``summary.md``, ``summary.csv``, ``summary.png`` and ``best_config.yaml`` in the
    sweep's folder; returns their paths."""
    out = sweep.directory
    out.mkdir(parents=True, exist_ok=True)
    paths = {"table": out / "summary.md", "csv": out / "summary.csv"}
    paths["table"].write_text(markdown_summary(sweep, rows))
    paths["csv"].write_text(csv_rows(rows))
    if plot_summary(sweep, rows, out / "summary.png"):
        paths["figure"] = out / "summary.png"
    summary = summarise(rows)
    if summary:
        best = best_setting(summary, sweep.metric)
        point = next(
            p for p in grid_points(sweep) if setting_label(sweep.varying, p) == best.setting
        )
        point.pop("seed", None)
        cfg = load_config(trial_data(base_data(sweep), point))
        paths["best"] = out / "best_config.yaml"
        paths["best"].write_text(
            f"# Best setting of sweep {sweep.name} ({best.setting}) by mean {sweep.metric} "
            f"over seeds {best.seeds}.\n# Train it: python -m agents.train {paths['best']}\n"
            + yaml.safe_dump(cfg.to_dict(), sort_keys=False)
        )
    return paths


# --------------------------------------------------------------------------- CLI


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    parser = argparse.ArgumentParser(
        prog="python -m agents.sweep", description=__doc__.split("\n")[0]
    )
    parser.add_argument("sweep", help="sweep YAML (configs/sweeps/*.yaml)")
    parser.add_argument(
        "--address",
        help="Ray cluster to run on: ray://HOST:10001 (Ray "
        "Client), HOST:PORT or auto; default $RAY_ADDRESS, else a local "
        "Ray instance started here",
    )
    parser.add_argument(
        "--resume",
        action="store_true",
        help="continue an interrupted sweep; finished trials are kept",
    )
    parser.add_argument("--storage", type=Path, help="override the sweep file's storage folder")
    parser.add_argument(
        "--num-cpus", type=int, help="CPUs of the local Ray instance (default: all)"
    )
    parser.add_argument(
        "--connect-timeout",
        type=float,
        default=5.0,
        help="seconds to wait for --address (default 5)",
    )
    parser.add_argument("--verbose", action="store_true", help="Ray's and Tune's own output")
    args = parser.parse_args(argv)
    prog = "agents.sweep"
    try:
        sweep = load_sweep(args.sweep, storage=args.storage)
        try:
            import ray  # noqa: F401
            from ray import tune  # noqa: F401
        except ImportError:
            raise SweepError("Ray Tune is not installed; pip install -e '.[sweep]'") from None
        rows = run_sweep(
            sweep,
            address=args.address,
            resume=args.resume,
            num_cpus=args.num_cpus,
            verbose=args.verbose,
            connect_timeout=args.connect_timeout,
        )
    except (ConfigError, SweepError) as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{prog}: interrupted; continue with --resume", file=sys.stderr)
        return 128 + signal.SIGINT
    expected = len(grid_points(sweep))
    if rows:
        paths = write_summary(sweep, rows)
        print(paths["table"].read_text())
        for name, p in paths.items():
            print(f"{name}: {p}")
    if len(rows) < expected:
        print(
            f"{prog}: {expected - len(rows)} of {expected} trials unfinished; continue with "
            "--resume (failed trials start again)",
            file=sys.stderr,
        )
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
