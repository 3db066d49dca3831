"""Progress a person can read while a run trains: env-steps/s, the latest evaluation, an ETA.

One line on stdout at most every ``every_s`` seconds (and one at the end), for example::

    Detumble__ppo__0   196,608/400,000 steps   41.2k steps/s   5 s
        eval@131k: success 0.98, fuel 1.09x PD (bar met at 131k, 3.4 s)   ETA 5 s

(one line, wrapped here). The rate and the ETA are measured from the start of the second
rollout on: the first rollout and update compile the kernels and warm torch up, so a line
before then says ``-.-k steps/s`` and ``ETA after the first update``. The same numbers go to
TensorBoard (``time/env_steps_per_s``, ``time/eta_s``; the evaluation's own
``eval/success_rate`` and ``eval/fuel_ratio_to_pd``). Needs nothing beyond SB3 (not tqdm or
rich, which SB3's progress bar needs).
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

from stable_baselines3.common.callbacks import BaseCallback

from .callbacks import DurableEvaluation


class TrainingProgress(BaseCallback):
    """Reports throughput, the latest evaluation and the time left.

    Args:
        name: the run's name, first on each line.
        total_timesteps: the run's budget (steps the model will have at the end).
        evaluation: the run's periodic evaluation (its ``latest`` and ``first_met``).
        every_s: seconds between lines.
        stream: where lines go; None prints nothing (TensorBoard only).
    """

    def __init__(
        self,
        name: str,
        total_timesteps: int,
        evaluation: DurableEvaluation | None,
        every_s: float = 5.0,
        stream: TextIO | None = sys.stdout,
    ) -> None:
        super().__init__()
        self.name, self.total, self.evaluation = name, total_timesteps, evaluation
        self.every_s, self.stream = every_s, stream
        self._t0 = self._last = 0.0
        self._steps0 = 0
        self._rollouts = 0
        # Where the rate is measured from: the start of the second rollout, after the first
        # rollout and update (which compile the task's kernels and warm torch up: seconds that
        # a rate from the start would spread over the whole run's ETA); None until then.
        self._ref: tuple[float, int] | None = None

    def _on_training_start(self) -> None:
        self._t0 = self._last = time.perf_counter()
        self._steps0 = self.num_timesteps

    def _on_rollout_start(self) -> None:
        self._rollouts += 1
        if self._rollouts == 2:
            self._ref = (time.perf_counter(), self.num_timesteps)

    def _on_step(self) -> bool:
        return True

    def _rates(self) -> tuple[float, float | None, float | None]:
        """(seconds since start, env-steps/s, ETA in seconds); the rate and the ETA are None
        until a rate is measured after the first rollout and update."""
        now = time.perf_counter()
        elapsed = max(now - self._t0, 1e-9)
        if self._ref is None or self.num_timesteps <= self._ref[1]:
            return elapsed, None, None
        rate = (self.num_timesteps - self._ref[1]) / max(now - self._ref[0], 1e-9)
        return elapsed, rate, max(self.total - self.num_timesteps, 0) / rate

    def _on_rollout_end(self) -> None:
        elapsed, rate, eta = self._rates()
        if rate is not None:
            self.logger.record("time/env_steps_per_s", rate)
            self.logger.record("time/eta_s", eta)
        if time.perf_counter() - self._last >= self.every_s:
            self._print(elapsed, rate, eta)

    def _on_training_end(self) -> None:
        elapsed, rate, _ = self._rates()
        if rate is None:  # too short to measure after the first update: the whole run's rate
            rate = (self.num_timesteps - self._steps0) / elapsed
        self._print(elapsed, rate, 0.0)

    def _print(self, elapsed: float, rate: float | None, eta: float | None) -> None:
        self._last = time.perf_counter()
        if self.stream is None:
            return
        parts = [
            self.name,
            f"{self.num_timesteps:,}/{self.total:,} steps",
            "-.-k steps/s" if rate is None else f"{rate / 1e3:.1f}k steps/s",
            f"{elapsed:.0f} s",
        ]
        latest = self.evaluation.latest if self.evaluation is not None else None
        if latest is not None:
            text = (
                f"eval@{latest['timesteps'] / 1e3:.0f}k: success {latest['success_rate']:.2f}, "
                f"fuel {latest['fuel_ratio']:.2f}x PD"
            )
            first = self.evaluation.first_met if self.evaluation is not None else None
            if first is not None:
                text += f" (bar met at {first[0] / 1e3:.0f}k, {first[1]:.1f} s)"
            parts.append(text)
        parts.append("ETA after the first update" if eta is None else f"ETA {eta:.0f} s")
        print("   ".join(parts), file=self.stream, flush=True)
