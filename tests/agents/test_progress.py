"""The progress line's rate and ETA leave the first rollout and update (compilation) out."""

from __future__ import annotations

import io
from types import SimpleNamespace

import pytest

from agents import progress
from agents.progress import TrainingProgress


class _Clock:
    """A perf_counter the test advances by hand [s]."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


class _Logger:
    def __init__(self) -> None:
        self.records: dict[str, float] = {}

    def record(self, key: str, value: float) -> None:
        self.records[key] = value


def test_no_eta_until_a_rate_is_measured_after_the_first_update(monkeypatch):
    """A first rollout of 1,000 steps that takes 60 s (compiling) and then 10,000 steps a
    second: the first line gives no ETA; the next reports 10k steps/s and the time left at
    that rate, not at the rate the compilation dragged down."""
    clock = _Clock()
    monkeypatch.setattr(progress.time, "perf_counter", clock)
    out = io.StringIO()
    cb = TrainingProgress("Detumble__ppo__0", 101_000, None, every_s=0.0, stream=out)
    logger = _Logger()
    cb.model = SimpleNamespace(logger=logger, num_timesteps=0)
    cb.on_training_start({}, {})
    cb.on_rollout_start()
    clock.now += 60.0  # the first rollout compiles the kernels
    cb.num_timesteps = 1_000
    cb.on_rollout_end()
    first = out.getvalue().splitlines()[-1]
    assert "ETA after the first update" in first and "-.-k steps/s" in first
    assert "time/eta_s" not in logger.records
    cb.on_rollout_start()  # after the first update: the rate is measured from here
    clock.now += 1.0
    cb.num_timesteps = 11_000
    cb.on_rollout_end()
    second = out.getvalue().splitlines()[-1]
    assert "10.0k steps/s" in second and second.endswith("ETA 9 s")  # 90,000 steps left
    assert logger.records["time/eta_s"] == pytest.approx(9.0)
    cb.num_timesteps = 101_000
    cb.on_training_end()
    assert out.getvalue().splitlines()[-1].endswith("ETA 0 s")


def test_a_run_too_short_to_measure_ends_with_its_whole_rate(monkeypatch):
    clock = _Clock()
    monkeypatch.setattr(progress.time, "perf_counter", clock)
    out = io.StringIO()
    cb = TrainingProgress("tiny", 256, None, every_s=1e9, stream=out)
    cb.model = SimpleNamespace(logger=_Logger(), num_timesteps=0)
    cb.on_training_start({}, {})
    cb.on_rollout_start()
    clock.now += 2.0
    cb.num_timesteps = 256
    cb.on_rollout_end()
    cb.on_training_end()
    assert out.getvalue().splitlines() == ["tiny   256/256 steps   0.1k steps/s   2 s   ETA 0 s"]
