"""Getting started's SubprocVecEnv note: the id that names its module works in SB3's worker
processes, which start without our import (forkserver or spawn)."""

from __future__ import annotations

import subprocess
import sys

import pytest
from blocks import ROOT, all_blocks


@pytest.mark.slow
def test_the_subproc_block_runs_in_a_fresh_interpreter(tmp_path):
    block = next(b for b in all_blocks("python") if "SubprocVecEnv" in b.code)
    script = tmp_path / "subproc.py"
    script.write_text(block.code)
    proc = subprocess.run(
        [sys.executable, str(script)], cwd=ROOT, capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["(2,", "10)"]
