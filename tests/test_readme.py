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
