"""Issue 35, unclear errors: each names its cause. /dev/zero or a pipe as a scene or a config
is "not a regular file" (not "out of memory", not a hang); a quoted number gets one message
wherever it is; a missing or dangling --out folder names the path."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from reliability_helpers import assert_one_line_error, write_config

from agents.train import main as train_main
from rigid_env.cli import main as cli_main
from rigid_env.config_files import MAX_FILE_BYTES
from rigid_env.scene import SceneError, load_scene

SCENE = Path(__file__).resolve().parents[2] / "configs" / "scenes" / "detumble.yaml"


def _fifo(tmp_path: Path) -> Path:
    path = tmp_path / "pipe.yaml"
    os.mkfifo(path)
    return path


@pytest.mark.parametrize("source", ["/dev/zero", "fifo"])
def test_a_device_or_pipe_as_a_scene_is_not_a_regular_file(tmp_path, capsys, source):
    path = _fifo(tmp_path) if source == "fifo" else Path(source)
    argv = ["simulate", str(path), "--steps", "2", "--out", str(tmp_path / "t.npz")]
    assert cli_main(argv) == 2
    assert_one_line_error(capsys.readouterr().err, f"rigid-env: error: {path}: ",
                          "not a regular file")  # fmt: skip


@pytest.mark.parametrize("source", ["/dev/zero", "fifo"])
def test_a_device_or_pipe_as_a_training_config_is_not_a_regular_file(tmp_path, capsys, source):
    path = _fifo(tmp_path) if source == "fifo" else Path(source)
    assert train_main([str(path), "--runs-dir", str(tmp_path / "runs")]) == 2
    line = assert_one_line_error(capsys.readouterr().err, "agents.train: error:",
                                 "not a regular file")  # fmt: skip
    assert "memory" not in line


def test_a_huge_file_is_refused_before_reading_it(tmp_path):
    path = tmp_path / "big.yaml"
    with open(path, "wb") as f:
        f.truncate(MAX_FILE_BYTES + 1)  # sparse: no disk used
    with pytest.raises(SceneError, match=r"is larger than 16 MiB"):
        load_scene(path)


@pytest.mark.parametrize(
    ("field", "value", "written"),
    [
        ("effects.gravity_gradient.mu", "3.986e14", "3.986e+14"),
        ("rtol", "1.0e-6", "1.0e-6"),
        ("dt", "0.02", "0.02"),
    ],
)
def test_a_quoted_number_gets_one_message_wherever_it_is(field, value, written):
    """A quoted "3.986e14" was blamed on YAML 1.1 while a quoted rtol "1.0e-6" was accepted:
    every quoted number is refused alike, naming the field and the number to write."""
    data = {
        "name": "q",
        "body": {"mass": 1.0, "inertia": [1.0, 2.0, 3.0]},
        "integrator": "dop853",
        "effects": {"gravity_gradient": {"mu": 3.986e14, "center": [0, 0, -7e6]}},
    }
    node, *path = field.split(".")
    target = data
    for key in [node, *path][:-1]:
        target = target[key]
    target[field.split(".")[-1]] = value
    with pytest.raises(SceneError) as info:
        load_scene(data)
    msg = str(info.value)
    assert msg.startswith(f"<scene dict>: {field}: expected a number"), msg
    assert f"got the string '{value}'; write the number without quotes: " in msg
    assert float(msg.rsplit(": ", 1)[1]) == float(written)
    assert "YAML 1.1" not in msg


def test_a_dangling_out_folder_names_the_path(tmp_path, capsys):
    """--out under a dangling link: the message names the link and its missing target, not a
    bare [Errno 17] "File exists"."""
    (tmp_path / "gone").symlink_to(tmp_path / "nowhere")
    out = tmp_path / "gone" / "sub" / "t.npz"
    assert cli_main(["simulate", str(SCENE), "--steps", "2", "--out", str(out)]) == 2
    assert_one_line_error(capsys.readouterr().err, "rigid-env: error: --out:", "gone",
                          "is a link to", "which does not exist")  # fmt: skip


def test_a_dangling_bench_out_names_the_path(tmp_path, capsys):
    (tmp_path / "gone").symlink_to(tmp_path / "nowhere")
    argv = ["bench", "learn", "--out", str(tmp_path / "gone" / "b"), "--tasks", "detumble",
            "--seeds", "0", "--previous-seeds"]  # fmt: skip
    assert cli_main(argv) == 2
    assert_one_line_error(capsys.readouterr().err, "rigid-env: error: --out: cannot create",
                          "gone", "which does not exist")  # fmt: skip


def test_a_config_with_a_quoted_rate_is_one_line(tmp_path, capsys):
    config = write_config(tmp_path, hyperparams={"learning_rate": "1.0e-4", "n_steps": 64})
    assert train_main([str(config), "--runs-dir", str(tmp_path / "runs")]) == 2
    assert_one_line_error(capsys.readouterr().err, "agents.train: error:", "without quotes")
