"""Train an SB3 agent on a RigidEnv task from a YAML config.

    python -m agents.train configs/agents/ppo_detumble.yaml [--seed S] [--total-timesteps N]
                           [--n-envs K] [--runs-dir runs] [--resume | --resume-or-start]
                           [--no-progress]

A run goes to ``runs/<task>__<algo>__<seed>/``: ``config.yaml`` (the full resolved config, as
it runs), ``tb/`` (TensorBoard), ``checkpoints/`` (model, ``VecNormalize`` statistics and replay
buffer every ``checkpoint_freq`` steps), ``eval/`` (evaluation history ``evaluations.npz`` and
the best model) and the final ``model.zip`` + ``vecnormalize.pkl`` (+ ``replay_buffer.pkl``).
Every model comes with a JSON sidecar naming its statistics, its environment and the resolved
config it was trained with, for ``agents.evaluate`` and ``--resume``; each set of files is
written whole or not at all (see :mod:`agents.callbacks`).

A run uses ``threads`` CPU threads (default 1: two seeds train at once on two cores). Every
``eval.freq`` steps it evaluates the policy on the same held-out episodes against the bar
(:mod:`agents.bar`), and prints a line with env-steps/s, that evaluation and an ETA
(:mod:`agents.progress`; TensorBoard gets the same numbers).

A config with ``learner: rsl_rl`` trains with rsl-rl's PPO over all its envs at once
(:mod:`agents.parallel`, the ``[learner]`` extra) in the same run folder, with the same files,
evaluations and resume rules; its models are SB3 ``PPO`` zips like the others.

``--resume`` continues from the newest complete checkpoint (or the final model) with its step
count, statistics and replay buffer; one that lacks a file its sidecar names (or statistics the
config needs) or does not load is skipped with a warning, and with none left the resume is
refused. The evaluation history and the best model are kept. A finished run is left alone
unless ``--total-timesteps`` asks for more. A config that differs from the one the run was
trained with (its newest sidecar's; ``config.yaml`` for older runs) in anything but
``total_timesteps``, ``device`` and ``threads`` is refused. ``--resume`` of a run that does not
exist is refused; ``--resume-or-start`` starts it.
"""

from __future__ import annotations

import errno
import json
import re
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from rigid_env.config_files import load_model, read_yaml

from ._cli import OneLineParser, folder_problem, integer, path
from .bar import BarEvaluation, evaluation_env_kwargs
from .callbacks import (
    CheckpointSnapshots,
    DurableEvaluation,
    finish_snapshots,
    save_snapshot,
    warn,
    write_atomic,
    zip_timesteps,
)
from .config import ConfigError, TrainConfig, algorithm_class, load_config
from .meaning import stamp
from .progress import TrainingProgress

#: Keys a resumed run may change: the budget and where it runs (all recorded as they run).
RESUMABLE_CHANGES = ("total_timesteps", "device", "threads")


def limit_threads(threads: int) -> None:
    """Run torch (its intra-op pool) and Numba on ``threads`` threads. Torch's default is one
    per core: two runs at once on two cores then share both cores between four threads, which
    took 309 s for two 100k-step Detumble runs against 25 s at one thread each (issue 24)."""
    import numba
    import torch

    torch.set_num_threads(threads)
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))


def training_env_kwargs(cfg: TrainConfig) -> dict[str, Any]:
    """The env kwargs of the training envs: the config's, with ``train_max_episode_steps``
    (where given) as their time limit over any ``max_episode_steps`` of ``env_kwargs``, which
    then limits the evaluation episodes alone."""
    kwargs = dict(cfg.env_kwargs)
    if cfg.train_max_episode_steps is not None:
        kwargs["max_episode_steps"] = cfg.train_max_episode_steps
    return kwargs


def training_episode_steps(cfg: TrainConfig) -> int:
    """The time limit of a training episode: :func:`training_env_kwargs`' or the id's."""
    import gymnasium as gym

    limit = training_env_kwargs(cfg).get("max_episode_steps")
    return int(limit if limit is not None else gym.spec(cfg.env_id).max_episode_steps)


