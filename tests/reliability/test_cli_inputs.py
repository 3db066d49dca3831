"""``rigid-env simulate`` and ``rigid-env bench``: no run that cannot fit, no overwrite without
--force, errors that name the user's path (items 5 and 10)."""

from __future__ import annotations

import errno
import os
from pathlib import Path

import numpy as np
import pytest
from reliability_helpers import ROOT, assert_one_line_error

import rigid_env.cli as cli
from rigid_env.bench.report import prepare_out
from rigid_env.scene import load_scene
from rigid_env.trajectory import simulate

SCENE = ROOT / "configs" / "scenes" / "asymmetric_spin.yaml"
ERR = "rigid-env: error: "


def test_a_trajectory_that_cannot_fit_is_refused_up_front(tmp_path, capsys):
    """Item 10. 1e12 steps (168 TB) is refused at once with its size and the most that fits,
    instead of filling memory for minutes and dying of MemoryError."""
    out = tmp_path / "traj.npz"
    assert cli.main(["simulate", str(SCENE), "--steps", "1e12", "--out", str(out)]) == 2
    line = assert_one_line_error(capsys.readouterr().err, ERR, "--steps", "168.0 TB")
    assert "give at most --steps" in line
    assert not out.exists()


def test_exponent_steps_and_chunks_give_the_same_trajectory(tmp_path, capsys, monkeypatch):
    """--steps 2e1 is 20 steps; the trajectory filled 7 steps at a time is bit for bit the one
    simulate() records in one call."""
    monkeypatch.setattr(cli, "_CHUNK_STEPS", 7)
    out = tmp_path / "traj.npz"
    assert cli.main(["simulate", str(SCENE), "--steps", "2e1", "--out", str(out)]) == 0
    world = load_scene(SCENE).build_world(1)
    want = simulate(world, 20)
    with np.load(out) as got:
        assert set(got.files) == set(want)
        for key, value in want.items():
            expected = value if key == "t" else value[:, 0]
            assert np.array_equal(got[key], expected), key
    assert "wrote" in capsys.readouterr().out


def _unwritable_folder(tmp_path: Path) -> Path:
    """A folder this process cannot create files in (read-only for a normal user; as root,
    which ignores permissions, sysfs)."""
    folder = tmp_path / "read_only"
    folder.mkdir()
    folder.chmod(0o555)
    probe = folder / "probe"
    try:
        probe.touch()
    except OSError:
        return folder
    probe.unlink()
    if os.path.isdir("/sys") and not os.access("/sys/probe", os.F_OK):
        try:
            Path("/sys/probe").touch()
        except OSError:
            return Path("/sys")
    pytest.skip("no unwritable folder on this machine")


def test_out_in_a_read_only_folder_names_the_users_path(tmp_path, capsys):
    """Item 10. The error names --out's path and the fix, not a temporary file."""
    out = _unwritable_folder(tmp_path) / "traj.npz"
    assert cli.main(["simulate", str(SCENE), "--steps", "10", "--out", str(out)]) == 2
    line = assert_one_line_error(capsys.readouterr().err, ERR, "--out", str(out), "choose a folder")
    assert ".tmp" not in line and "probe" not in line


def test_a_failed_write_names_the_users_path_and_leaves_nothing(tmp_path, capsys, monkeypatch):
    """Item 10. A write that fails part way (a full disk) names --out and leaves no file."""

    def full_disk(*args: object, **kwargs: object) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(cli.np, "savez", full_disk)
    out = tmp_path / "traj.npz"
    assert cli.main(["simulate", str(SCENE), "--steps", "10", "--out", str(out)]) == 2
    assert_one_line_error(capsys.readouterr().err, ERR, "--out", str(out), "No space left")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("argv", "result"),
    [
        (["bench", "accuracy", "--quick"], "accuracy.csv"),
        (["bench", "speed", "--smoke"], "speed.md"),
        (["bench", "stability", "--quick"], "stability.md"),
    ],
)
def test_bench_asks_for_force_before_overwriting(tmp_path, capsys, argv, result):
    """Item 5. Earlier results in --out stop a benchmark before it runs (the files keep their
    bytes), with a line that names them and --force."""
    earlier = tmp_path / result
    earlier.write_text("earlier results")
    assert cli.main([*argv, "--out", str(tmp_path)]) == 2
    assert_one_line_error(capsys.readouterr().err, ERR, "--out", earlier.name, "--force")
    assert earlier.read_text() == "earlier results"


def test_force_lets_the_benchmark_overwrite(tmp_path):
    (tmp_path / "speed.md").write_text("earlier")
    with pytest.raises(ValueError, match="--force"):
        prepare_out(tmp_path, ["speed.md", "speed.csv"], force=False)
    assert prepare_out(tmp_path, ["speed.md", "speed.csv"], force=True) == tmp_path
    prepare_out(tmp_path, ["new.md"], force=False)  # nothing there: nothing to ask


# ---- issue 28: nothing replaced that is not a file, nothing that runs without a word ---------


@pytest.mark.parametrize("kind", ["fifo", "symlink"])
def test_out_that_is_not_a_regular_file_is_refused_and_left_alone(tmp_path, capsys, kind):
    """The trajectory is written beside --out and renamed over it, which would replace a
    device (as root, `--out /dev/full --force` replaced /dev/full with an npz), a pipe or a
    link instead of writing through it."""
    out = tmp_path / "out.npz"
    if kind == "fifo":
        os.mkfifo(out)
    else:
        (tmp_path / "target.npz").write_bytes(b"keep")
        out.symlink_to(tmp_path / "target.npz")
    argv = ["simulate", str(SCENE), "--steps", "3", "--out", str(out), "--force"]
    assert cli.main(argv) == 2
    words = ("symbolic link",) if kind == "symlink" else ("not a regular file",)
    assert_one_line_error(capsys.readouterr().err, ERR, "--out", *words)
    assert out.is_symlink() if kind == "symlink" else not out.is_file()
    if kind == "symlink":
        assert (tmp_path / "target.npz").read_bytes() == b"keep"


def test_substeps_beyond_the_bound_are_refused(tmp_path, capsys):
    """--substeps 1e12 ran for ever without a line (one world step never ended)."""
    argv = ["simulate", str(SCENE), "--steps", "3", "--substeps", "1e12", "--out", "x.npz"]
    assert cli.main([*argv[:-1], str(tmp_path / "x.npz")]) == 2
    assert_one_line_error(capsys.readouterr().err, ERR, "substeps", "1000000", "smaller dt")


def test_a_long_simulation_says_its_time_up_front_and_reports_progress(
    tmp_path, capsys, monkeypatch
):
    """With the progress period set to 0 every chunk after the timed one prints a line: the
    expected time first, then steps done; the trajectory is the one simulate() records in one
    call, bit for bit (chunks of a second's worth of steps change nothing)."""
    monkeypatch.setattr(cli, "_PROGRESS_EVERY_S", 0.0)
    out = tmp_path / "traj.npz"
    assert cli.main(["simulate", str(SCENE), "--steps", "300", "--out", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("simulating 300 steps: about ")
    progress = [line for line in lines if line.startswith("  ") and "steps, about" in line]
    for line in progress:
        done = int(line.split("/")[0])
        assert 17 <= done < 300
    want = simulate(load_scene(SCENE).build_world(1), 300)
    with np.load(out) as got:
        for key, value in want.items():
            assert np.array_equal(got[key], value if key == "t" else value[:, 0]), key
