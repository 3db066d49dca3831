"""The suite's Hypothesis settings: the same examples on every run (``derandomize``), so that a
CI run is reproducible and a red one means a change, not a new draw. The long profiles of the
property files (``HYPOTHESIS_PROFILE=long``) draw afresh each time: that is where to hunt.

And the order of the files: those whose kernels take longest to compile on a cold cache run
first (:data:`FIRST`), so that the two workers, which take whole files in the order given
(``--dist loadfile --no-loadscope-reorder``), end together rather than one of them compiling
alone at the end (the longest first: the classic rule for balancing jobs of known length)."""

from __future__ import annotations

import pytest
from hypothesis import settings

settings.register_profile("suite", derandomize=True, database=None)
settings.load_profile("suite")

FIRST = (
    "core/test_effects_outside.py",  # 290 s: every integrator compiled in a process of its own
    "core/test_actuators_generic.py",  # 460 s of compile, integrators in reverse order
    "core/test_effects_generic.py",  # 310 s, loading most of what the file above compiles
    "core/test_world.py",  # 340 s: each integrator's range and threads entries
    "core/test_wheel_laws.py",  # 200 s
    "envs/test_idle_draws.py",  # 150 s
    "core/test_couple.py",  # 60 s: an actuator registered from outside, in a process of its own
)
"""Test files by their compile seconds on a cold cache, longest first (measured on a 2-core
machine, ``NUMBA_CACHE_DIR`` empty); the other files follow in their own order."""


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Put the files of :data:`FIRST` first, in that order (a stable sort: each file's tests
    keep theirs, and every worker collects the same order)."""
    rank = {name: i for i, name in enumerate(FIRST)}

    def key(item: pytest.Item) -> int:
        path = item.nodeid.split("::")[0].removeprefix("tests/")
        return rank.get(path, len(FIRST))

    items.sort(key=key)