def make_vec_env(
    cfg: TrainConfig, n_envs: int, seed: int, training: bool = True, norm_stats: Path | None = None
) -> Any:
    """The native SB3 adapter with ``VecMonitor`` and (optionally) ``VecNormalize``."""
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from .vec_adapter import RigidBodySB3VecEnv

    # Infos at episode ends only: SB3 reads no other (a third of the adapter's time per step).
    venv = RigidBodySB3VecEnv(
        cfg.env_id, num_envs=n_envs, step_infos=False, **training_env_kwargs(cfg)
    )
    venv.seed(seed)
    venv = VecMonitor(venv)
    if cfg.normalize.obs or cfg.normalize.reward:
        if norm_stats is not None:
            venv = VecNormalize.load(str(norm_stats), venv)
        else:
            venv = VecNormalize(
                venv,
                norm_obs=cfg.normalize.obs,
                norm_reward=cfg.normalize.reward,
                clip_obs=cfg.normalize.clip_obs,
                gamma=cfg.gamma,
            )
        venv.training = training
        if not training:
            venv.norm_reward = False
    return venv


def _policy_kwargs(cfg: TrainConfig) -> dict[str, Any]:
    import torch

    kw = cfg.policy_kwargs.model_dump(exclude_none=True)
    if "activation_fn" in kw:
        kw["activation_fn"] = {"tanh": torch.nn.Tanh, "relu": torch.nn.ReLU}[kw["activation_fn"]]
    return kw


@dataclass(frozen=True)
class Snapshot:
    """A saved model and its companions (absent ones ``None``); ``missing`` says why it cannot
    be resumed from (a companion file it needs is not there), else ``None``."""

    steps: int
    model: Path
    norm: Path | None
    buffer: Path | None
    config: dict[str, Any] | None = None
    missing: str | None = None


def _from_sidecar(model: Path, steps: int, norm_required: bool) -> Snapshot | None:
    """The snapshot a model's committed JSON sidecar describes, ``None`` without one.

    The files the sidecar names must all be there, and so must statistics when the config
    normalises: a model resumed without its ``VecNormalize`` statistics would go on with fresh
    ones, i.e. from something other than what was saved."""
    side = _read_json(model.with_suffix(".json"))
    if side is None or "staged" in side:
        return None
    recorded = side.get("num_timesteps")
    if not _is_count(recorded):
        return Snapshot(steps, model, None, None, None, f"{model.with_suffix('.json').name}: "
                        f"num_timesteps is {recorded!r}, not a step count")  # fmt: skip
    inside = zip_timesteps(model)
    if inside != recorded:
        problem = (
            f"{model.name} does not load (not a readable model zip)"
            if inside is None
            else f"{model.name} holds {inside} steps, its sidecar says {recorded}"
        )
        return Snapshot(steps, model, None, None, None, problem)
    steps = int(recorded)
    named = {k: side.get(k) for k in ("vecnormalize", "replay_buffer")}
    files = {k: model.parent / v if isinstance(v, str) else None for k, v in named.items()}
    gone = [f.name for f in files.values() if f is not None and not f.exists()]
    if norm_required and files["vecnormalize"] is None:
        gone.append("its VecNormalize statistics (the sidecar names none)")
    config = side.get("config") if isinstance(side.get("config"), dict) else None
    missing = f"{model.name} lacks {', '.join(gone)}" if gone else None
    return Snapshot(steps, model, files["vecnormalize"], files["replay_buffer"], config, missing)


def _checkpoints(ckpt_dir: Path, norm_required: bool) -> list[Snapshot]:
    """The checkpoints in ``ckpt_dir``, newest first (incomplete ones with ``missing`` set).

    One written with its JSON sidecar (:mod:`agents.callbacks`) is complete when the files the
    sidecar names are there (the sidecar is written last). One written by SB3's
    ``CheckpointCallback`` (model, then replay buffer, then statistics, no sidecar) counts only
    when it has every kind of companion file that any checkpoint of the run has, and its
    statistics when the config normalises."""
    kinds = {k for k in ("vecnormalize", "replay_buffer") if any(ckpt_dir.glob(f"model_{k}_*.pkl"))}
    if norm_required:
        kinds.add("vecnormalize")
    found: list[Snapshot] = []
    for p in ckpt_dir.glob("model_*_steps.zip"):
        m = re.fullmatch(r"model_(\d+)_steps\.zip", p.name)
        if m is None:
            continue
        n = int(m.group(1))
        snap = _from_sidecar(p, n, norm_required)
        if snap is None and zip_timesteps(p) not in (None, n):
            continue  # renamed: its steps are not what its name says (unreadable: never loads)
        if snap is None:
            side = {
                k: ckpt_dir / f"model_{k}_{n}_steps.pkl" for k in ("vecnormalize", "replay_buffer")
            }
            if not all(side[k].exists() for k in kinds):
                continue  # SB3 was killed between its files: never complete
            there = {k: v if v.exists() else None for k, v in side.items()}
            snap = Snapshot(n, p, there["vecnormalize"], there["replay_buffer"])
        found.append(snap)
    return sorted(found, key=lambda s: s.steps, reverse=True)


