"""The speed benchmark's vocabulary, shared by what measures (:mod:`rigid_env.bench.speed`) and
what shows the results (:mod:`rigid_env.bench.speed_report`): the sections, the names of the
cases the tables single out, the run's configuration and the measured rows."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

from rigid_env.core import INTEGRATORS

SECTIONS = ("core", "env", "vec", "effects", "ppo", "random")
"""The measurements, in the order they run and appear."""

MJ_INTEGRATORS = {"Euler": "symplectic_euler", "RK4": "rk4"}
"""MuJoCo integrator -> our integrator of the same kind (semi-implicit Euler: velocity first,
then position with the new velocity; classical RK4)."""
ENV_REFERENCE = "InvertedPendulum-v5"
SYNC_CASE = "Detumble SyncVectorEnv"
CARTPOLE_CASE = "CartPoleVectorEnv"
NO_EFFECTS = "no effects"
NOISE_FLOOR = "no effects (again)"
PPO_ADAPTER = "RigidBodySB3VecEnv"
PPO_DUMMY = "DummyVecEnv"
PPO_SUBPROC = "SubprocVecEnv"
RANDOMISED = " randomised"
"""The suffix of a ``random`` case measured with its shipped randomisation and sensors (the case
without it is its nominal peer)."""
RESET = " reset"
"""The suffix of a ``random`` case that times resets (per reset env) rather than steps."""
WORLD_STEPS = " world steps"
"""The suffix of a ``random`` row that gives the world steps per env step of a case (its
envs' mean action repeat), not a timing."""


@dataclass(frozen=True)
class Config:
    """What to measure and how long; :data:`rigid_env.bench.speed.FULL`, ``QUICK`` and ``SMOKE``."""

    name: str
    """``full``, ``quick`` or ``smoke``."""
    min_time: float
    """Shortest repeat [s]: calls per repeat are chosen from the warm-up to reach it."""
    repeats: int
    """Repeats per case (rounds over a group); the tables give the median."""
    core_sizes: tuple[int, ...]
    """Batch sizes ``N`` of the core measurement."""
    core_integrators: tuple[str, ...]
    """Integrators of the core measurement (names in ``INTEGRATORS``)."""
    env_ids: tuple[str, ...]
    """Our tasks for the single- and vector-env measurements."""
    vec_sizes: tuple[int, ...]
    """``num_envs`` of the vector-env measurement."""
    sync_sizes: tuple[int, ...]
    """``num_envs`` at which Detumble under ``SyncVectorEnv`` is measured (it steps env by env;
    larger ``N`` use its per-env cost at the largest of these)."""
    effect_sizes: tuple[int, ...]
    """Batch sizes of the effects measurement."""
    ppo_timesteps: int
    """PPO environment steps per timed ``learn`` (a multiple of ``ppo_n_steps * n_envs``)."""
    ppo_repeats: int
    """Timed ``learn`` calls per PPO variant."""
    ppo_warmup: bool = True
    """Run one untimed rollout-and-update first."""
    ppo_n_envs: tuple[int, ...] = (8, 16)
    """Sub-environments of the PPO variants; 16 is what the previous Detumble config trained
    with (configs/agents/previous/; ``rigid-env bench learn`` measures the shipped ones)."""
    ppo_n_steps: int = 256
    """PPO ``n_steps`` (per sub-environment)."""
    ppo_batch_size: int = 512
    """PPO minibatch size."""
    effect_integrator: str = "rk4"
    """Integrator of the effects measurement."""
    random_size: int = 4096
    """``num_envs`` of the randomisation measurement (its steps and resets)."""
    clock: str = "wall"
    """``wall`` or ``cpu`` (:data:`rigid_env.bench.timing.CLOCKS`); PPO is always timed on
    the wall clock (its SubprocVecEnv works in other processes)."""

    def __post_init__(self) -> None:
        unknown = [n for n in self.core_integrators if n not in INTEGRATORS]
        if unknown:
            raise ValueError(
                f"core_integrators: unknown {unknown}; known: {', '.join(INTEGRATORS)}"
            )
        for n_envs in self.ppo_n_envs:
            if self.ppo_timesteps % (self.ppo_n_steps * n_envs):
                raise ValueError(
                    f"ppo_timesteps: {self.ppo_timesteps} is not a multiple of "
                    f"n_steps * n_envs = {self.ppo_n_steps * n_envs}"
                )


@dataclass
class Row:
    """One measured case: a line of ``speed.csv``.

    Attributes:
        section: measurement (one of :data:`SECTIONS`).
        case: what ran (integrator, engine, env id, effect, VecEnv).
        n: batch size / number of environments (1 for a single env).
        metric: what ``value`` is, e.g. ``body_steps_per_s``.
        value: the median measurement in ``unit``.
        unit: unit of ``value``.
        median_s, min_s, max_s: seconds per unit of work on ``clock`` (median, fastest and
            slowest repeat).
        clock: ``wall`` (``perf_counter``) or ``cpu`` (``process_time``).
        wall_median_s: median wall seconds per unit of work.
        repeats: repeats of the case.
        calls: calls per repeat.
        cpu_share: CPU time of the process / wall time (see :class:`Timing`).
        cpu_median_s: median CPU seconds of the process per unit of work.
        peer: the case the ratio compares with ("" if none).
        ratio: our throughput / the peer's (higher is faster), or for ``us_per_step`` rows our
            time / the peer's (lower is faster); NaN if no peer.
        note: e.g. ``extrapolated`` or why a peer is missing.
    """

    section: str
    case: str
    n: int
    metric: str
    value: float
    unit: str
    median_s: float = math.nan
    min_s: float = math.nan
    max_s: float = math.nan
    clock: str = "wall"
    wall_median_s: float = math.nan
    repeats: int = 0
    calls: int = 0
    cpu_share: float = math.nan
    cpu_median_s: float = math.nan
    peer: str = ""
    ratio: float = math.nan
    note: str = ""


CSV_COLUMNS = tuple(f.name for f in fields(Row))


@dataclass
class Results:
    """What a run measured: the CSV's rows, and each section's notes on its method."""

    config: Config
    rows: list[Row] = field(default_factory=list)
    notes: dict[str, list[str]] = field(default_factory=dict)

    def get(self, section: str, case: str, n: int) -> Row | None:
        """The row of ``case`` at ``n`` in ``section``, if measured."""
        return next((r for r in self.rows if (r.section, r.case, r.n) == (section, case, n)), None)

    def section(self, name: str) -> list[Row]:
        """The rows of one section, in measurement order."""
        return [r for r in self.rows if r.section == name]


def short_id(env_id: str) -> str:
    """``RigidEnv/Detumble-v0 -> Detumble``."""
    return env_id.split("/")[-1].removesuffix("-v0")
