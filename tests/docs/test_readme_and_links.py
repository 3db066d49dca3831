"""The README is a front door: at most 200 lines, its demo table the committed results file,
its links into the manual resolving to pages the manual builds."""

from __future__ import annotations

import re
from pathlib import Path

from blocks import DOCS, NOT_PAGES, ROOT, pages

README = ROOT / "README.md"
DEMO_RESULTS = DOCS / "results" / "demo" / "results.md"
MAX_LINES = 200


def table_lines(text: str) -> list[str]:
    return [line for line in text.splitlines() if line.startswith("|")]


def test_readme_is_at_most_200_lines():
    assert len(README.read_text().splitlines()) <= MAX_LINES


def test_readme_demo_table_is_the_committed_demo_results():
    """The README's table between its markers equals the table of ``rigid-env demo``'s
    results.md as committed (the slow demo test compares a fresh run to that file)."""
    text = README.read_text()
    start, end = text.index("<!-- demo-table:start -->"), text.index("<!-- demo-table:end -->")
    assert table_lines(text[start:end]) == table_lines(DEMO_RESULTS.read_text())


def test_readme_has_no_issue_or_commit_numbers():
    text = README.read_text()
    commit = r"\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*\d)[0-9a-f]{7,40}\b"
    assert not re.search(rf"\bissue \d+|#\d+\b|{commit}", text), "history belongs in git"


def _links(path: Path) -> list[str]:
    text = re.sub(r"```.*?```", "", path.read_text(), flags=re.S)
    return re.findall(r"\]\(([^)\s]+)\)", text)


def test_every_relative_link_resolves():
    """Every relative link of the README and the manual's pages names a file that exists;
    one into docs/ names a page the manual builds or a file it ships (a figure, a result)."""
    for page in pages():
        for link in _links(page):
            if re.match(r"^[a-z]+://|^#|^mailto:", link):
                continue
            target = (page.parent / link.split("#")[0]).resolve()
            assert target.exists(), f"{page.relative_to(ROOT)}: {link} does not exist"
            if page == README and target.suffix == ".md" and DOCS in target.parents:
                rel = target.relative_to(DOCS)
                built = rel.parts[0] not in NOT_PAGES or rel.parts[0] in ("results",)
                assert built, f"README: {link} is not a page of the manual"
