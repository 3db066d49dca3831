"""The agents' command lines share one habit: a mistake is one stderr line, exit status 2."""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path
from typing import Any, NoReturn


class OneLineParser(argparse.ArgumentParser):
    """``argparse`` whose errors are one line (``agents.train: error: ...``), not a usage block."""

    def parse_known_args(self, args: Any = None, namespace: Any = None) -> Any:
        """As argparse's, but a flag given ``=--`` is refused (argparse would hand the command
        an empty list)."""
        argv = list(sys.argv[1:] if args is None else args)
        for arg in argv:
            flag, eq, value = str(arg).partition("=")
            if flag.startswith("--") and eq and value == "--":
                self.error(f"argument {flag}: expected a value, got '--'")
        return super().parse_known_args(argv, namespace)

    def error(self, message: str) -> NoReturn:
        name = self.prog.removeprefix("python -m ")
        print(f"{name}: error: {message} (see {self.prog} --help)", file=sys.stderr)
        raise SystemExit(2)


def integer(text: str) -> int:
    """An integer flag value, also in exponent notation (``1e5``, ``2.5e3``)."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        x = float(text)
    except ValueError:
        x = math.nan
    if not (math.isfinite(x) and x.is_integer()):
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}")
    return int(x)


def positive_integer(text: str) -> int:
    """An integer flag value >= 1 (exponent notation allowed, as :func:`integer`)."""
    n = integer(text)
    if n < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}")
    return n


def positive_number(text: str) -> float:
    """A finite number > 0."""
    try:
        x = float(text)
    except ValueError:
        x = math.nan
    if not (math.isfinite(x) and x > 0):
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}")
    return x


def path(text: str) -> Path:
    """A path flag value; an empty one (an unset shell variable) would mean the current folder,
    so it is refused."""
    if not text.strip():
        raise argparse.ArgumentTypeError(
            "empty path; give a folder or file name (an unset variable?)"
        )
    return Path(text)


def folder_problem(folder: Path) -> str | None:
    """Why ``folder`` cannot hold what a command writes (it, or the nearest existing folder
    above it, is a file or not writable), or ``None``."""
    for candidate in (folder, *folder.resolve().parents):
        if not candidate.exists():
            continue
        if not candidate.is_dir():
            return f"{candidate} is a file, not a folder"
        if not os.access(candidate, os.W_OK | os.X_OK):
            return f"{candidate} is not writable"
        return None
    return None
