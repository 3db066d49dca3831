"""A ratchet: the files outside the actuator modules (``rigid_env/core/actuator.py``,
``rigid_env/core/actuators/``) that still test an actuator's class (``isinstance(e,
Thrusters)``) or name an actuator (``"magnetorquers"``, ``.reaction_wheels``). What the layers
above need of an actuator comes from its declaration (:mod:`rigid_env.core.actuator`: ``where``,
``listed``, ``fuel_per_unit``, ...). The lists may only shrink: a file that stops doing it leaves
its list, and no file joins one."""

from __future__ import annotations

import re
from pathlib import Path

from rigid_env.core.actuator import actuators

ROOT = Path(__file__).resolve().parents[2]
OWN = ("rigid_env/core/actuator.py", "rigid_env/core/actuators/")
"""The actuator modules, where the classes and names belong."""

TESTS_CLASS: set[str] = set()
"""Files that still ``isinstance`` an actuator class."""
NAMES_ONE = {
    # a variant's registered kwargs: the env keyword ``thrusters="realistic"`` that the
    # thrusters' presets declare (registering imports no core to look it up)
    "rigid_env/envs/__init__.py",
}
"""Files that still name an actuator (a string or an attribute of its scene key)."""


def _files() -> list[Path]:
    out = []
    for folder in ("rigid_env", "agents"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            if not rel.startswith(OWN):
                out.append(path)
    return out


def _classes() -> str:
    names = {a.spec.__name__ for a in actuators()} | {"LinearActuator"}
    return "|".join(sorted(names))


def test_no_new_file_tests_an_actuator_class() -> None:
    pattern = re.compile(rf"isinstance\([^()]*\b({_classes()})\b")
    found = {p.relative_to(ROOT).as_posix() for p in _files() if pattern.search(p.read_text())}
    assert found <= TESTS_CLASS, (
        f"{sorted(found - TESTS_CLASS)} test an actuator's class: ask its declaration instead "
        "(rigid_env.core.actuator.where, listed)"
    )


def test_no_new_file_names_an_actuator() -> None:
    names = "|".join(a.name for a in actuators())
    pattern = re.compile(rf"""["']({names})["']|(?<!core)\.({names})\b""")  # not a module
    found = {p.relative_to(ROOT).as_posix() for p in _files() if pattern.search(p.read_text())}
    assert found <= NAMES_ONE, (
        f"{sorted(found - NAMES_ONE)} name an actuator: ask its declaration instead "
        "(rigid_env.core.actuator)"
    )