def _snapshots(run_dir: Path, norm_required: bool) -> list[Snapshot]:
    """The run's snapshots, newest first: checkpoints and the final model (first of equal
    steps: it is the same state); incomplete ones have ``missing`` set."""
    found = _checkpoints(run_dir / "checkpoints", norm_required)
    steps = _final_steps(run_dir)
    if steps is not None:
        snap = _from_sidecar(run_dir / "model.zip", steps, norm_required)
        if snap is not None:
            found.append(snap)
    return sorted(found, key=lambda s: (s.steps, s.model.name == "model.zip"), reverse=True)


def _is_count(value: Any) -> bool:
    """Whether a sidecar's ``num_timesteps`` is a step count (an int >= 0, not a bool)."""
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


def _final_steps(run_dir: Path) -> int | None:
    """The steps of the run's final model as its sidecar ``model.json`` records them, checked
    against ``model.zip`` (None: no final model).

    Raises:
        ConfigError: a final model without its sidecar, a sidecar without its model, or the
            two disagreeing (resume would otherwise put a checkpoint in its place, or call the
            run finished).
    """
    model, sidecar = run_dir / "model.zip", run_dir / "model.json"
    side = _read_json(sidecar)
    if side is None and not model.exists():
        if sidecar.exists():
            raise ConfigError(str(sidecar), "", "is not a JSON mapping",
                              "restore it from the run, or remove it to resume from the "
                              "checkpoints")  # fmt: skip
        return None
    if side is None:
        raise ConfigError(
            str(model), "", "the final model has no readable sidecar model.json (it is never "
            "replaced by a checkpoint)", "restore model.json, or move model.zip out of the run "
            "to resume from its checkpoints",
        )  # fmt: skip
    steps = side.get("num_timesteps")
    if not _is_count(steps):
        raise ConfigError(str(sidecar), "num_timesteps", f"expected a step count, got "
                          f"{steps!r}", "restore the file the run wrote")  # fmt: skip
    if not model.exists():
        raise ConfigError(
            str(model), "", f"is missing, but model.json records a final model of {steps} steps",
            "restore model.zip, or remove model.json to resume from the checkpoints",
        )  # fmt: skip
    inside = zip_timesteps(model)
    if inside != steps:
        found = "does not load" if inside is None else f"holds {inside} steps"
        raise ConfigError(
            str(model), "", f"{found}, its sidecar model.json says {steps} steps",
            "restore the pair the run wrote, or move both out of the run to resume from its "
            "checkpoints",
        )  # fmt: skip
    return steps


def _refuse_resume_of_nothing(run_dir: Path, resume: bool, or_start: bool) -> None:
    """``--resume`` (without ``--resume-or-start``) of a run folder with nothing trained."""
    if resume and not or_start and not _has_training(run_dir):
        raise ConfigError(
            str(run_dir),
            "--resume",
            "no run to resume (nothing trained there)",
            "check --seed and --runs-dir, or pass --resume-or-start to start the run when "
            "there is none",
        )


def run_lock(run_dir: Path) -> Any:
    """The lock of a run folder (``<run>/.lock``, :mod:`filelock`), held while a run writes it:
    a second run on the same folder is refused at once (two configs that map to one run
    name, e.g. two learning rates, would otherwise write each other's files). The same
    object for the same folder in a process, so taking it again nests."""
    from filelock import FileLock

    run_dir.mkdir(parents=True, exist_ok=True)
    return FileLock(run_dir / ".lock", timeout=0, is_singleton=True)


