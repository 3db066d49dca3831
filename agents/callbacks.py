"""Training callbacks whose files survive a kill: every set of files is whole, old or new.

A *snapshot* is a model and its companions: ``<name>.zip``, the ``VecNormalize`` statistics,
the replay buffer (off-policy algorithms) and a JSON sidecar ``<name>.json`` that says which
files belong to it and what the model was trained on. The files are written whole into a
staging folder, then the sidecar is renamed into place (``os.replace`` is atomic: this is the
commit), then the staged files are renamed over the old ones and the sidecar loses its
``staged`` key. A ``kill -9`` before the commit leaves the previous set as it was; one after
it leaves a sidecar with ``staged``, which :func:`finish_snapshots` completes (``agents.train``
calls it before anything else reads the run). ``agents.evaluate`` reads the sidecar to find
the statistics of any model a run wrote (final, best or checkpoint).

The evaluation history ``eval/evaluations.npz`` (SB3's ``timesteps``, ``results``,
``ep_lengths``, plus per-episode ``successes`` and ``fuel`` [N s], the PD controller's mean
``pd_fuel`` on the same episodes, ``seconds`` and ``cpu_seconds``, the training wall-clock and
the process's CPU time since the segment started) and the best model survive resumes: on
resume from a checkpoint at step S the entries of steps after S, which describe models that
no longer exist, move to ``abandoned_timesteps`` / ``abandoned_results`` /
``abandoned_ep_lengths`` / ``abandoned_successes`` (nothing is dropped, and the main arrays
stay one increasing line for plotting); the best model is replaced only by a better one,
whichever segment it came from.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import time
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from .bar import BarEvaluation, live_policy

HISTORY_KEYS = (
    "timesteps",
    "results",
    "ep_lengths",
    "successes",
    "fuel",
    "pd_fuel",
    "seconds",
    "cpu_seconds",
)


def warn(message: str) -> None:
    """One warning line on stderr."""
    print(f"agents.train: warning: {message}", file=sys.stderr, flush=True)


def _temporary(path: Path) -> Path:
    """A sibling name with the same suffix (SB3 appends ``.zip``/``.pkl`` to names without)."""
    return path.with_name(f".tmp-{os.getpid()}-{path.name}")


def write_atomic(paths: dict[Path, Callable[[Path], Any]]) -> None:
    """Write each file with its writer under a temporary name, then rename them all in order."""
    done: list[tuple[Path, Path]] = []
    try:
        for path, writer in paths.items():
            tmp = _temporary(path)
            writer(tmp)
            done.append((tmp, path))
        for tmp, path in done:
            os.replace(tmp, path)
    finally:
        for tmp, _ in done:
            tmp.unlink(missing_ok=True)


def write_json_atomic(path: Path, data: dict[str, Any]) -> None:
    """``data`` as indented JSON at ``path``, atomically."""
    write_atomic({path: lambda p: p.write_text(json.dumps(data, indent=2) + "\n")})


def save_snapshot(
    model: Any,
    zip_path: Path,
    norm_path: Path | None,
    buffer_path: Path | None,
    meta: dict[str, Any],
) -> dict[str, Any]:
    """Save ``model`` (+ the ``VecNormalize`` statistics of its env, + its replay buffer) with
    its sidecar ``zip_path.with_suffix(".json")`` as one set; returns the sidecar's content.

    Args:
        meta: what the model was trained on (``env_id``, ``algo``, ``env_kwargs``, ...).
    """
    folder = zip_path.parent
    stage = folder / f".tmp-stage-{zip_path.stem}-{int(model.num_timesteps)}"
    shutil.rmtree(stage, ignore_errors=True)
    stage.mkdir(parents=True)
    model.save(stage / zip_path.name)
    norm_env = model.get_vec_normalize_env()
    if norm_path is not None and norm_env is not None:
        norm_env.save(stage / norm_path.name)
    else:
        norm_path = None
    if buffer_path is not None and getattr(model, "replay_buffer", None) is not None:
        model.save_replay_buffer(stage / buffer_path.name)
    else:
        buffer_path = None
    side = {
        **meta,
        "num_timesteps": int(model.num_timesteps),
        "vecnormalize": norm_path.name if norm_path is not None else None,
        "replay_buffer": buffer_path.name if buffer_path is not None else None,
    }
    sidecar = zip_path.with_suffix(".json")
    write_json_atomic(sidecar, {**side, "staged": stage.name})  # the commit
    finish_snapshot(sidecar)
    return side


def finish_snapshot(sidecar: Path) -> None:
    """Complete a committed save (idempotent): move its staged files into place."""
    try:
        side = json.loads(sidecar.read_text())
    except (OSError, ValueError):
        return
    if not isinstance(side, dict) or "staged" not in side:
        return
    stage = sidecar.parent / str(side.pop("staged"))
    if stage.is_dir():
        for path in stage.iterdir():
            os.replace(path, sidecar.parent / path.name)
        stage.rmdir()
    write_json_atomic(sidecar, side)


def finish_snapshots(run_dir: Path) -> None:
    """Complete every committed save in a run, then drop what uncommitted ones left."""
    for sidecar in run_dir.rglob("*.json"):
        finish_snapshot(sidecar)
    for partial in sorted(run_dir.rglob(".tmp-*"), reverse=True):
        if partial.is_dir():
            shutil.rmtree(partial, ignore_errors=True)
        else:
            partial.unlink(missing_ok=True)


def zip_timesteps(zip_path: Path) -> int | None:
    """``num_timesteps`` stored inside an SB3 model zip (``None`` if unreadable)."""
    try:
        with zipfile.ZipFile(zip_path) as zf:
            return int(json.loads(zf.read("data"))["num_timesteps"])
    except (OSError, KeyError, ValueError, TypeError, zipfile.BadZipFile):
        return None


class CheckpointSnapshots(BaseCallback):
    """Every ``save_freq`` calls: ``model_<N>_steps.zip`` with
    ``model_vecnormalize_<N>_steps.pkl``, ``model_replay_buffer_<N>_steps.pkl`` and
    ``model_<N>_steps.json`` in ``folder`` (SB3's ``CheckpointCallback`` names)."""

    def __init__(self, folder: Path, save_freq: int, meta: dict[str, Any]) -> None:
        super().__init__()
        self.folder, self.save_freq, self.meta = folder, save_freq, meta

    def _on_step(self) -> bool:
        if self.n_calls % self.save_freq == 0:
            n = self.num_timesteps
            save_snapshot(
                self.model,
                self.folder / f"model_{n}_steps.zip",
                self.folder / f"model_vecnormalize_{n}_steps.pkl",
                self.folder / f"model_replay_buffer_{n}_steps.pkl",
                self.meta,
            )
        return True


class DurableEvaluation(BaseCallback):
    """Periodic deterministic evaluation against the bar (:mod:`agents.bar`) whose history and
    best model outlive kills and resumes; see the module docstring. ``latest`` holds the last
    evaluation's ``timesteps``, ``success_rate``, ``fuel_ratio`` and ``met``, and
    ``first_met`` the ``(timesteps, seconds)`` of the first that met the bar in this segment.

    Args:
        evaluation: the held-out episodes (normalised with the training env's statistics as
            they are at each evaluation).
        folder: ``eval/``: ``evaluations.npz`` and the ``best_model`` snapshot.
        eval_freq: calls between evaluations.
        meta: sidecar content of the best model.
        resumed_from: steps of the checkpoint this training segment starts from (``None`` for
            a fresh run); history entries after it are moved to the ``abandoned_*`` arrays.
    """

    def __init__(
        self,
        evaluation: BarEvaluation,
        folder: Path,
        eval_freq: int,
        meta: dict[str, Any],
        resumed_from: int | None,
    ) -> None:
        super().__init__()
        self.evaluation, self.folder, self.meta = evaluation, folder, meta
        self.eval_freq = eval_freq
        self.latest: dict[str, Any] | None = None
        self.first_met: tuple[int, float] | None = None
        self._start, self._cpu_start = time.perf_counter(), time.process_time()
        self.history, self.abandoned = _read_history(folder / "evaluations.npz")
        times = self.history["timesteps"]
        cut = next((i for i, t in enumerate(times) if t > (resumed_from or 0)), len(times))
        if resumed_from is not None and cut < len(times):  # entries are in increasing steps
            for key, values in self.history.items():
                self.abandoned[key] += values[cut:]
                del values[cut:]
            self._write_history()
        self.best_mean_reward = self._best_so_far()

    def _best_so_far(self) -> float:
        """The best model's mean reward: from its sidecar when that matches the zip, else the
        best mean in the history (a run written before sidecars existed)."""
        best_zip, best_json = self.folder / "best_model.zip", self.folder / "best_model.json"
        if not best_zip.exists():
            return -np.inf
        try:
            side = json.loads(best_json.read_text())
            if side.get("num_timesteps") == zip_timesteps(best_zip):
                return float(side["mean_reward"])
        except (OSError, ValueError, KeyError, TypeError):
            pass
        means = [float(np.mean(r)) for r in self.history["results"] + self.abandoned["results"]]
        warn(f"{best_json}: missing or not for {best_zip.name}; taking the best in the history")
        return max(means, default=-np.inf)

    def _write_history(self) -> None:
        arrays = _aligned(self.history)
        arrays |= _aligned(self.abandoned, "abandoned_")

        def write(path: Path) -> None:
            with open(path, "wb") as fh:
                np.savez(fh, **arrays)

        self.folder.mkdir(parents=True, exist_ok=True)
        write_atomic({self.folder / "evaluations.npz": write})

    def _on_training_start(self) -> None:
        self._start, self._cpu_start = time.perf_counter(), time.process_time()

    def _on_step(self) -> bool:
        if self.n_calls % self.eval_freq != 0:
            return True
        res = self.evaluation(live_policy(self.model))
        seconds = time.perf_counter() - self._start
        cpu_seconds = time.process_time() - self._cpu_start
        entry = {
            "timesteps": self.num_timesteps,
            "results": res["return"].tolist(),
            "ep_lengths": res["length"].tolist(),
            "successes": res["success"].tolist(),
            "fuel": res["fuel"].tolist(),
            "pd_fuel": self.evaluation.pd_fuel,
            "seconds": seconds,
            "cpu_seconds": cpu_seconds,
        }
        for key, value in entry.items():
            self.history[key].append(value)
        self._write_history()
        self.latest = {k: res[k] for k in ("success_rate", "fuel_ratio", "met")}
        self.latest["timesteps"] = self.num_timesteps
        if res["met"] and self.first_met is None:
            self.first_met = (self.num_timesteps, seconds)
        mean = float(np.mean(res["return"]))
        self.logger.record("eval/mean_reward", mean)
        self.logger.record("eval/mean_ep_length", float(np.mean(res["length"])))
        self.logger.record("eval/success_rate", res["success_rate"])
        self.logger.record("eval/fuel_ratio_to_pd", res["fuel_ratio"])
        self.logger.record("eval/bar_met", float(res["met"]))
        if mean > self.best_mean_reward:
            folder = self.folder
            save_snapshot(
                self.model,
                folder / "best_model.zip",
                folder / "best_model_vecnormalize.pkl",
                None,
                {**self.meta, "mean_reward": mean},
            )
            self.best_mean_reward = mean
        return True


def _aligned(entries: dict[str, list[Any]], prefix: str = "") -> dict[str, np.ndarray]:
    """Arrays of the keys with one row per evaluation (``successes`` is missing from histories
    SB3 wrote for envs without ``is_success``); nothing for an empty abandoned set."""
    n = len(entries["timesteps"])
    if n == 0 and prefix:
        return {}
    return {prefix + k: np.asarray(v) for k, v in entries.items() if len(v) == n}


def _read_history(path: Path) -> tuple[dict[str, list[Any]], dict[str, list[Any]]]:
    """The history and abandoned entries of ``evaluations.npz`` as lists (empty if absent)."""
    history: dict[str, list[Any]] = {k: [] for k in HISTORY_KEYS}
    abandoned: dict[str, list[Any]] = {k: [] for k in HISTORY_KEYS}
    if not path.exists():
        return history, abandoned
    try:
        with np.load(path) as data:
            for key in data.files:
                target = abandoned if key.startswith("abandoned_") else history
                name = key.removeprefix("abandoned_")
                if name in target:
                    target[name] = list(data[key].tolist())
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        aside = path.with_name(f"{path.name}.unreadable")
        os.replace(path, aside)
        warn(f"{path}: unreadable ({type(exc).__name__}); kept it as {aside.name}, new history")
    return history, abandoned
