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


def _code_spans(path: Path) -> list[str]:
    text = re.sub(r"```.*?```", "", path.read_text(), flags=re.S)
    return re.findall(r"`([^`\n]+)`", text)


def test_files_and_names_the_manual_mentions_exist():
    """A path of the repository (``rigid_env/core/effects.py``, ``configs/agents/x.yaml``) or a
    dotted name (``rigid_env.core.integrators.INTEGRATORS``) in a page's code spans exists, so
    that the checklists of docs/extending/ and every pointer into the code follow the code."""
    import importlib

    for page in pages():
        for span in _code_spans(page):
            for word in span.split():
                word = word.strip("(),:;'\"")
                if re.fullmatch(
                    r"(rigid_env|agents|configs|docs|tests)/[\w/.-]+\.(py|yaml|md)", word
                ):
                    if "<" not in word:
                        assert (ROOT / word).exists(), f"{page.relative_to(ROOT)}: {word}"
                elif re.fullmatch(r"rigid_env(\.\w+)+", word):
                    parts = word.split(".")
                    for k in range(len(parts), 0, -1):  # the longest importable module prefix
                        try:
                            obj = importlib.import_module(".".join(parts[:k]))
                        except ModuleNotFoundError:
                            continue
                        for attr in parts[k:]:
                            assert hasattr(obj, attr), f"{page.relative_to(ROOT)}: {word}"
                            obj = getattr(obj, attr)
                        break
                    else:
                        raise AssertionError(f"{page.relative_to(ROOT)}: {word}")


def test_each_checklist_names_what_its_files_define():
    """docs/extending/: every identifier a checklist puts in code (``IntegratorInfo``,
    ``accelerations``, ``RARE``, ``PD_LAWS``, ...) occurs in a file the page names, so a
    renamed function or table shows up here, not in a reader's failed attempt."""
    for page in sorted((DOCS / "extending").glob("*.md")):
        if page.name == "index.md":  # a map of the package, not a checklist
            continue
        spans = _code_spans(page)
        files = {w for s in spans for w in s.split() if re.fullmatch(r"[\w/]+\.py", w)}
        if page.name == "task.md":  # its example comes from the README, whose imports name these
            files |= {"rigid_env/envs/batch.py", "rigid_env/envs/environments.py"}
        source = "\n".join((ROOT / f).read_text() for f in files if (ROOT / f).is_file())
        for span in spans:
            name = span.split("(")[0].split("=")[0].strip()
            if re.fullmatch(r"[A-Za-z_]\w*", name) and ("_" in name or name[0].isupper()):
                placeholder = "name" in name.split("_")  # _name_range: the new method's
                if name.startswith("test_") or len(name) < 4 or placeholder:
                    continue
                assert re.search(rf"\b{name}\b", source), f"{page.name}: {name} not in {files}"