@contextmanager
def locked(run_dir: Path) -> Iterator[None]:
    """Hold :func:`run_lock` of ``run_dir``.

    Raises:
        ConfigError: another run holds it, naming the folder.
    """
    from filelock import Timeout

    path = run_dir / ".lock"
    if path.is_symlink() or (path.exists() and not path.is_file()):
        kind = "a folder" if path.is_dir() and not path.is_symlink() else "not a plain file"
        raise ConfigError(
            str(path), "", f"is {kind}, where the run keeps its lock file",
            "move it away (or remove it); the run then makes its lock file there",
        )  # fmt: skip
    lock = run_lock(run_dir)
    try:
        lock.acquire()
    except Timeout:
        raise ConfigError(
            str(run_dir), "", "another run is writing this run folder now (same env, algorithm "
            "and seed)", "wait for it to finish, or give this one another --seed or --runs-dir",
        ) from None  # fmt: skip
    try:
        yield
    finally:
        lock.release()


def _read_json(path: Path) -> dict[str, Any] | None:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _has_training(run_dir: Path) -> bool:
    """Whether ``run_dir`` holds anything trained (a start-up failure leaves at most a
    ``config.yaml``, which a new start may replace)."""
    return any(
        [
            (run_dir / "model.zip").exists(),
            (run_dir / "model.json").exists(),
            any((run_dir / "checkpoints").glob("model_*_steps.zip")),
            (run_dir / "eval" / "evaluations.npz").exists(),
            (run_dir / "eval" / "best_model.zip").exists(),
        ]
    )


def _changed_fields(old: Any, new: Any, prefix: str = "") -> list[str]:
    """Dotted paths where two config dicts differ, with both values."""
    if isinstance(old, dict) and isinstance(new, dict):
        return [
            change
            for key in sorted(set(old) | set(new), key=str)
            for change in _changed_fields(old.get(key), new.get(key), f"{prefix}{key}.")
        ]
    if old == new:
        return []
    shown = ["not set" if v is None else repr(v) for v in (old, new)]
    return [f"{prefix[:-1]} (run: {shown[0]}, now: {shown[1]})"]


def _norm_required(cfg: TrainConfig) -> bool:
    return cfg.normalize.obs or cfg.normalize.reward


def _recorded_config(run_dir: Path) -> tuple[dict[str, Any], str] | None:
    """The config the run was trained with and where it was read: the one recorded in the
    sidecar of its newest snapshot (what ran, whatever happened to ``config.yaml``), else the
    run's ``config.yaml`` (runs written before sidecars recorded it); ``None`` if neither."""
    for snap in _snapshots(run_dir, norm_required=False):
        if snap.config is not None:
            return snap.config, str(snap.model.with_suffix(".json").relative_to(run_dir))
    path = run_dir / "config.yaml"
    if path.exists():
        data = read_yaml(path)
        if isinstance(data, dict):
            return data, "config.yaml"
    return None


def _check_unchanged(cfg: TrainConfig, run_dir: Path, continues: bool) -> None:
    """Refuse a resume whose config differs from the one the run was trained with, or, when
    it ``continues`` a saved model, whose config was never recorded."""
    record = _recorded_config(run_dir)
    if record is None:
        if continues:
            raise ConfigError(
                str(run_dir),
                "--resume",
                "the run has no record of the config it was trained with (config.yaml is "
                "missing and its checkpoints predate recorded configs)",
                "put the run's config.yaml back, or start a new run with another --seed or "
                "--runs-dir",
            )
        return
    data, where = record
    recorded = load_model(TrainConfig, dict(data), name=str(run_dir / where)).to_dict()
    current = cfg.to_dict()
    for key in RESUMABLE_CHANGES:
        recorded.pop(key, None)
        current.pop(key, None)
    changes = _changed_fields(recorded, current)
    if changes:
        raise ConfigError(
            str(run_dir),
            "--resume",
            f"the config differs from the one the run was trained with ({where}) in "
            f"{'; '.join(changes)}",
            "resume with the run's own config.yaml, or start a new run with another --seed "
            "or --runs-dir (only total_timesteps, device and threads may change on resume)",
        )


