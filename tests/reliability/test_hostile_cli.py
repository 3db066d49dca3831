"""Every entry point, run as a user runs it (a subprocess), with input a hostile or careless user
gives (issue 28): exit status != 0, exactly one stderr line that names the flag or file and the
fix, no traceback, and nothing written where it should not be.

Each case starts an interpreter (a few seconds with torch and Numba imported), so the module is
marked slow; ``pytest -m "not slow"`` leaves it out, CI runs it.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from reliability_helpers import ROOT, TINY, assert_one_line_error

pytestmark = pytest.mark.slow

SCENE = str(ROOT / "configs" / "scenes" / "asymmetric_spin.yaml")
PRETRAINED = str(ROOT / "agents" / "pretrained" / "ppo_detumble.zip")


def _run(
    args: list[str], cwd: Path, address_space: int | None = None
) -> subprocess.CompletedProcess[str]:
    """``args`` (``rigid-env ...`` or ``python -m ...``) in ``cwd``, optionally under
    ``ulimit -v`` (bytes)."""

    def limit() -> None:
        if address_space is not None:
            resource.setrlimit(resource.RLIMIT_AS, (address_space, address_space))

    if args[0] == "rigid-env":
        args = [sys.executable, "-m", "rigid_env.cli", *args[1:]]
    else:
        args = [sys.executable, *args]
    env = {
        **os.environ,
        "PYTHONPATH": str(ROOT),
        "SDL_VIDEODRIVER": "dummy",
        "MPLBACKEND": "Agg",
        "RAY_ADDRESS": "",
    }
    return subprocess.run(
        args, cwd=cwd, capture_output=True, text=True, timeout=300, env=env, preexec_fn=limit
    )


@pytest.fixture
def place(tmp_path: Path) -> Path:
    """An empty working folder with a file named ``afile`` and a tiny training config."""
    (tmp_path / "afile").write_text("not a folder\n")
    (tmp_path / "tiny.yaml").write_text(yaml.safe_dump(TINY, sort_keys=False))
    return tmp_path


#: (command line, prefix of the one stderr line, words it must name). ``{tmp}`` is the
#: working folder of the case.
CASES = [
    # rigid-env demo (section 5)
    (["rigid-env", "demo", "--episodes", "1e9"], "rigid-env: error: --episodes", ["1000"]),
    (["rigid-env", "demo", "--episodes", str(10**20)], "rigid-env: error: --episodes", ["1000"]),
    (["rigid-env", "demo", "--out", ""], "rigid-env: error: --out: empty path", []),
    (["rigid-env", "demo", "--out="], "rigid-env: error: --out: empty path", []),
    (["rigid-env", "demo", "--out", "{tmp}/afile"], "rigid-env: error: --out", ["is a file"]),
    (
        ["rigid-env", "demo", "--task", "RigidEnv/Reorient-v0"],
        "rigid-env: error: --task",
        ["RigidEnv/Reorient-v1"],
    ),
    (["rigid-env", "demo", "--task", "Pendulum-v1"], "rigid-env: error: --task", ["Detumble"]),
    # rigid-env simulate and bench
    (["rigid-env", "simulate", SCENE, "--steps", "10", "--out", ""], "rigid-env: error: --out", []),
    (
        ["rigid-env", "bench", "accuracy", "--quick", "--out", " "],
        "rigid-env: error: --out: empty path",
        [],
    ),
    # python -m agents.train (section 2)
    (
        ["-m", "agents.train", "{tmp}/tiny.yaml", "--runs-dir", "{tmp}/afile"],
        "agents.train: error: ",
        ["--runs-dir", "is a file"],
    ),
    (
        ["-m", "agents.train", "{tmp}/tiny.yaml", "--runs-dir", "{tmp}/afile/runs"],
        "agents.train: error: ",
        ["--runs-dir", "afile is a file"],
    ),
    (
        ["-m", "agents.train", "{tmp}/tiny.yaml", "--runs-dir", ""],
        "agents.train: error: ",
        ["empty"],
    ),
    (
        ["-m", "agents.train", "{tmp}/tiny.yaml", "--runs-dir", "{tmp}/runs", "--resume"],
        "agents.train: error: ",
        ["no run to resume", "--resume-or-start"],
    ),
    (
        ["-m", "agents.train", "{tmp}/tiny.yaml", "--resume", "--resume-or-start"],
        "agents.train: error: ",
        ["not allowed"],
    ),
    (
        ["-m", "agents.train", "{tmp}/tiny.yaml", "--n-envs", "1e9"],
        "agents.train: error: ",
        ["n_envs", "65536"],
    ),
    # python -m agents.evaluate (section 5)
    (
        [
            "-m", "agents.evaluate", PRETRAINED, "--env", "RigidEnv/Detumble-v0",
            "--episodes", "2", "--env-kwargs", "render_mode=human",
        ],
        "agents.evaluate: error: --env-kwargs",
        ["render_mode", "--video"],
    ),
    (
        [
            "-m", "agents.evaluate", "none", "--env", "RigidEnv/Detumble-v0", "--video", "",
        ],
        "agents.evaluate: error: ",
        ["--video", "empty"],
    ),
    # python -m agents.sweep and agents.baselines
    (
        ["-m", "agents.sweep", str(ROOT / "configs/sweeps/detumble_seeds.yaml"), "--num-cpus", "0"],
        "agents.sweep: error: ",
        ["--num-cpus", ">= 1"],
    ),
    (
        [
            "-m", "agents.sweep", str(ROOT / "configs/sweeps/detumble_seeds.yaml"),
            "--storage", "{tmp}/afile",
        ],
        "agents.sweep: error: ",
        ["storage", "is a file"],
    ),
    (
        ["-m", "agents.baselines", "{tmp}", "--out", "{tmp}/afile"],
        "agents.baselines: error: --out",
        ["is a file"],
    ),
]  # fmt: skip


@pytest.mark.parametrize(("args", "prefix", "words"), CASES, ids=lambda v: str(v)[:60])
def test_one_line_and_nothing_written(place: Path, args: list[str], prefix: str, words: list[str]):
    before = sorted(p.relative_to(place) for p in place.rglob("*"))
    proc = _run([a.replace("{tmp}", str(place)) for a in args], cwd=place)
    assert proc.returncode != 0, proc.stdout
    assert_one_line_error(proc.stderr, prefix, *words)
    assert sorted(p.relative_to(place) for p in place.rglob("*")) == before  # nothing written


def test_duplicate_keys_in_each_file_kind_from_the_command_line(place: Path):
    """Issue 28's example, `{mass: 1.0, mass: 2.0}`, refused by the three commands that read
    the three kinds of file."""
    scene = place / "dup_scene.yaml"
    text = Path(SCENE).read_text()
    block = text[text.index("body:\n") : text.index("initial:")]
    scene.write_text(text.replace(block, "body: {mass: 1.0, mass: 2.0, shape: {box: [1, 1, 1]}}\n"))
    proc = _run(["rigid-env", "simulate", str(scene), "--steps", "5", "--out", "t.npz"], place)
    assert proc.returncode == 2
    assert_one_line_error(proc.stderr, "rigid-env: error: ", "'mass' given twice", "keep one")

    config = place / "dup.yaml"
    config.write_text(
        (place / "tiny.yaml").read_text() + "normalize: {obs: true, reward: true, obs: false}\n"
    )
    proc = _run(["-m", "agents.train", str(config), "--runs-dir", str(place / "runs")], place)
    assert proc.returncode == 2
    assert_one_line_error(proc.stderr, "agents.train: error: ", "'obs' given twice", "dup.yaml")
    assert not (place / "runs").exists()

    sweep = place / "dup_sweep.yaml"
    sweep.write_text(f"{{name: s, base: {config}, name: t}}\n")
    proc = _run(["-m", "agents.sweep", str(sweep)], place)
    assert proc.returncode == 2
    assert_one_line_error(proc.stderr, "agents.sweep: error: ", "'name' given twice")


def test_simulate_sizes_against_the_address_space_limit(place: Path):
    """Under `ulimit -v` of 900 MB, 1e7 steps (1.7 GB of trajectory) are refused up front
    with the most that fits (there was free RAM, so the old check let it through to a
    MemoryError traceback); nothing is written."""
    proc = _run(
        ["rigid-env", "simulate", SCENE, "--steps", "1e7", "--out", "t.npz"],
        place,
        address_space=900 * 2**20,
    )
    assert proc.returncode == 2
    line = assert_one_line_error(proc.stderr, "rigid-env: error: --steps", "1.7 GB", "ulimit -v")
    assert "give at most --steps" in line or "raise the limit" in line
    assert not (place / "t.npz").exists()


def test_evaluate_with_more_episodes_than_memory_holds(place: Path):
    """All episodes of an evaluation run at once: 1e9 of them under a 3 GB address space
    end in one line, not a MemoryError traceback."""
    proc = _run(
        ["-m", "agents.evaluate", "none", "--env", "RigidEnv/Detumble-v0", "--episodes", "1e9"],
        place,
        address_space=3 * 2**30,
    )
    assert proc.returncode == 2
    assert_one_line_error(proc.stderr, "agents.evaluate: error: --episodes", "give fewer")
