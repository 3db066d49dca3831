"""No inline code span of the manual or the README is cut by a line that Markdown reads as the
start of a list or a heading (a span's text wrapped onto a line starting with ``+ ``, ``- ``,
``* ``, ``1. `` or ``#``): the span would swallow the text up to the next backtick and the line
render as a bullet (docs/wheels.md's ``h_k' = motor + friction`` did)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = [*sorted((ROOT / "docs").rglob("*.md")), ROOT / "README.md"]
BLOCK_START = re.compile(r"^\s{0,3}([-+*]\s|\d+[.)]\s|#{1,6}\s|>)")


def _cut_spans(text: str) -> list[int]:
    """Line numbers (1-based) that start a block while a code span of their paragraph is open."""
    cut, open_span, fenced = [], False, False
    for number, line in enumerate(text.splitlines(), 1):
        if line.lstrip().startswith(("```", "~~~")):
            fenced, open_span = not fenced, False
            continue
        if fenced:
            continue
        if not line.strip():
            open_span = False  # a blank line ends the paragraph (and an unclosed span)
            continue
        if open_span and BLOCK_START.match(line):
            cut.append(number)
        runs = re.findall(r"`+", line)
        if sum(1 for r in runs if len(r) == 1) % 2:
            open_span = not open_span
    return cut


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(ROOT)) for p in PAGES])
def test_no_code_span_is_cut_by_a_block_start(page):
    assert _cut_spans(page.read_text()) == []


def test_the_check_finds_the_wheels_page_as_it_was():
    broken = "each wheel `h_k' = motor\n+ friction`: a gyrostat\n"
    assert _cut_spans(broken) == [2]
    assert _cut_spans("each wheel\n`h_k' = motor + friction`: a gyrostat\n") == []