def _new_model(cfg: TrainConfig, env: Any, run_dir: Path, verbose: int) -> Any:
    """A fresh model; what SB3 itself refuses (``batch_size: 1`` for PPO, ...) in one line. Its
    hidden layers' tanh is NumPy's while it trains (:mod:`agents.activations`)."""
    from .activations import use_fast_tanh

    algo_cls = algorithm_class(cfg.algo)
    try:
        model = algo_cls(
            cfg.policy,
            env,
            seed=cfg.seed,
            device=cfg.device,
            verbose=verbose,
            tensorboard_log=str(run_dir / "tb"),
            policy_kwargs=_policy_kwargs(cfg),
            **cfg.hyperparams.model_dump(exclude_none=True),
        )
    except (AssertionError, ValueError, TypeError) as exc:
        env.close()
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise ConfigError(
            cfg.run_name,
            "hyperparams",
            f"{algo_cls.__name__} refuses them ({reason})",
            "fix the values in the config",
        ) from None
    use_fast_tanh(model.policy)  # the saved zip keeps torch.nn.Tanh: SB3's own
    return model


def _load(cfg: TrainConfig, snap: Snapshot) -> tuple[Any, Any]:
    """``(model, training env)`` from a snapshot (NumPy's tanh, as :func:`_new_model`); raises
    whatever a broken file raises."""
    from .activations import use_fast_tanh

    env = make_vec_env(cfg, cfg.n_envs, cfg.seed, training=True, norm_stats=snap.norm)
    try:
        model = algorithm_class(cfg.algo).load(str(snap.model), env=env, device=cfg.device)
        use_fast_tanh(model.policy)
        if snap.buffer is not None and hasattr(model, "load_replay_buffer"):
            model.load_replay_buffer(str(snap.buffer))
    except BaseException:
        env.close()
        raise
    return model, env


def _resume_point(cfg: TrainConfig, run_dir: Path) -> tuple[Any, Any, Snapshot, list[str]] | None:
    """The newest complete snapshot that loads, and why each newer one was skipped (the
    caller warns "falling back" only where it does resume from the snapshot found)."""
    snaps = _snapshots(run_dir, _norm_required(cfg))
    problems = []
    for snap in snaps:
        if snap.missing is not None:
            problems.append(snap.missing)
            continue
        try:
            model, env = _load(cfg, snap)
        except Exception as exc:  # a file cut short by a kill, or not a model at all
            problems.append(f"{snap.model.name} does not load ({type(exc).__name__})")
            continue
        return model, env, snap, problems
    if snaps:
        raise ConfigError(
            str(run_dir),
            "--resume",
            f"no checkpoint is complete and loads ({'; '.join(problems)})",
            "start a new run with another --seed or --runs-dir",
        )
    return None


def check_runs_dir(runs_dir: Path, run_dir: Path) -> None:
    """Refuse a ``--runs-dir`` (or run folder) that cannot hold a run, before any work.

    Raises:
        ConfigError: it, or the nearest existing folder above it, is not a folder or not
            writable.
    """
    problem = folder_problem(run_dir)
    if problem is not None:
        raise ConfigError(
            str(runs_dir),
            "--runs-dir",
            problem,
            "give a folder you can write to (created if missing)",
        )


def train(
    cfg: TrainConfig,
    runs_dir: Path = Path("runs"),
    resume: bool = False,
    progress: bool = True,
    verbose: int = 0,
    callbacks: Sequence[Any] = (),
    or_start: bool = False,
    stop: Callable[[Any, float], bool] | None = None,
) -> Path:
    """Train and save; returns the run directory.

    Args:
        resume: continue the run in ``runs_dir`` (see the module docstring); a finished run
            with at least ``cfg.total_timesteps`` steps is left as it is.
        progress: print progress lines (env-steps/s, latest evaluation, ETA; TensorBoard
            gets the numbers either way).
        callbacks: extra SB3 callbacks, called after the built-in ones (checkpoints,
            evaluation) at every step, so on an evaluation step right after the evaluation
            (``agents.sweep`` reports to Ray Tune this way).
        or_start: with ``resume``, start the run when there is none (else that is an error).
        stop: ``learner: rsl_rl`` only: called after each evaluation with the run's
            ``DurableEvaluation`` and the seconds evaluations took so far; True ends the run
            there (SB3 callbacks do not run in that learner).

    Raises:
        ConfigError: the run exists and ``resume`` is not set; ``resume`` without
            ``or_start`` and no run; the config differs from the run's; no checkpoint of the
            run is complete and loads; ``runs_dir`` cannot hold a run.
    """
    limit_threads(cfg.threads)
    run_dir = runs_dir / cfg.run_name
    check_runs_dir(runs_dir, run_dir)
    _refuse_resume_of_nothing(run_dir, resume, or_start)  # before the lock creates the folder
    with locked(run_dir):
        return _train(cfg, run_dir, resume, progress, verbose, callbacks, or_start, stop)


