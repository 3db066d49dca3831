"""Training runs lose nothing to a kill, a resume, a finished run or a failed start (items 1-4).

The kill case is a real ``SIGKILL`` of a training subprocess; the others call
``agents.train.main`` in this process (no interpreter start-up per case) on tiny budgets.
"""

from __future__ import annotations

import json
import os
import pickle
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from reliability_helpers import ROOT, TINY, assert_one_line_error, write_config

from agents.train import main as train_main

pytestmark = pytest.mark.slow  # every case trains (one is a SIGKILLed subprocess)

RUN = "Detumble__ppo__0"
ERR = "agents.train: error: "


def _history(run: Path) -> dict[str, np.ndarray]:
    with np.load(run / "eval" / "evaluations.npz") as data:
        return {k: data[k] for k in data.files}


def _means(results: np.ndarray) -> list[float]:
    return [float(np.mean(r)) for r in results]


def _obs_count(path: Path) -> float:
    with open(path, "rb") as fh:
        return float(pickle.load(fh).obs_rms.count)


def _train(*args: str) -> int:
    return train_main([*map(str, args), "--no-progress"])


def _start_killable(config: Path, runs: Path, *extra: str) -> subprocess.Popen[bytes]:
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "agents.train",
            str(config),
            "--runs-dir",
            str(runs),
            "--no-progress",
            *extra,
        ],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        start_new_session=True,
        env={**os.environ, "SDL_VIDEODRIVER": "dummy"},
    )


def _kill_after_evaluation_past_checkpoint(
    proc: subprocess.Popen[bytes], run: Path, min_evals: int
) -> dict[str, np.ndarray]:
    """SIGKILL the run once its history has ``min_evals`` entries and the newest one is of a
    step after the newest checkpoint (so that resuming abandons it); returns the history."""
    deadline = time.time() + 180
    log = run / "eval" / "evaluations.npz"
    while time.time() < deadline and proc.poll() is None:
        if log.exists():
            history = _history(run)
            ckpts = [int(p.name.split("_")[1]) for p in (run / "checkpoints").glob("*.json")]
            times = history["timesteps"]
            if len(times) >= min_evals and ckpts and times[-1] > max(ckpts):
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
                return _history(run)
        time.sleep(0.05)
    err = proc.stderr.read().decode()[-2000:] if proc.stderr else ""
    os.killpg(proc.pid, signal.SIGKILL)
    raise AssertionError(f"the run never reached the kill point: {err}")


