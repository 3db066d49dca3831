"""The README's ten-line example runs and prints what its comment says."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def test_ten_line_example_prints_its_comment() -> None:
    text = README.read_text()
    section = text[text.index("## Ten lines") :]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    expected = re.search(r"print\(.*\)\s+#\s*(.+)", code).group(1).split()
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "README.md", "exec"), {})
    got = out.getvalue().split()
    assert got[0] == expected[0]
    for g, e in zip(got[1:], expected[1:], strict=True):
        digits = len(e.split(".")[1]) if "." in e else 0
        assert float(g) == pytest.approx(float(e), abs=0.5 * 10.0**-digits), (got, expected)


def test_ten_line_example_counts_the_ids_it_registers() -> None:
    """Its comment says how many ids ``import rigid_env`` registers: as many as there are."""
    import rigid_env

    line = next(x for x in README.read_text().splitlines() if x.startswith("import rigid_env  #"))
    count = int(re.search(r"registers the (\d+) RigidEnv ids", line).group(1))
    assert count == len(rigid_env.envs.ALL_ENV_IDS)
