"""Helpers of the reliability cases (issue 16, "Nothing lost, nothing silent").

Every case ends in one of three ways: a one-line error (non-zero exit, one stderr line naming the
field or file and the fix, no traceback), a sensible acceptance, or the documented behaviour.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).resolve().parents[2]

#: A PPO run small enough to train in about a second: 128 env steps a rollout, an evaluation
#: (one 400-step episode) every 256 steps, a checkpoint every 256 steps.
TINY: dict[str, Any] = {
    "env_id": "RigidEnv/Detumble-v0",
    "algo": "ppo",
    "total_timesteps": 512,
    "n_envs": 2,
    "policy_kwargs": {"net_arch": [16, 16]},
    "hyperparams": {"n_steps": 64, "batch_size": 64, "n_epochs": 1},
    "eval": {"freq": 256, "episodes": 1, "seed": 99},
    "checkpoint_freq": 256,
}


def write_config(folder: Path, name: str = "tiny.yaml", **changes: Any) -> Path:
    """:data:`TINY` with top-level ``changes``, written as YAML; returns its path."""
    path = folder / name
    path.write_text(yaml.safe_dump({**TINY, **changes}, sort_keys=False))
    return path


def assert_one_line_error(err: str, prefix: str, *words: str) -> str:
    """``err`` is exactly one line, starts with ``prefix``, has no traceback and names
    every one of ``words``; returns the line."""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(prefix), err
    assert "Traceback" not in err
    for word in words:
        assert word in lines[0], (word, lines[0])
    return lines[0]


def run_module(*args: str, timeout: float = 240) -> subprocess.CompletedProcess[str]:
    """``python -m <args>`` from the repository root, output captured."""
    return subprocess.run(
        [sys.executable, "-m", *args], cwd=ROOT, capture_output=True, text=True, timeout=timeout
    )
