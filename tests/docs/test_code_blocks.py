"""Every code block of the README and the manual runs: Python blocks execute (from a file of
their own, as a user would keep them; Numba caches kernels by file) and print what the page
shows; shell blocks name commands that exist and whose arguments their parsers accept."""

from __future__ import annotations

import contextlib
import io
import re
import runpy
import shlex
import sys
from pathlib import Path

import pytest
from blocks import ROOT, Block, all_blocks

sys.path.insert(0, str(ROOT / "docs" / "_ext"))
import rigid_docs

PYTHON = all_blocks("python")
SHELL = all_blocks("bash")


def _same(got: str, want: str) -> None:
    """Printed text against the page's: token by token, a number to the digits the page shows
    (half a unit of its last digit), anything else exactly."""
    g, w = got.split(), want.split()
    assert len(g) == len(w), (got, want)
    for a, b in zip(g, w, strict=True):
        try:
            x, y = float(a.strip(",()[]")), float(b.strip(",()[]"))
        except ValueError:
            assert a == b, (got, want)
            continue
        digits = len(b.strip(",()[]").split(".")[1]) if "." in b else 0
        assert x == pytest.approx(y, abs=0.5 * 10.0**-digits), (got, want)


def _comment_output(code: str) -> str | None:
    """``print(...)  # expected`` on a block's last print (the README's style)."""
    prints = re.findall(r"^print\(.*\)\s+#\s*(.+)$", code, re.M)
    return prints[-1] if prints else None


@pytest.mark.parametrize("block", PYTHON, ids=[b.id for b in PYTHON])
def test_python_block_runs_and_prints_what_the_page_shows(block: Block, tmp_path: Path) -> None:
    if block.skip:
        pytest.skip(block.skip)
    name = re.sub(r"\W", "_", block.id)
    path = tmp_path / f"{name}.py"
    path.write_text(block.code.replace('"StopZ-v0"', f'"{name}-v0"'))
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        runpy.run_path(str(path), run_name="__main__")
    if block.output is not None:  # the page shows it as printed: exactly what prints
        assert out.getvalue().split() == block.output.split(), (out.getvalue(), block.output)
    elif (want := _comment_output(block.code)) is not None:  # a comment: to its digits
        _same(out.getvalue(), want)


# ---- shell blocks ---------------------------------------------------------------------------

_OPTIONAL = (ROOT / "pyproject.toml").read_text().split("[project.optional-dependencies]")[1]
EXTRAS = set(re.findall(r"^(\w+) = \[", _OPTIONAL.split("\n[")[0], re.M))
PARSERS = None


def _parsers():
    global PARSERS
    if PARSERS is None:
        PARSERS = rigid_docs.commands()
    return PARSERS


def _commands(code: str) -> list[list[str]]:
    """Each simple command of a block, split at ``&&``, ``||``, ``;``, ``&`` and ``|``
    (comments dropped)."""
    out: list[list[str]] = []
    for line in code.splitlines():
        lexer = shlex.shlex(line, posix=True, punctuation_chars=";&|")
        lexer.whitespace_split = True
        lexer.commenters = "#"
        words: list[str] = []
        for token in lexer:
            if token in ("&&", "||", ";", "&", "|", ";;"):
                out.append(words)
                words = []
            else:
                words.append(token)
        out.append(words)
    return [w for w in out if w]


def _check(words: list[str]) -> str | None:
    """Check one command; returns what was checked (None: a command we do not check)."""
    while words and re.match(r"^[A-Z_]+=", words[0]):  # VAR=value prefix, $(...) included
        value = words.pop(0)
        while "$(" in value and not value.endswith(")") and words:
            value = words.pop(0)
    if words[:2] == ["taskset", "-c"]:
        words = words[3:]
    if not words:
        return None
    prog = words[0].removeprefix(".venv/bin/")
    if prog == "rigid-env":
        rest = words[1:]
        if rest[:1] == ["bench"]:
            name, rest = f"rigid-env bench {rest[1]}", rest[2:]
        elif rest:
            name, rest = f"rigid-env {rest[0]}", rest[1:]
        else:
            name = "rigid-env"
        _parse(name, rest)
        return name
    if prog in ("python", "python3") and words[1:2] == ["-m"]:
        module = words[2].removeprefix("rigid_env.")
        if module.startswith("agents."):
            _parse(f"python -m {module}", words[3:])
            return module
        if module in ("pytest", "sphinx", "venv"):
            return module
        raise AssertionError(f"unknown module {words[2]}")
    if prog in ("python", "python3") and words[1] == "-c":
        compile(words[2], "<python -c>", "exec")
        return "python -c"
    if prog in ("python", "python3") and words[1].endswith(".py"):
        assert (ROOT / words[1]).is_file(), words[1]
        return words[1]
    if prog == "pip" and "install" in words:
        for extra in re.findall(r"\[([\w,]+)\]", " ".join(words)):
            assert set(extra.split(",")) <= EXTRAS, extra
        return "pip"
    return None


def _parse(name: str, args: list[str]) -> None:
    parsers = _parsers()
    assert name in parsers, f"{name}: no such command"
    try:
        parsers[name].parse_args(args)
    except SystemExit as exc:
        raise AssertionError(f"{name} {' '.join(args)}: refused by its parser") from exc
    for arg in args:  # files of the repository a command names exist
        if re.match(r"^(configs|agents|docs)/[\w/.-]+\.(yaml|zip|py)$", arg):
            assert (ROOT / arg).is_file(), arg


@pytest.mark.parametrize("block", SHELL, ids=[b.id for b in SHELL])
def test_shell_block_names_commands_that_exist_and_parse(block: Block) -> None:
    if block.skip:
        pytest.skip(block.skip)
    checked = [c for c in map(_check, _commands(block.code)) if c]
    assert checked, f"{block.id}: no command this test knows; mark it skip with a reason"


YAML = [b for b in all_blocks("yaml") if b.code.lstrip().startswith("name:")]


@pytest.mark.parametrize("block", YAML, ids=[b.id for b in YAML])
def test_a_whole_scene_shown_is_a_valid_scene(block: Block, tmp_path: Path) -> None:
    """A YAML block that is a whole scene (it starts with ``name:``) loads, and builds a world."""
    from rigid_env.scene import load_scene

    path = tmp_path / "scene.yaml"
    path.write_text(block.code)
    load_scene(path).build_world()
