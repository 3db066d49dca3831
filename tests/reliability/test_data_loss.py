"""Issue 35, data loss: files a user owns are never removed. ``rigid-env bench learn`` removes
only the run folders its manifest lists; a run folder is locked while a run writes it, so a
second ``agents.train`` on it is refused in one line naming it (the resume cases that train are
in test_resume.py)."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest
from reliability_helpers import assert_one_line_error, write_config

from agents.train import main as train_main
from rigid_env.bench.learn import MANIFEST, _clear_own_runs, _run_name
from rigid_env.cli import main as cli_main

RUN = "Detumble__ppo__0"


def _tree(folder: Path) -> dict[Path, bytes]:
    return {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def _user_runs(folder: Path) -> dict[Path, bytes]:
    """A user's own runs/ (a run of theirs and runs/mine), as bench learn's planned layout."""
    mine = folder / "runs" / "mine"
    mine.mkdir(parents=True)
    (mine / "notes.txt").write_text("three weeks of results")
    theirs = folder / "runs" / "shipped" / _run_name("detumble", 0, False)
    theirs.mkdir(parents=True)
    (theirs / "model.zip").write_bytes(b"a user's model")
    return _tree(folder)


def test_bench_learn_refuses_a_run_folder_it_did_not_write(tmp_path, capsys):
    """`bench learn --out .` over a user's runs/ (a folder where it would put a run): refused in
    one line naming the folder, before any training; with --force too; nothing removed."""
    before = _user_runs(tmp_path)
    for force in ([], ["--force"]):
        argv = ["bench", "learn", "--out", str(tmp_path), "--tasks", "detumble", "--seeds", "0",
                "--previous-seeds", *force]  # fmt: skip
        assert cli_main(argv) == 2
        assert_one_line_error(
            capsys.readouterr().err, "rigid-env: error: --out:", "did not write", RUN
        )
        assert _tree(tmp_path) == before


def test_bench_learn_removes_only_what_its_manifest_lists(tmp_path):
    """With --force, an earlier run of the benchmark (listed in its manifest) is replaced; a
    user's runs/mine beside it, never listed, stays byte for byte; without --force the earlier
    run is refused in one line. The manifest lists the planned runs before training starts."""
    mine = tmp_path / "runs" / "mine"
    mine.mkdir(parents=True)
    (mine / "model.zip").write_bytes(b"mine")
    own = tmp_path / "runs" / "shipped" / _run_name("detumble", 0, False)
    own.mkdir(parents=True)
    (own / "model.zip").write_bytes(b"the benchmark's")
    (tmp_path / MANIFEST).write_text(json.dumps([str(own.relative_to(tmp_path))]))
    with pytest.raises(ValueError, match=r"earlier run of this benchmark; pass --force"):
        _clear_own_runs(tmp_path, [own], force=False)
    assert own.exists()
    _clear_own_runs(tmp_path, [own], force=True)
    assert not own.exists()
    assert (mine / "model.zip").read_bytes() == b"mine"
    assert json.loads((tmp_path / MANIFEST).read_text()) == [str(own.relative_to(tmp_path))]


def test_a_manifest_cannot_make_the_benchmark_remove_a_folder_it_does_not_plan(tmp_path):
    """A manifest that lists runs/mine (edited, or another benchmark's) removes nothing that is
    not a planned run of this call."""
    mine = tmp_path / "runs" / "mine"
    mine.mkdir(parents=True)
    (mine / "a.txt").write_text("keep")
    (tmp_path / MANIFEST).write_text(json.dumps(["runs/mine", "..", "/"]))
    planned = tmp_path / "runs" / "shipped" / _run_name("detumble", 0, False)
    _clear_own_runs(tmp_path, [planned], force=True)
    assert (mine / "a.txt").read_text() == "keep"


def _hold_lock(run_dir: Path) -> subprocess.Popen[str]:
    """Another process holding ``run_dir``'s lock (as a running agents.train does)."""
    code = (
        "import sys, time; from pathlib import Path; from agents.train import run_lock; "
        "lock = run_lock(Path(sys.argv[1])); lock.acquire(); print('held', flush=True); "
        "time.sleep(60)"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", code, str(run_dir)], stdout=subprocess.PIPE, text=True,
        cwd=Path(__file__).resolve().parents[2],
    )  # fmt: skip
    assert proc.stdout is not None and proc.stdout.readline().strip() == "held"
    return proc


@pytest.mark.parametrize("how", [[], ["--resume-or-start"]])
def test_a_second_run_on_a_locked_run_folder_is_refused(tmp_path, capsys, how):
    """Two configs mapping to one run folder (same env, algo and seed, two learning rates):
    while one runs, the other is refused in one line naming the folder, exit 2, and writes
    nothing there."""
    config = write_config(tmp_path, hyperparams={"n_steps": 64, "batch_size": 64,
                                                 "learning_rate": 1e-3})  # fmt: skip
    run_dir = tmp_path / "runs" / RUN
    holder = _hold_lock(run_dir)
    try:
        before = _tree(run_dir)
        start = time.perf_counter()
        assert train_main([str(config), "--runs-dir", str(tmp_path / "runs"), *how]) == 2
        assert time.perf_counter() - start < 30  # refused at once, not after waiting
        assert_one_line_error(
            capsys.readouterr().err, "agents.train: error:", str(run_dir), "another run"
        )
        assert _tree(run_dir) == before
    finally:
        holder.kill()
        holder.wait()
