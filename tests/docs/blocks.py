"""The fenced code blocks of the README and the manual's pages, as the tests read them.

A block is ```` ```lang ```` to ```` ``` ````. A ```` ```python ```` block runs; the
```` ```output ```` block right after it (blank lines between allowed) is what it prints. An
HTML comment ``<!-- docs-test: skip (why) -->`` on the line before a block leaves it out (the
reason is required, and names the test that runs it instead where one does).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
#: Folders of docs/ that hold no page of the manual (build output, generated text, data).
NOT_PAGES = ("_build", "_generated", "results", "figures")
SKIP = re.compile(r"<!--\s*docs-test:\s*skip\s*\((.+)\)\s*-->")


@dataclass(frozen=True)
class Block:
    path: Path
    line: int  # 1-based line of the opening fence
    lang: str
    code: str
    output: str | None  # the ```output block after a python block
    skip: str | None  # the reason given in a skip comment

    @property
    def id(self) -> str:
        return f"{self.path.relative_to(ROOT)}:{self.line}"


def pages() -> list[Path]:
    """README.md and every Markdown page of the manual."""
    found = sorted(
        p
        for p in DOCS.rglob("*.md")
        if not any(part in NOT_PAGES for part in p.relative_to(DOCS).parts)
    )
    return [ROOT / "README.md", *found]


def blocks(path: Path) -> list[Block]:
    lines = path.read_text().splitlines()
    raw: list[tuple[int, str, str, str | None]] = []
    i = 0
    while i < len(lines):
        m = re.match(r"^(`{3,})(\{[\w-]+\}|[\w-]*)", lines[i])
        if not m:
            i += 1
            continue
        fence, lang, start = m.group(1), m.group(2), i
        j = i + 1
        while j < len(lines) and lines[j].strip() != fence:
            j += 1
        if lang.startswith("{"):  # a MyST directive (include, toctree, ...): no code
            i = j + 1
            continue
        before = next((lines[k] for k in range(start - 1, -1, -1) if lines[k].strip()), "")
        skip = SKIP.search(before)
        raw.append(
            (start + 1, lang, "\n".join(lines[start + 1 : j]) + "\n", skip and skip.group(1))
        )
        i = j + 1
    out: list[Block] = []
    for k, (line, lang, code, skip) in enumerate(raw):
        if lang == "output":
            continue
        output = None
        if lang == "python" and k + 1 < len(raw) and raw[k + 1][1] == "output":
            between = lines[line - 1 + code.count("\n") + 1 : raw[k + 1][0] - 1]
            if not any(s.strip() for s in between[1:]):
                output = raw[k + 1][2]
        out.append(Block(path, line, lang, code, output, skip))
    return out


def all_blocks(lang: str) -> list[Block]:
    return [b for p in pages() for b in blocks(p) if b.lang == lang]
