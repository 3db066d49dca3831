"""The suite's Hypothesis settings: the same examples on every run (``derandomize``), so that a
CI run is reproducible and a red one means a change, not a new draw. The long profiles of the
property files (``HYPOTHESIS_PROFILE=long``) draw afresh each time: that is where to hunt."""

from hypothesis import settings

settings.register_profile("suite", derandomize=True, database=None)
settings.load_profile("suite")