def test_history_and_best_model_survive_kills_and_resumes(tmp_path):
    """Item 1. Kill -9 mid-run twice, resume each time, then finish: every evaluation made is
    still in eval/evaluations.npz (those of the killed segments past their checkpoint in
    abandoned_*), the main arrays increase, and the best model is the best ever evaluated:
    never replaced by a worse one, and only by a better one."""
    # Evaluations every 256 steps, checkpoints every 768: most kills strand an evaluation.
    config = write_config(
        tmp_path, total_timesteps=100_000, checkpoint_freq=768, eval={"freq": 256, "episodes": 1}
    )
    runs, run = tmp_path / "runs", tmp_path / "runs" / RUN
    seen: list[dict[str, np.ndarray]] = []
    for extra, min_evals in (((), 4), (("--resume",), 8)):
        proc = _start_killable(config, runs, *extra)
        seen.append(_kill_after_evaluation_past_checkpoint(proc, run, min_evals))
        assert not (run / "model.json").exists()  # really killed mid-run
    best_before = json.loads((run / "eval" / "best_model.json").read_text())
    zip_before = (run / "eval" / "best_model.zip").read_bytes()

    newest = max(int(p.name.split("_")[1]) for p in (run / "checkpoints").glob("*.json"))
    count = _obs_count(run / "checkpoints" / f"model_vecnormalize_{newest}_steps.pkl")
    target = newest + 768
    assert _train(config, "--runs-dir", runs, "--resume", "--total-timesteps", target) == 0
    # Continued from the checkpoint, not restarted: its step count and its VecNormalize
    # statistics go on (768 new samples, plus the first observation of each of the 2 envs).
    assert json.loads((run / "model.json").read_text())["num_timesteps"] == target
    assert _obs_count(run / "vecnormalize.pkl") == pytest.approx(count + 768 + 2)

    assert list(run.rglob(".tmp-*")) == []  # files half-written by the kills are gone
    final = _history(run)
    kept = dict(zip(final["timesteps"].tolist(), _means(final["results"]), strict=True))
    gone = list(
        zip(final["abandoned_timesteps"].tolist(), _means(final["abandoned_results"]), strict=True)
    )
    assert np.all(np.diff(final["timesteps"]) > 0)
    assert final["timesteps"][-1] == target
    for history in seen:  # each evaluation ever made: kept in place, or kept as abandoned
        for t, mean in zip(history["timesteps"].tolist(), _means(history["results"]), strict=True):
            assert kept.get(t) == mean or (t, mean) in gone, (t, mean)
    assert len(gone) >= 2  # both kills stranded an evaluation past their checkpoint

    best = json.loads((run / "eval" / "best_model.json").read_text())
    assert best["mean_reward"] >= best_before["mean_reward"]
    last_segment = [m for t, m in kept.items() if t > newest]  # evaluated by the final resume
    assert last_segment and max(last_segment) <= best["mean_reward"]  # none better went unsaved
    if best["mean_reward"] == best_before["mean_reward"]:
        assert (run / "eval" / "best_model.zip").read_bytes() == zip_before
    assert best["mean_reward"] in [m for _, m in gone] + list(kept.values())
    assert best["vecnormalize"] == "best_model_vecnormalize.pkl"
    assert (run / "eval" / best["vecnormalize"]).exists()  # what agents.evaluate reads


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished tiny run (512 steps, checkpoints at 256 and 512)."""
    folder = tmp_path_factory.mktemp("finished")
    config = write_config(folder)
    assert _train(config, "--runs-dir", folder / "runs") == 0
    return folder


def _copy_run(finished: Path, tmp_path: Path) -> tuple[Path, Path]:
    shutil.copytree(finished, tmp_path, dirs_exist_ok=True)
    return tmp_path / "tiny.yaml", tmp_path / "runs"


def test_finished_run_is_left_alone(finished_run, tmp_path, capsys):
    """Item 2. --resume on a finished run trains nothing, rewrites nothing and says so."""
    config, runs = _copy_run(finished_run, tmp_path)
    run = runs / RUN
    before = {p: p.read_bytes() for p in run.rglob("*") if p.is_file()}
    assert _train(config, "--runs-dir", runs, "--resume") == 0
    out = capsys.readouterr().out
    assert "finished (512 steps" in out and "--total-timesteps" in out
    assert {p: p.read_bytes() for p in run.rglob("*") if p.is_file()} == before


def test_more_steps_continue_from_the_final_model(finished_run, tmp_path):
    """Item 2. --resume --total-timesteps beyond a finished run continues from model.zip (its
    VecNormalize sample count goes on from the final one), not from an older checkpoint."""
    config, runs = _copy_run(finished_run, tmp_path)
    run = runs / RUN
    for path in (run / "checkpoints").glob("*_512_steps.*"):
        path.unlink()  # the final state only in model.zip, beside an older checkpoint
    count_final = _obs_count(run / "vecnormalize.pkl")
    assert count_final != _obs_count(run / "checkpoints" / "model_vecnormalize_256_steps.pkl")
    assert _train(config, "--runs-dir", runs, "--resume", "--total-timesteps", 768) == 0
    assert json.loads((run / "model.json").read_text())["num_timesteps"] == 768
    # 256 new observations, plus the first observation of each of the 2 envs after reset.
    assert _obs_count(run / "vecnormalize.pkl") == pytest.approx(count_final + 256 + 2)
    assert "total_timesteps: 768" in (run / "config.yaml").read_text()  # what it ran with


def test_changed_config_on_resume_is_refused(finished_run, tmp_path, capsys):
    """Item 3. A resume with another learning rate would record a value the model does not
    use: it is refused, naming the field and both values, and config.yaml stays as it was."""
    _, runs = _copy_run(finished_run, tmp_path)
    recorded = (runs / RUN / "config.yaml").read_text()
    changed = write_config(
        tmp_path,
        "changed.yaml",
        hyperparams={"n_steps": 64, "batch_size": 64, "n_epochs": 1, "learning_rate": 0.05},
    )
    code = _train(changed, "--runs-dir", runs, "--resume", "--total-timesteps", 1024)
    assert code == 2
    line = assert_one_line_error(capsys.readouterr().err, ERR, "hyperparams.learning_rate", "0.05")
    assert "--seed or --runs-dir" in line
    assert (runs / RUN / "config.yaml").read_text() == recorded


def test_failed_start_leaves_nothing_that_blocks_a_rerun(tmp_path, capsys):
    """Item 4. A start that SB3 refuses (PPO's batch_size 1) is one line and leaves no run
    folder; a folder that an older version left with only config.yaml blocks neither a plain
    rerun nor --resume."""
    bad = write_config(tmp_path, "bad.yaml", hyperparams={"n_steps": 64, "batch_size": 1})
    runs = tmp_path / "runs"
    assert _train(bad, "--runs-dir", runs) == 2
    assert_one_line_error(capsys.readouterr().err, ERR, "hyperparams", "batch_size")
    assert not (runs / RUN / "config.yaml").exists()

    (runs / RUN).mkdir(parents=True, exist_ok=True)
    (runs / RUN / "config.yaml").write_text("left: by a failed start\n")
    good = write_config(tmp_path, total_timesteps=256)
    assert _train(good, "--runs-dir", runs) == 0
    assert json.loads((runs / RUN / "model.json").read_text())["num_timesteps"] == 256

    shutil.rmtree(runs / RUN / "checkpoints")
    (runs / RUN).joinpath("model.json").unlink()  # as if killed before its first
    (runs / RUN).joinpath("model.zip").unlink()  # checkpoint
    assert _train(good, "--runs-dir", runs, "--resume") == 0
    assert "no checkpoint yet; starting at step 0" in capsys.readouterr().err


@pytest.mark.parametrize("broken", ["model_768_steps.zip", "model_vecnormalize_768_steps.pkl"])
def test_corrupted_newest_checkpoint_falls_back_with_a_warning(tmp_path, capsys, broken):
    """Item 4. A newest checkpoint cut short (as by a kill during its write) is skipped with
    one warning line; training resumes from the previous one (its VecNormalize count goes on
    from that checkpoint's)."""
    config = write_config(tmp_path, total_timesteps=768)
    runs = tmp_path / "runs"
    assert _train(config, "--runs-dir", runs) == 0
    ckpt = runs / RUN / "checkpoints"
    (runs / RUN / "model.json").unlink()  # not finished: the run died after its
    (runs / RUN / "model.zip").unlink()  # checkpoint, before its final save
    data = (ckpt / broken).read_bytes()
    (ckpt / broken).write_bytes(data[: len(data) // 2])
    capsys.readouterr()
    assert _train(config, "--runs-dir", runs, "--resume", "--total-timesteps", 1024) == 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "model_768_steps.zip does not load" in err and "falling back" in err
    count_512 = _obs_count(ckpt / "model_vecnormalize_512_steps.pkl")
    assert _obs_count(runs / RUN / "vecnormalize.pkl") == pytest.approx(count_512 + 512 + 2)


def test_every_model_a_run_writes_names_its_statistics(finished_run, capsys):
    """Item 6. The final model, the best model and each checkpoint have a sidecar that names
    the statistics saved with them, which agents.evaluate then uses (no warning)."""
    from agents.evaluate import evaluate, find_normalization, read_sidecar

    run = finished_run / "runs" / RUN
    models = [run / "model.zip", run / "eval" / "best_model.zip"]
    models += sorted((run / "checkpoints").glob("model_*_steps.zip"))
    assert len(models) == 4
    for model in models:
        meta = read_sidecar(model)
        assert meta is not None and meta["env_id"] == "RigidEnv/Detumble-v0", model
        stats = find_normalization(model, meta)
        assert stats is not None and stats.exists() and stats.parent == model.parent
        steps = meta["num_timesteps"]
        # The statistics of that very model: one sample a step, plus the 2 envs' first reset.
        assert _obs_count(stats) == pytest.approx(steps + 2, abs=1e-3), model
    evaluate(run / "eval" / "best_model.zip", "RigidEnv/Detumble-v0", 2, 0, only=["model"])
    assert capsys.readouterr().err == ""


def test_a_save_killed_after_its_commit_is_completed(finished_run, tmp_path, capsys):
    """Items 1 and 4. The moment between a snapshot's commit (its sidecar renamed into place)
    and the renames of its staged files: the next --resume completes that save, drops an
    uncommitted one, and meanwhile agents.evaluate reads the committed set."""
    from agents.evaluate import find_normalization, load_policy, read_sidecar

    config, runs = _copy_run(finished_run, tmp_path)
    ev = runs / RUN / "eval"
    ckpt = runs / RUN / "checkpoints"
    stage = ev / ".tmp-stage-best_model-256"  # as save_snapshot stages the best model
    stage.mkdir()
    shutil.copy(ckpt / "model_256_steps.zip", stage / "best_model.zip")
    shutil.copy(ckpt / "model_vecnormalize_256_steps.pkl", stage / "best_model_vecnormalize.pkl")
    side = json.loads((ckpt / "model_256_steps.json").read_text())
    side |= {"mean_reward": 1e9, "vecnormalize": "best_model_vecnormalize.pkl"}
    (ev / "best_model.json").write_text(json.dumps({**side, "staged": stage.name}))
    uncommitted = ckpt / ".tmp-stage-model_768_steps-768"
    uncommitted.mkdir()
    (uncommitted / "model_768_steps.zip").write_bytes(b"half a model")

    meta = read_sidecar(ev / "best_model.zip")
    assert (
        find_normalization(stage / "best_model.zip", meta) == stage / "best_model_vecnormalize.pkl"
    )
    load_policy(ev / "best_model.zip", "RigidEnv/Detumble-v0")  # the staged, committed model

    assert _train(config, "--runs-dir", runs, "--resume") == 0  # finished: only the repair
    assert (ev / "best_model.zip").read_bytes() == (ckpt / "model_256_steps.zip").read_bytes()
    assert "staged" not in json.loads((ev / "best_model.json").read_text())
    assert list((runs / RUN).rglob(".tmp-*")) == []
    assert "finished" in capsys.readouterr().out


# ---- issue 28, section 2: resume continues from nothing but what it says ----------------------


def test_checkpoint_without_its_statistics_is_not_resumed_from(tmp_path, capsys):
    """A newest checkpoint whose VecNormalize statistics are gone (its sidecar still there) is
    not complete: one warning line, and training goes on from the previous checkpoint, whose
    statistics' sample count continues (fresh statistics would start from 0)."""
    config = write_config(tmp_path, total_timesteps=768)
    runs = tmp_path / "runs"
    assert _train(config, "--runs-dir", runs) == 0
    ckpt = runs / RUN / "checkpoints"
    (runs / RUN / "model.json").unlink()  # the run died after its last checkpoint,
    (runs / RUN / "model.zip").unlink()  # before its final save
    (ckpt / "model_vecnormalize_768_steps.pkl").unlink()
    capsys.readouterr()
    assert _train(config, "--runs-dir", runs, "--resume", "--total-timesteps", 1024) == 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert "model_768_steps.zip lacks model_vecnormalize_768_steps.pkl" in err
    assert "falling back" in err
    count_512 = _obs_count(ckpt / "model_vecnormalize_512_steps.pkl")
    # 512 new observations from step 512 to 1024, plus the first one of each of the 2 envs.
    assert _obs_count(runs / RUN / "vecnormalize.pkl") == pytest.approx(count_512 + 512 + 2)


def test_final_model_without_its_statistics_is_never_replaced_by_a_checkpoint(
    finished_run, tmp_path, capsys
):
    """The final model.zip without vecnormalize.pkl: more steps from a checkpoint would put a
    checkpoint (saved before the final update) in the final model's place; refused in one line
    naming what is missing, with no "falling back" it does not do (issue 44), nothing in the
    run rewritten (issue 35)."""
    config, runs = _copy_run(finished_run, tmp_path)
    run = runs / RUN
    (run / "vecnormalize.pkl").unlink()
    before = _files(run)
    assert _train(config, "--runs-dir", runs, "--resume", "--total-timesteps", 768) == 2
    err = capsys.readouterr().err
    assert_one_line_error(err, ERR, "never replaced by a checkpoint")
    assert "model.zip lacks vecnormalize.pkl" in err and "falling back" not in err
    assert _files(run) == before


def test_a_lock_that_is_a_folder_gets_a_true_message(tmp_path, capsys):
    """A folder (or a link) where the run keeps its ``.lock`` file: one line saying so and
    what to move, not "check that the folder can be written and has free space"."""
    config = write_config(tmp_path, total_timesteps=256)
    runs = tmp_path / "runs"
    (runs / RUN / ".lock").mkdir(parents=True)
    assert _train(config, "--runs-dir", runs) == 2
    err = capsys.readouterr().err
    assert_one_line_error(err, ERR, ".lock: is a folder, where the run keeps its lock file")
    assert "free space" not in err
    (runs / RUN / ".lock").rmdir()
    (runs / RUN / ".lock").symlink_to(tmp_path / "elsewhere")
    assert _train(config, "--runs-dir", runs) == 2
    assert "is not a plain file" in capsys.readouterr().err


def _files(run: Path) -> dict[Path, bytes]:
    return {p: p.read_bytes() for p in run.rglob("*") if p.is_file() and p.name != ".lock"}


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ("no model.json", ["model.zip", "no readable sidecar model.json"]),
        ("no model.zip", ["model.zip", "is missing, but model.json records a final model"]),
        ("null", ["model.json", "num_timesteps", "None"]),
        ("lots", ["model.json", "num_timesteps", "'lots'"]),
        ("other steps", ["model.zip", "holds 512 steps, its sidecar model.json says 256 steps"]),
        ("tb file", ["tb", "is a file"]),
    ],
)
def test_resume_checks_every_file_it_trusts_against_the_sidecar(
    finished_run, tmp_path, capsys, change, words
):
    """Issue 35: a final model without its sidecar (the last checkpoint would be written over
    the trained model), a sidecar without its model (reported "finished"), a sidecar's step
    count that is not a count or disagrees with the model, a tb/ that is a file: each --resume
    is one line naming the file, exit 2, nothing in the run rewritten."""
    config, runs = _copy_run(finished_run, tmp_path)
    run = runs / RUN
    side = json.loads((run / "model.json").read_text())
    if change == "no model.json":
        (run / "model.json").unlink()
    elif change == "no model.zip":
        (run / "model.zip").unlink()
    elif change == "tb file":
        shutil.rmtree(run / "tb")
        (run / "tb").write_text("not a folder")
    else:
        steps = {"null": None, "lots": "lots", "other steps": 256}[change]
        (run / "model.json").write_text(json.dumps({**side, "num_timesteps": steps}))
    before = _files(run)
    for more in ([], ["--total-timesteps", "1024"]):
        assert _train(config, "--runs-dir", runs, "--resume", *more) == 2
        assert_one_line_error(capsys.readouterr().err, ERR, *words)
        assert _files(run) == before


def test_steps_of_a_checkpoint_come_from_its_sidecar_not_its_name(finished_run, tmp_path):
    """A checkpoint renamed to model_999999_steps.zip (its sidecar with it) counts the 256
    steps its sidecar and its zip record; one renamed without its sidecar, whose zip holds
    other steps than its name says, is not resumed from."""
    from agents.train import _snapshots

    _, runs = _copy_run(finished_run, tmp_path)
    ckpt = runs / RUN / "checkpoints"
    for suffix in (".zip", ".json"):
        (ckpt / f"model_256_steps{suffix}").rename(ckpt / f"model_999999_steps{suffix}")
    (ckpt / "model_512_steps.zip").rename(ckpt / "model_777_steps.zip")
    (ckpt / "model_512_steps.json").unlink()
    steps = {s.model.name: s.steps for s in _snapshots(runs / RUN, norm_required=False)}
    assert steps == {"model.zip": 512, "model_999999_steps.zip": 256}


def test_no_complete_checkpoint_is_refused(finished_run, tmp_path, capsys):
    """Every snapshot without its statistics: nothing can be resumed as saved; refused in one
    line naming each, and nothing in the run is rewritten."""
    config, runs = _copy_run(finished_run, tmp_path)
    run = runs / RUN
    for stats in [run / "vecnormalize.pkl", *(run / "checkpoints").glob("*vecnormalize*")]:
        stats.unlink()
    before = {p: p.read_bytes() for p in run.rglob("*") if p.is_file()}
    code = _train(config, "--runs-dir", runs, "--resume", "--total-timesteps", 1024)
    assert code == 2
    err = capsys.readouterr().err
    line = assert_one_line_error(err.splitlines()[-1], ERR, "no checkpoint is complete")
    assert "model_256_steps.zip lacks" in line and "model.zip lacks" in line
    assert {p: p.read_bytes() for p in run.rglob("*") if p.is_file()} == before


def test_resume_checks_what_ran_when_config_yaml_is_gone(finished_run, tmp_path, capsys):
    """Issue 28's example: config.yaml deleted, --resume with gamma 0.5 where the model was
    trained with 0.99. Refused, naming the sidecar it compared against; config.yaml is not
    written with a value the model never used. With the run's own config it resumes, and
    config.yaml again records what runs."""
    config, runs = _copy_run(finished_run, tmp_path)
    run = runs / RUN
    (run / "config.yaml").unlink()
    hyper = {"n_steps": 64, "batch_size": 64, "n_epochs": 1}
    changed = write_config(tmp_path, "changed.yaml", hyperparams={**hyper, "gamma": 0.5})
    assert _train(changed, "--runs-dir", runs, "--resume", "--total-timesteps", 768) == 2
    line = assert_one_line_error(capsys.readouterr().err, ERR, "hyperparams.gamma", "0.5")
    assert "model.json" in line
    assert not (run / "config.yaml").exists()
    assert json.loads((run / "model.json").read_text())["num_timesteps"] == 512

    assert _train(config, "--runs-dir", runs, "--resume", "--total-timesteps", 768) == 0
    recorded = yaml.safe_load((run / "config.yaml").read_text())
    assert "gamma" not in recorded["hyperparams"]  # SB3's default 0.99, as trained
    assert recorded["total_timesteps"] == 768
    side = json.loads((run / "model.json").read_text())
    assert side["config"] == recorded  # the sidecar records the same


def test_resume_without_any_record_of_the_config_is_refused(finished_run, tmp_path, capsys):
    """A run from before sidecars recorded configs, with config.yaml gone: nothing says what
    the model was trained with, so resuming it is refused (one line), not guessed."""
    config, runs = _copy_run(finished_run, tmp_path)
    run = runs / RUN
    (run / "config.yaml").unlink()
    for side in run.rglob("*.json"):
        data = json.loads(side.read_text())
        data.pop("config", None)
        side.write_text(json.dumps(data))
    assert _train(config, "--runs-dir", runs, "--resume", "--total-timesteps", 768) == 2
    assert_one_line_error(capsys.readouterr().err, ERR, "no record of the config", "config.yaml")


def test_resume_of_a_run_that_does_not_exist_is_refused(tmp_path, capsys):
    """A wrong --seed or --runs-dir with --resume: refused in one line, nothing created;
    --resume-or-start starts it, and later resumes it."""
    config = write_config(tmp_path, total_timesteps=256)
    runs = tmp_path / "runs"
    assert _train(config, "--runs-dir", runs, "--resume") == 2
    line = assert_one_line_error(capsys.readouterr().err, ERR, "no run to resume", "--seed")
    assert "--resume-or-start" in line
    assert not runs.exists()
    assert _train(config, "--runs-dir", runs, "--resume", "--seed", 7) == 2  # a wrong seed
    assert not runs.exists()
    # Only config.yaml (an older failed start) is not a run either.
    (runs / RUN).mkdir(parents=True)
    (runs / RUN / "config.yaml").write_text(yaml.safe_dump(TINY))
    assert _train(config, "--runs-dir", runs, "--resume") == 2
    capsys.readouterr()

    assert _train(config, "--runs-dir", runs, "--resume-or-start") == 0
    assert json.loads((runs / RUN / "model.json").read_text())["num_timesteps"] == 256
    assert _train(config, "--runs-dir", runs, "--resume-or-start", "--total-timesteps", 512) == 0
    assert json.loads((runs / RUN / "model.json").read_text())["num_timesteps"] == 512