def _train(
    cfg: TrainConfig,
    run_dir: Path,
    resume: bool,
    progress: bool,
    verbose: int,
    callbacks: Sequence[Any],
    or_start: bool,
    stop: Callable[[Any, float], bool] | None = None,
) -> Path:
    """:func:`train` with the run folder's lock held."""
    tb = run_dir / "tb"
    if tb.exists() and not tb.is_dir():
        raise ConfigError(str(tb), "", "is a file, where the run's TensorBoard logs go",
                          "move it away (or remove it)")  # fmt: skip
    trained = _has_training(run_dir)
    if trained and not resume:
        raise ConfigError(
            str(run_dir),
            "",
            "a run already exists",
            "pass --resume to continue it, or choose another --seed or --runs-dir",
        )
    _refuse_resume_of_nothing(run_dir, resume, or_start)
    if trained:
        finish_snapshots(run_dir)  # saves a kill interrupted: completed, or dropped if uncommitted
        _check_unchanged(cfg, run_dir, continues=bool(_snapshots(run_dir, False)))
    final = _final_steps(run_dir) if trained else None
    if final is not None and final >= cfg.total_timesteps:
        print(
            f"{run_dir}: finished ({final} steps, total_timesteps "
            f"{cfg.total_timesteps}); nothing to do. To train further, pass --resume "
            "--total-timesteps N with N larger"
        )
        return run_dir
    start = _resume_point(cfg, run_dir) if trained else None
    if trained and start is None:
        warn(f"{run_dir}: no checkpoint yet; starting at step 0, keeping eval/ history and best")
    if final is not None and (start is None or start[2].model != run_dir / "model.zip"):
        why = "does not load or lacks a file its sidecar names"
        if start is not None:
            start[1].close()
            why = next(iter(start[3]), why)  # the newest snapshot's problem: the final one's
        raise ConfigError(  # never a checkpoint (or a fresh start) in place of the final model
            str(run_dir / "model.zip"), "", f"the final model ({final} steps): {why}; it is "
            "never replaced by a checkpoint",
            "restore its files, or move model.zip and model.json out of the run to resume from "
            "its checkpoints",
        )  # fmt: skip
    if cfg.learner == "rsl_rl":
        from .parallel.train import train_parallel

        if callbacks:
            raise ConfigError(cfg.run_name, "learner", "SB3 callbacks do not run in learner "
                              "rsl_rl", "pass stop= instead, or use learner sb3")  # fmt: skip
        return train_parallel(cfg, run_dir, start, trained, progress, stop)
    if start is not None:
        model, env, snap, skipped = start
        for problem in skipped:
            warn(f"{run_dir}: {problem}; falling back to the previous checkpoint")
        if verbose:
            print(f"resuming {run_dir} from {snap.model} ({snap.steps} steps)")
    else:
        env = make_vec_env(cfg, cfg.n_envs, cfg.seed, training=True)
        model = _new_model(cfg, env, run_dir, verbose)
    stamp(model, cfg.env_id, cfg.env_kwargs)  # what its actions mean, saved inside every zip
    # The run starts here, so a start-up failure above leaves no trace that blocks a rerun.
    run_dir.mkdir(parents=True, exist_ok=True)
    config_text = yaml.safe_dump(cfg.to_dict(), sort_keys=False)
    write_atomic({run_dir / "config.yaml": lambda p: p.write_text(config_text)})
    # env_kwargs: the env the model is evaluated on (agents.bar's rule: the training ones less
    # the randomisation); trained_env_kwargs: what it was trained on; config: the config it
    # was trained with (what --resume checks).
    meta = {
        "env_id": cfg.env_id,
        "algo": cfg.algo,
        "env_kwargs": evaluation_env_kwargs(cfg.env_kwargs),
        "trained_env_kwargs": cfg.env_kwargs,
        "config": cfg.to_dict(),
    }
    evaluation = DurableEvaluation(
        BarEvaluation(cfg.env_id, cfg.env_kwargs, cfg.eval.episodes, cfg.eval.seed),
        run_dir / "eval",
        max(1, cfg.eval.freq // cfg.n_envs),
        meta,
        resumed_from=start[2].steps if start is not None else (0 if trained else None),
    )
    builtin = [
        CheckpointSnapshots(
            run_dir / "checkpoints", max(1, cfg.checkpoint_freq // cfg.n_envs), meta
        ),
        evaluation,
        TrainingProgress(
            cfg.run_name, cfg.total_timesteps, evaluation, stream=sys.stdout if progress else None
        ),
    ]
    remaining = cfg.total_timesteps - model.num_timesteps
    if remaining > 0:
        model.learn(
            total_timesteps=remaining,
            callback=[*builtin, *callbacks],
            reset_num_timesteps=start is None,
            tb_log_name="run",
        )
    # The final set; its sidecar model.json (the commit) marks the run done.
    save_snapshot(
        model,
        run_dir / "model.zip",
        run_dir / "vecnormalize.pkl",
        run_dir / "replay_buffer.pkl",
        meta,
    )
    env.close()
    return run_dir


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    parser = OneLineParser(prog="python -m agents.train", description=__doc__.split("\n")[0])
    parser.add_argument("config", help="training config YAML (configs/agents/*.yaml)")
    parser.add_argument("--seed", type=integer, help="override the config's seed")
    parser.add_argument("--total-timesteps", type=integer, help="override total_timesteps")
    parser.add_argument("--n-envs", type=integer, help="override n_envs")
    parser.add_argument(
        "--runs-dir", type=path, default=Path("runs"), help="where runs go (default runs/)"
    )
    how = parser.add_mutually_exclusive_group()
    how.add_argument(
        "--resume",
        action="store_true",
        help="continue the run from its newest complete checkpoint (total_timesteps: the "
        "run's own unless --total-timesteps is given); an error if there is no such run",
    )
    how.add_argument(
        "--resume-or-start",
        action="store_true",
        help="as --resume, but start the run when there is none (for scripts and job queues)",
    )
    parser.add_argument(
        "--no-progress", action="store_true", help="no progress lines (TensorBoard keeps them)"
    )
    parser.add_argument("--verbose", type=int, default=0)
    args = parser.parse_args(argv)
    resume = args.resume or args.resume_or_start
    overrides = {
        k: v
        for k, v in (
            ("seed", args.seed),
            ("total_timesteps", args.total_timesteps),
            ("n_envs", args.n_envs),
        )
        if v is not None
    }
    try:
        cfg = load_config(args.config, overrides)
        run_dir = args.runs_dir / cfg.run_name
        check_runs_dir(args.runs_dir, run_dir)
        _refuse_resume_of_nothing(run_dir, args.resume, args.resume_or_start)
        with locked(run_dir):  # held through train(), which takes it again
            if resume and args.total_timesteps is None and _has_training(run_dir):
                finish_snapshots(run_dir)
                record = _recorded_config(run_dir)
                if record is not None and "total_timesteps" in record[0]:
                    budget = {"total_timesteps": record[0]["total_timesteps"]}
                    cfg = load_config(args.config, {**overrides, **budget})
            run_dir = train(
                cfg,
                args.runs_dir,
                resume=resume,
                progress=not args.no_progress,
                verbose=args.verbose,
                or_start=args.resume_or_start,
            )
    except ConfigError as exc:
        print(f"agents.train: error: {exc}", file=sys.stderr)
        return 2
    except MemoryError:
        print(
            "agents.train: error: out of memory; give fewer --n-envs (or a smaller "
            "buffer_size / n_steps), then continue with --resume if the run had started",
            file=sys.stderr,
        )
        return 1
    except OSError as exc:  # the disk filled up, a folder was removed under the run, ...
        where = f"{exc.filename}: " if exc.filename else ""
        fix = (
            "a folder (or a file) stands where the run writes the other: move it away"
            if exc.errno in (errno.EISDIR, errno.ENOTDIR)
            else "check that the folder can be written and has free space"
        )
        print(
            f"agents.train: error: {where}{exc.strerror or exc}; {fix}, then run again (with "
            "--resume if the run had started)",
            file=sys.stderr,
        )
        return 1
    print(f"model: {run_dir / 'model.zip'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
