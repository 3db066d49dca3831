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

What is ours and what is Tune's. Ours: the sweep file (:mod:`agents.sweep_config`, a pydantic
model that builds every trial's training config before anything runs), the run folders, and
the summary (:mod:`agents.sweep_report`). Tune's: the trials' state, scheduling and
``--resume`` (``Tuner.restore``), and the results each trial reported.

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
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ._cli import OneLineParser, folder_problem, path, positive_integer, positive_number
from .config import ConfigError, TrainConfig, load_config
from .sweep_config import (
    METRICS,
    SweepConfig,
    base_data,
    grid_points,
    load_sweep,
    setting_folder,
    setting_label,
    trial_data,
)
from .sweep_report import TrialRow, write_summary

__all__ = [
    "SweepError",
    "grid_points",
    "load_sweep",
    "main",
    "run_sweep",
    "run_trial",
    "setting_label",
]

_TUNE_DIR = "tune"


class SweepError(RuntimeError):
    """The sweep cannot run (no cluster at the address, nothing to resume); one line."""


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


def _spec(sweep: SweepConfig, sweep_dir: Path) -> dict[str, Any]:
    """What every trial needs besides its grid point (passed to Tune once)."""
    return {
        "base": base_data(sweep),
        "axes": list(sweep.grid),
        "varying": sweep.varying,
        "sweep_dir": str(sweep_dir),
        "evaluation": sweep.evaluation.model_dump(),
        "threads": sweep.cpus_per_trial,
    }


def _param_space(sweep: SweepConfig) -> dict[str, Any]:
    """The grid as Tune's ``grid_search`` axes, nested like a training config."""
    from ray import tune

    space: dict[str, Any] = {}
    for axis, values in sweep.grid.items():
        group, dot, key = axis.partition(".")
        if dot:
            space.setdefault(group, {})[key] = tune.grid_search(values)
        else:
            space[axis] = tune.grid_search(values)
    return space


def _flatten_point(params: dict[str, Any], axes: Sequence[str]) -> dict[str, Any]:
    """Tune's nested trial config back to ``{axis: value}``."""
    out = {}
    for a in axes:
        group, dot, key = a.partition(".")
        out[a] = params[group][key] if dot else params[a]
    return out


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
    if not verbose:  # Tune's legacy reporter at verbose=0 prints nothing
        os.environ.setdefault("RAY_AIR_NEW_OUTPUT", "0")
    import ray
    from ray import tune

    sweep_dir = sweep.directory.resolve()
    exp_dir = sweep_dir / _TUNE_DIR
    saved = sweep_dir / "sweep.yaml"
    resolved = yaml.safe_dump(sweep.to_dict(), sort_keys=False)
    if resume and not tune.Tuner.can_restore(str(exp_dir)):
        raise SweepError(f"{sweep_dir}: no sweep to resume; start it without --resume")
    if resume and saved.exists() and saved.read_text() != resolved:
        raise SweepError(
            f"{sweep.source}: changed since the sweep in {sweep_dir} started; "
            f"resume with the same file (a copy is in {saved}) or use a new name"
        )
    if not resume and exp_dir.exists():
        raise SweepError(
            f"{sweep_dir}: a sweep already exists; pass --resume to continue it, "
            "or choose another name or --storage"
        )
    address = address or os.environ.get("RAY_ADDRESS") or None
    local_cpus = num_cpus or os.cpu_count() or 1
    if address in (None, "local") and sweep.cpus_per_trial > local_cpus:
        raise ConfigError(
            f"{sweep.source}: cpus_per_trial: {sweep.cpus_per_trial} is more than "
            f"the {local_cpus} CPUs here; lower it or use --address"
        )

    where, owned = connect(address, num_cpus, verbose, connect_timeout)
    log(
        f"{'resuming' if resume else 'running'} sweep {sweep.name}: {len(grid_points(sweep))} "
        f"trials on {where}, {sweep.cpus_per_trial} CPU(s) each"
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
    return _finished(sweep, results, log)


def _trial_dirname(trial: Any) -> str:
    return f"trial_{trial.trial_id}"


def _finished(sweep: SweepConfig, results: Any, log: Callable[[str], None]) -> list[TrialRow]:
    """The trials of Tune's results that reported their final evaluation, in grid order
    (failed ones are logged with the folder of their error)."""
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
        keys = (*METRICS, "episodes", "mean_time_to_success", "numerical_errors", "timesteps")
        df = r.metrics_dataframe
        curve = []
        if df is not None and "timesteps" in df:
            curve = [
                (int(t), float(s), float(ret))
                for t, s, ret in zip(
                    df["timesteps"], df["success_rate"], df["mean_return"], strict=True
                )
            ]
        rows.append(
            TrialRow(
                setting=m["setting"],
                seed=int(m["seed"]),
                run_dir=m["run_dir"],
                metrics={k: m.get(k) for k in keys},
                curve=curve,
            )
        )
    order = {setting_label(sweep.varying, p): i for i, p in enumerate(grid_points(sweep))}
    rows.sort(key=lambda r: (order.get(r.setting, len(order)), r.seed))
    return rows


# --------------------------------------------------------------------------- CLI


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    parser = OneLineParser(prog="python -m agents.sweep", description=__doc__.split("\n")[0])
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
    parser.add_argument("--storage", type=path, help="override the sweep file's storage folder")
    parser.add_argument(
        "--num-cpus", type=positive_integer, help="CPUs of the local Ray instance (default: all)"
    )
    parser.add_argument(
        "--connect-timeout",
        type=positive_number,
        default=5.0,
        help="seconds to wait for --address (default 5)",
    )
    parser.add_argument("--verbose", action="store_true", help="Ray's and Tune's own output")
    args = parser.parse_args(argv)
    prog = "agents.sweep"
    try:
        sweep = load_sweep(args.sweep, storage=args.storage)
        local = (args.address or os.environ.get("RAY_ADDRESS") or "local") == "local"
        problem = folder_problem(sweep.directory) if local else None  # else: the nodes' disks
        if problem is not None:
            raise SweepError(
                f"{sweep.directory}: storage: {problem}; give a folder every node can write "
                "(--storage or the sweep file's storage)"
            )
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
