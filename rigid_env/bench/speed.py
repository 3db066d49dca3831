"""Speed: throughput of the core, the environments and training, beside their peers.

    rigid-env bench speed [--out DIR] [--quick] [--force] [--only core,env,vec,effects,ppo]
                          [--repeats K] [--clock wall|cpu]
    python -m rigid_env.bench.speed --quick

writes ``speed.png`` (one figure, one panel per measurement), ``speed.md`` (machine header,
one table per measurement, the targets) and ``speed.csv`` (one row per measured case).

What is measured, each beside the peer it is compared with:

1. ``core``: body-steps per second of :meth:`World.step` against the batch size ``N`` for
   each integrator, on a torque-free asymmetric body (principal moments (1, 2, 3)) with random
   spins; beside MuJoCo on the same body (one free joint, no gravity, no contacts), stepped by
   ``mujoco.mj_step`` in a Python loop (one body) and by ``mujoco.rollout.rollout`` on the
   calling thread (``N`` initial states), with MuJoCo's ``Euler`` and ``RK4`` integrators.
2. ``env``: microseconds per ``env.step`` of every task through ``gym.make`` (default
   wrappers), beside Gymnasium's ``Pendulum-v1`` and MuJoCo's ``InvertedPendulum-v5``.
3. ``vec``: env-steps per second of every task's native vector env
   (``vectorization_mode="vector_entry_point"``) against ``N``, beside Gymnasium's
   ``CartPoleVectorEnv`` and Detumble under Gymnasium's ``SyncVectorEnv``.
4. ``effects``: cost of one :meth:`World.step` with no effect, each effect alone and all of
   them; the no-effect world is measured twice (the noise floor).
5. ``ppo``: PPO's environment steps per second with our SB3 adapter, ``DummyVecEnv`` and
   ``SubprocVecEnv`` (same PPO settings and number of environments).

How it times (DESIGN.md, "Measuring"). Every measurement is ``time.perf_counter`` around a
block of calls, with the garbage collector off. A case is first warmed up, which also tells
how many calls make one repeat last at least ``min_time``; then the cases of one group (the
peers that a table compares) run one repeat each in turn, ``repeats`` rounds, so that slow
phases of a shared machine fall on all of them alike. A table reports the median over the
repeats and ratios between peers of the same group of the same run; the CSV keeps the fastest
and slowest repeat too, and the CPU time of the timing thread (``time.thread_time``), whose
share of the wall time the header reports: well below 100 % means a busy machine. On one,
``--clock cpu`` ranks by that CPU time instead (PPO stays on the wall clock). Targets are
printed for information; nothing here asserts on time.
"""

from __future__ import annotations

import argparse
import gc
import math
import os
import platform
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, fields, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import gymnasium as gym
import matplotlib
import matplotlib.ticker
import mujoco
import mujoco.rollout
import numpy as np
from matplotlib.figure import Figure
from numpy.typing import NDArray

import rigid_env.envs  # noqa: F401  (registers the RigidEnv ids)
from rigid_env.bench._common import cpu_model, refuse_overwrite
from rigid_env.core import (
    INTEGRATORS,
    AngularDamping,
    BodyModel,
    ForceEffect,
    Gravity,
    LinearDamping,
    QuadraticDrag,
    State,
    StepMap,
    Thrusters,
    World,
)
from rigid_env.envs import ENV_IDS

FloatArray = NDArray[np.float64]

SECTIONS = ("core", "env", "vec", "effects", "ppo")
"""The measurements, in the order they run and appear."""

DETUMBLE = "RigidEnv/Detumble-v0"
INERTIA = (1.0, 2.0, 3.0)
"""Principal moments of the benchmark body [kg m^2] (asymmetric: the gyroscopic term counts)."""
DT = 0.01
"""Time step of every core and MuJoCo step [s] (the cost does not depend on it)."""
SPIN_RANGE = (0.5, 1.0)
"""Initial angular speeds [rad/s], uniform, random axes: slow enough that no integrator drifts
far (MuJoCo's explicit Euler blows up after ~50 s at 3.7 rad/s) over the ~10 s a repeat runs."""
MJ_BLOCK = 1000
"""``mj_step`` calls per timed call of the Python-loop peer (the state is restored first)."""
MJ_ROLLOUT_BODY_STEPS = 8192
"""Body-steps per ``rollout`` call: ``nstep = 8192 / N`` clipped to [10, 1000]."""


# --------------------------------------------------------------------------------------------
# Configuration
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Config:
    """What to measure and how long; :data:`FULL`, :data:`QUICK` and :data:`SMOKE` below."""

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
    effect_integrator: str
    """Integrator of the effects measurement."""
    ppo_timesteps: int
    """PPO environment steps per timed ``learn`` (a multiple of ``ppo_n_steps * ppo_n_envs``)."""
    ppo_repeats: int
    """Timed ``learn`` calls per PPO variant."""
    ppo_warmup: bool
    """Run one untimed rollout-and-update first."""
    ppo_n_envs: tuple[int, ...] = (8, 16)
    """Sub-environments of the PPO variants (each measured at every one of these)."""
    ppo_target_n_envs: int = 16
    """``n_envs`` at which the PPO target is read: our Detumble baseline's
    (``configs/agents/ppo_detumble.yaml``), what its training runs."""
    ppo_n_steps: int = 256
    """PPO ``n_steps`` (per sub-environment)."""
    ppo_batch_size: int = 512
    """PPO minibatch size."""
    ppo_epochs: int = 1
    """PPO ``n_epochs``."""
    clock: str = "wall"
    """``"wall"``: ``time.perf_counter``; ``"cpu"``: CPU time of the timing thread
    (``time.thread_time``), for a busy machine. PPO is always timed on the wall clock (its
    SubprocVecEnv works in other processes)."""

    def __post_init__(self) -> None:
        if self.clock not in ("wall", "cpu"):
            raise ValueError(f"clock: must be 'wall' or 'cpu', got {self.clock!r}")
        unknown = [n for n in self.core_integrators if n not in INTEGRATORS]
        if unknown:
            raise ValueError(
                f"core_integrators: unknown {unknown}; known: {', '.join(INTEGRATORS)}"
            )
        for n_envs in self.ppo_n_envs:
            rollout = self.ppo_n_steps * n_envs
            if self.ppo_timesteps % rollout:
                raise ValueError(
                    f"ppo_timesteps: {self.ppo_timesteps} is not a multiple of "
                    f"n_steps * n_envs = {rollout}"
                )
        if self.ppo_target_n_envs not in self.ppo_n_envs:
            raise ValueError(
                f"ppo_target_n_envs: {self.ppo_target_n_envs} is not one of ppo_n_envs "
                f"{self.ppo_n_envs}"
            )


FULL = Config(
    name="full",
    min_time=0.1,
    repeats=7,
    core_sizes=(1, 16, 256, 4096, 65536),
    core_integrators=tuple(INTEGRATORS),
    env_ids=tuple(ENV_IDS),
    vec_sizes=(64, 1024, 4096),
    sync_sizes=(64, 1024),
    effect_sizes=(1, 4096),
    effect_integrator="rk4",
    ppo_timesteps=16384,
    ppo_repeats=3,
    ppo_warmup=True,
)
QUICK = replace(
    FULL,
    name="quick",
    min_time=0.02,
    repeats=5,
    core_sizes=(1, 256, 4096),
    core_integrators=("symplectic_euler", "rk4", "splitting"),
    sync_sizes=(64,),
    ppo_timesteps=4096,
    ppo_repeats=1,
)
SMOKE = replace(
    FULL,
    name="smoke",
    min_time=0.0,
    repeats=1,
    core_sizes=(1, 8),
    core_integrators=("symplectic_euler", "rk4"),
    env_ids=(DETUMBLE,),
    vec_sizes=(4, 8),
    sync_sizes=(4,),
    effect_sizes=(1, 8),
    ppo_timesteps=64,
    ppo_repeats=1,
    ppo_warmup=False,
    ppo_n_envs=(2,),
    ppo_target_n_envs=2,
    ppo_n_steps=32,
    ppo_batch_size=64,
)
"""A tiny run of all the machinery, for the test-suite (numbers meaningless)."""


# --------------------------------------------------------------------------------------------
# Timing
# --------------------------------------------------------------------------------------------


@dataclass
class Case:
    """One thing to time.

    Attributes:
        name: label in the tables.
        fn: one call of the measured work.
        work: units of work per call (body-steps, env-steps).
        reset: run before each repeat, outside the timing (e.g. restore the initial state).
        calls: calls per repeat; None = chosen from the warm-up.
        close: releases what the case holds (an environment), after the measurement.
    """

    name: str
    fn: Callable[[], object]
    work: float
    reset: Callable[[], None] | None = None
    calls: int | None = None
    close: Callable[[], None] | None = None


@dataclass(frozen=True)
class Timing:
    """Seconds per call of one case, one number per repeat.

    Attributes:
        work: units of work per call.
        calls: calls per repeat.
        per_call: (repeats,) wall seconds per call (``perf_counter``).
        cpu_per_call: (repeats,) CPU seconds of the timing thread per call (``thread_time``):
            steadier than wall time on a shared machine, but blind to work done in other
            threads or processes (``SubprocVecEnv``'s workers).
        clock: which of the two :attr:`median`, :attr:`rate` and :attr:`per_unit` use:
            ``"wall"`` or ``"cpu"``.
    """

    work: float
    calls: int
    per_call: tuple[float, ...]
    cpu_per_call: tuple[float, ...] = ()
    clock: str = "wall"

    @property
    def seconds(self) -> tuple[float, ...]:
        """(repeats,) seconds per call on :attr:`clock`."""
        return self.cpu_per_call if self.clock == "cpu" else self.per_call

    @property
    def cpu_share(self) -> float:
        """CPU time of the timing thread over wall time, over all repeats: about 1 when the
        benchmark had a core to itself, less when other processes took turns on it."""
        return sum(self.cpu_per_call) / sum(self.per_call) if self.cpu_per_call else math.nan

    @property
    def median(self) -> float:
        """Median seconds per call on :attr:`clock`."""
        return float(np.median(self.seconds))

    @property
    def rate(self) -> float:
        """Units of work per second (from the median)."""
        return self.work / self.median

    @property
    def per_unit(self) -> float:
        """Median seconds per unit of work."""
        return self.median / self.work


def _timed(fn: Callable[[], object], calls: int) -> tuple[float, float]:
    """Wall seconds (``perf_counter``) and CPU seconds of this thread for ``calls`` calls of
    ``fn``, garbage collector off (as ``timeit``)."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        c0, t0 = time.thread_time(), time.perf_counter()
        for _ in range(calls):
            fn()
        return time.perf_counter() - t0, time.thread_time() - c0
    finally:
        if enabled:
            gc.enable()


def measure(
    cases: Sequence[Case],
    *,
    min_time: float,
    repeats: int,
    warmup: bool = True,
    clock: str = "wall",
) -> dict[str, Timing]:
    """Time a group of peers, interleaved: each round runs one repeat of every case in turn.

    Warm-up: each case is called once untimed (one-time costs: compiling a step, filling
    caches), then until ``min_time / 2`` has passed (at least once), which sets its calls per
    repeat to ``ceil(min_time / seconds per call)`` (at least 1). The order of the cases
    rotates from round to round.

    Returns:
        A :class:`Timing` per case name, reporting on ``clock`` (both clocks are kept).
    """
    calls: dict[str, int] = {}
    for c in cases:
        if c.calls is not None:
            calls[c.name] = c.calls
            if warmup:
                if c.reset is not None:
                    c.reset()
                c.fn()
            continue
        if c.reset is not None:
            c.reset()
        if warmup:
            c.fn()  # not timed: a first call's one-time costs would inflate the estimate
        n, elapsed = 0, 0.0
        while n == 0 or (warmup and elapsed < 0.5 * min_time):
            elapsed += _timed(c.fn, 1)[0]
            n += 1
        calls[c.name] = max(1, math.ceil(min_time / (elapsed / n)))
    per_call: dict[str, list[float]] = {c.name: [] for c in cases}
    cpu: dict[str, list[float]] = {c.name: [] for c in cases}
    for r in range(repeats):
        k = r % len(cases)
        for c in [*cases[k:], *cases[:k]]:
            if c.reset is not None:
                c.reset()
            wall, used = _timed(c.fn, calls[c.name])
            per_call[c.name].append(wall / calls[c.name])
            cpu[c.name].append(used / calls[c.name])
    for c in cases:
        if c.close is not None:
            c.close()
    return {
        c.name: Timing(c.work, calls[c.name], tuple(per_call[c.name]), tuple(cpu[c.name]), clock)
        for c in cases
    }


# --------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------


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
        clock: ``wall`` (``perf_counter``) or ``cpu`` (``thread_time`` of the timing thread).
        wall_median_s: median wall seconds per unit of work.
        repeats: repeats of the case.
        calls: calls per repeat.
        cpu_share: CPU time of the timing thread / wall time (see :class:`Timing`).
        cpu_median_s: median CPU seconds of the timing thread per unit of work.
        peer: the case the ratio compares with ("" if none).
        ratio: our throughput / the peer's (higher is faster), or for ``us_per_step`` and
            ``cost_ratio`` rows our time / the peer's (lower is faster); NaN if no peer.
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


def _row(
    section: str, case: str, n: int, metric: str, unit: str, t: Timing, value: float, **kw: Any
) -> Row:
    per = [p / t.work for p in t.seconds]
    return Row(
        section,
        case,
        n,
        metric,
        value,
        unit,
        t.per_unit,
        min(per),
        max(per),
        t.clock,
        float(np.median(t.per_call)) / t.work,
        len(t.per_call),
        t.calls,
        t.cpu_share,
        float(np.median(t.cpu_per_call)) / t.work if t.cpu_per_call else math.nan,
        **kw,
    )


@dataclass
class Results:
    """Everything a run measured, the notes for the Markdown, and the run's context."""

    config: Config
    rows: list[Row] = field(default_factory=list)
    notes: dict[str, list[str]] = field(default_factory=dict)
    context: dict[str, str] = field(default_factory=dict)

    def get(self, section: str, case: str, n: int) -> Row | None:
        """The row of ``case`` at ``n`` in ``section``, if measured."""
        for r in self.rows:
            if r.section == section and r.case == case and r.n == n:
                return r
        return None

    def section(self, name: str) -> list[Row]:
        """The rows of one section, in measurement order."""
        return [r for r in self.rows if r.section == name]


def _log(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


# --------------------------------------------------------------------------------------------
# 1. Core: World.step against N, beside MuJoCo
# --------------------------------------------------------------------------------------------

MJCF = """<mujoco model="free_body">
  <option timestep="{dt}" gravity="0 0 0" integrator="{integrator}"/>
  <worldbody>
    <body name="body">
      <freejoint/>
      <inertial pos="0 0 0" mass="1" diaginertia="{i1} {i2} {i3}"/>
    </body>
  </worldbody>
</mujoco>
"""
"""One free body without geoms (so no contacts), no gravity: torque-free rotation."""

MJ_INTEGRATORS = {"Euler": "symplectic_euler", "RK4": "rk4"}
"""MuJoCo integrator -> our integrator of the same kind (semi-implicit Euler: velocity first,
then position with the new velocity; classical RK4)."""


def random_spins(n: int, seed: int = 0) -> FloatArray:
    """(n, 3) body angular velocities: uniform directions, speeds uniform in
    :data:`SPIN_RANGE` [rad/s]."""
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    return axis * rng.uniform(*SPIN_RANGE, size=(n, 1))


def spinning_state(n: int, seed: int = 0) -> State:
    """``n`` bodies at the origin, identity orientation, random spins."""
    s = State.zeros(n)
    s.w[:] = random_spins(n, seed)
    return s


def mujoco_model(integrator: str) -> mujoco.MjModel:
    """The benchmark body in MuJoCo with ``integrator`` (``"Euler"`` or ``"RK4"``)."""
    i1, i2, i3 = INERTIA
    return mujoco.MjModel.from_xml_string(
        MJCF.format(dt=DT, integrator=integrator, i1=i1, i2=i2, i3=i3)
    )


def mujoco_states(model: mujoco.MjModel, w_body: FloatArray) -> FloatArray:
    """(N, nstate) ``mjSTATE_FULLPHYSICS`` states at rest in translation spinning at ``w_body``.

    The free joint's ``qvel`` is (linear velocity, world; angular velocity, body frame).
    """
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS.value
    data = mujoco.MjData(model)
    base = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, base, spec)
    start = sum(
        mujoco.mj_stateSize(model, s.value)
        for s in (mujoco.mjtState.mjSTATE_TIME, mujoco.mjtState.mjSTATE_QPOS)
    )
    states = np.tile(base, (w_body.shape[0], 1))
    states[:, start + 3 : start + 6] = w_body
    mujoco.mj_setState(model, data, states[0], spec)  # check the layout assumed above
    if not np.array_equal(data.qvel[3:], w_body[0]):
        raise RuntimeError(
            "mujoco: unexpected mjSTATE_FULLPHYSICS layout (qvel not after "
            "time and qpos); the benchmark needs updating for this version"
        )
    return states


def _core_cases(n: int, cfg: Config) -> list[Case]:
    cases = []
    s0 = spinning_state(n)
    model = BodyModel.single(1.0, INERTIA)
    for name in cfg.core_integrators:
        world = World(model, integrator=name, dt=DT, state=s0)
        cases.append(Case(name, world.step, n, reset=lambda w=world: w.reset(s0)))
    for mj_name in MJ_INTEGRATORS:
        m = mujoco_model(mj_name)
        d = mujoco.MjData(m)
        init = mujoco_states(m, s0.w)
        nstep = min(1000, max(10, MJ_ROLLOUT_BODY_STEPS // n))
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS.value
        out = np.empty((n, nstep, init.shape[1]))
        sens = np.empty((n, nstep, m.nsensordata))

        def roll(m=m, d=d, init=init, nstep=nstep, out=out, sens=sens) -> None:
            mujoco.rollout.rollout(m, d, init, nstep=nstep, state=out, sensordata=sens)

        cases.append(Case(f"MuJoCo {mj_name} rollout", roll, n * nstep))
        if n == 1:
            d1 = mujoco.MjData(m)
            step = mujoco.mj_step

            def loop(m=m, d=d1, s=init[0], spec=spec, step=step) -> None:
                mujoco.mj_setState(m, d, s, spec)
                for _ in range(MJ_BLOCK):
                    step(m, d)

            cases.append(Case(f"MuJoCo {mj_name} mj_step loop", loop, MJ_BLOCK))
    return cases


def bench_core(cfg: Config, res: Results) -> None:
    """Body-steps per second of every integrator and of MuJoCo at each batch size."""
    for n in cfg.core_sizes:
        t0 = time.perf_counter()
        timings = measure(
            _core_cases(n, cfg), min_time=cfg.min_time, repeats=cfg.repeats, clock=cfg.clock
        )
        for name, t in timings.items():
            if name.startswith("MuJoCo"):
                peer = name if "rollout" in name else name.replace("mj_step loop", "rollout")
                peer_t = timings[peer]
            else:
                mj = "Euler" if INTEGRATORS[name].order == 1 else "RK4"
                peer = f"MuJoCo {mj} rollout"
                peer_t = timings[peer]
            res.rows.append(
                _row(
                    "core",
                    name,
                    n,
                    "body_steps_per_s",
                    "1/s",
                    t,
                    t.rate,
                    peer=peer,
                    ratio=t.rate / peer_t.rate,
                )
            )
        _log(f"  core N={n}: {len(timings)} cases, {time.perf_counter() - t0:.1f} s")
    res.notes["core"] = [
        f"Torque-free body, principal moments {INERTIA} kg m^2, mass 1 kg, dt {DT} s, spins "
        f"{SPIN_RANGE[0]}-{SPIN_RANGE[1]} rad/s about random axes; one `World.step` advances "
        "all N bodies. MuJoCo: the same body as one free joint (no geoms, gravity 0); "
        "`rollout` runs N initial states on the calling thread (nthread 0), "
        f"`nstep = {MJ_ROLLOUT_BODY_STEPS} / N` clipped to [10, 1000] (starting a trajectory "
        "costs about one step, so 10 steps give MuJoCo ~90 % of its long-rollout rate); the "
        f"`mj_step` loop runs {MJ_BLOCK} steps per call in Python (state restored first).",
        "Ratio: our body-steps/s over MuJoCo `rollout` at the same N, first-order integrators "
        "against MuJoCo `Euler`, the others against `RK4` (higher is faster).",
    ]


# --------------------------------------------------------------------------------------------
# 2. Single environment: env.step through gym.make
# --------------------------------------------------------------------------------------------

ENV_PEERS = ("Pendulum-v1", "InvertedPendulum-v5")
ENV_REFERENCE = "InvertedPendulum-v5"


def _env_case(env_id: str, seed: int = 0, pool: int = 256) -> Case:
    env = gym.make(env_id)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(pool)]
    env.reset(seed=seed)
    i = 0

    def step() -> None:
        nonlocal i
        _, _, terminated, truncated, _ = env.step(actions[i % pool])
        i += 1
        if terminated or truncated:
            env.reset()

    return Case(env_id, step, 1, close=env.close)


def bench_env(cfg: Config, res: Results) -> None:
    """Microseconds per ``env.step`` of every task and of the Gymnasium peers."""
    cases, missing = [], {}
    for env_id in (*cfg.env_ids, *ENV_PEERS):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                cases.append(_env_case(env_id))
        except (ImportError, gym.error.Error) as exc:
            missing[env_id] = " ".join(str(exc).split())
    timings = measure(cases, min_time=cfg.min_time, repeats=cfg.repeats, clock=cfg.clock)
    ref = timings.get(ENV_REFERENCE)
    for name, t in timings.items():
        res.rows.append(
            _row(
                "env",
                name,
                1,
                "us_per_step",
                "us",
                t,
                t.per_unit * 1e6,
                peer=ENV_REFERENCE if ref else "",
                ratio=t.per_unit / ref.per_unit if ref else math.nan,
            )
        )
    for name, why in missing.items():
        res.rows.append(
            Row("env", name, 1, "us_per_step", math.nan, "us", note=f"not available: {why}")
        )
    res.notes["env"] = [
        "`env.step` through `gym.make` (default wrappers: TimeLimit, OrderEnforcing, "
        "PassiveEnvChecker), random actions drawn beforehand, reset when an episode ends "
        "(the reset is part of the cost).",
        f"Ratio: our time per step over `{ENV_REFERENCE}`'s (lower is faster).",
    ]
    for name, why in missing.items():
        res.notes["env"].append(f"`{name}` could not be made: {why}")
    _log(f"  env: {len(timings)} envs")


# --------------------------------------------------------------------------------------------
# 3. Vector environment
# --------------------------------------------------------------------------------------------

CARTPOLE = "CartPole-v1"
SYNC_CASE = "Detumble SyncVectorEnv"
CARTPOLE_CASE = "CartPoleVectorEnv"


def _env_step_rows(
    res: Results, section: str, n: int, timings: dict[str, Timing], peer: str
) -> None:
    """Env-steps per second of every case at ``n`` envs, with its ratio over ``peer``'s."""
    base = timings[peer].rate
    for name, t in timings.items():
        res.rows.append(
            _row(
                section,
                name,
                n,
                "env_steps_per_s",
                "1/s",
                t,
                t.rate,
                peer=peer,
                ratio=t.rate / base,
            )
        )


def _vec_case(name: str, env_id: str, n: int, mode: str, seed: int = 0, pool: int = 8) -> Case:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gym.make_vec(env_id, num_envs=n, vectorization_mode=mode)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(pool)]
    env.reset(seed=seed)
    i = 0

    def step() -> None:
        nonlocal i
        env.step(actions[i % pool])
        i += 1

    return Case(name, step, n, close=env.close)


def _short(env_id: str) -> str:
    return env_id.split("/")[-1].removesuffix("-v0")


def bench_vec(cfg: Config, res: Results) -> None:
    """Env-steps per second of the native vector envs, CartPole's and SyncVectorEnv."""
    sync_rate: dict[int, float] = {}
    for n in cfg.vec_sizes:
        cases = [_vec_case(_short(e), e, n, "vector_entry_point") for e in cfg.env_ids]
        cases.append(_vec_case(CARTPOLE_CASE, CARTPOLE, n, "vector_entry_point"))
        if n in cfg.sync_sizes:
            cases.append(_vec_case(SYNC_CASE, DETUMBLE, n, "sync"))
        timings = measure(cases, min_time=cfg.min_time, repeats=cfg.repeats, clock=cfg.clock)
        if SYNC_CASE in timings:
            sync_rate[n] = timings[SYNC_CASE].rate
        _env_step_rows(res, "vec", n, timings, CARTPOLE_CASE)
        del cases
        gc.collect()
        _log(f"  vec N={n}: done")
    # SyncVectorEnv steps its envs one by one: its cost per env-step does not fall with N, so
    # where it was not measured, its rate at the largest measured N stands in for it.
    if sync_rate:
        n_ref = max(sync_rate)
        for n in cfg.vec_sizes:
            if n in sync_rate:
                continue
            row = Row(
                "vec",
                SYNC_CASE,
                n,
                "env_steps_per_s",
                sync_rate[n_ref],
                "1/s",
                median_s=1.0 / sync_rate[n_ref],
                peer=CARTPOLE_CASE,
                note=f"extrapolated: per-env cost at N={n_ref}",
            )
            cart_row = res.get("vec", CARTPOLE_CASE, n)
            if cart_row is not None:
                row.ratio = row.value / cart_row.value
            res.rows.append(row)
        vec = sorted(res.section("vec"), key=lambda r: r.n)  # stable: the N order of the tables
        res.rows = [r for r in res.rows if r.section != "vec"] + vec
    notes = [
        '`gym.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point")` for ours '
        'and CartPole; Detumble under `SyncVectorEnv` is `vectorization_mode="sync"`. '
        "Random actions drawn beforehand; autoreset as each env defines it.",
        f"Ratios: env-steps/s over `{CARTPOLE_CASE}`'s and over Detumble under "
        "`SyncVectorEnv` at the same N (higher is faster).",
    ]
    unmeasured = [n for n in cfg.vec_sizes if n not in sync_rate]
    if sync_rate and unmeasured:
        n_ref = max(sync_rate)
        step_s = max(unmeasured) / sync_rate[n_ref]
        notes.append(
            f"`SyncVectorEnv` was measured at N = {', '.join(map(str, sorted(sync_rate)))} only: "
            f"it steps its envs one after another, so one step at N = {max(unmeasured)} would "
            f"take ~{step_s:.2f} s. At N = {', '.join(map(str, unmeasured))} its per-env cost "
            f"measured at N = {n_ref} is used (marked *extrapolated*)."
        )
    res.notes["vec"] = notes


# --------------------------------------------------------------------------------------------
# 4. Effects: only what a scene calls for
# --------------------------------------------------------------------------------------------

THRUSTERS = Thrusters(
    points=np.array(
        [
            [0.0, 0.15, 0.0],
            [0.0, -0.15, 0.0],
            [0.0, 0.0, 0.1],
            [0.0, 0.0, -0.1],
            [0.2, 0.0, 0.0],
            [-0.2, 0.0, 0.0],
        ]
    ),
    directions=np.array(
        [
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
        ]
    ),
    max_force=np.full(6, 0.1),
)
"""Detumble's six thrusters (``configs/scenes/detumble.yaml``)."""

NO_EFFECTS = "no effects"
NOISE_FLOOR = "no effects (again)"


def effect_variants() -> dict[str, list[ForceEffect | StepMap]]:
    """Name -> the effects of that world."""
    gravity = Gravity(np.array([0.0, 0.0, -9.81]))
    drag = QuadraticDrag()
    drag_cp = QuadraticDrag(center_of_pressure=np.array([0.0, 0.0, 0.05]))
    lin, ang = LinearDamping(0.999), AngularDamping(0.999)
    return {
        NO_EFFECTS: [],
        NOISE_FLOOR: [],
        "gravity": [gravity],
        "quadratic_drag (CoM)": [drag],
        "quadratic_drag (offset CoP)": [drag_cp],
        "linear_damping": [lin],
        "angular_damping": [ang],
        "thrusters (command)": [THRUSTERS],
        "all of them": [gravity, drag_cp, lin, ang, THRUSTERS],
    }


def _effect_cases(n: int, integrator: str) -> list[Case]:
    s0 = spinning_state(n, seed=1)
    s0.v[:] = np.random.default_rng(2).normal(size=(n, 3))  # a wind for the drag to act on
    command = np.random.default_rng(3).uniform(-1.0, 1.0, size=(n, THRUSTERS.action_dim))
    model = BodyModel.single(1.0, INERTIA)
    cases = []
    for name, effects in effect_variants().items():
        world = World(model, effects, integrator=integrator, dt=DT, state=s0)
        act = command if world.action_dim else None
        cases.append(
            Case(name, lambda w=world, a=act: w.step(a), n, reset=lambda w=world: w.reset(s0))
        )
    return cases


def bench_effects(cfg: Config, res: Results) -> None:
    """Cost of one World.step for each set of effects, relative to no effects."""
    for n in cfg.effect_sizes:
        timings = measure(
            _effect_cases(n, cfg.effect_integrator),
            min_time=cfg.min_time,
            repeats=cfg.repeats,
            clock=cfg.clock,
        )
        base = timings[NO_EFFECTS]
        for name, t in timings.items():
            res.rows.append(
                _row(
                    "effects",
                    name,
                    n,
                    "us_per_step",
                    "us",
                    t,
                    t.median * 1e6,
                    peer=NO_EFFECTS,
                    ratio=t.median / base.median,
                )
            )
        _log(f"  effects N={n}: done")
    res.notes["effects"] = [
        f"One `World.step` ({cfg.effect_integrator}, dt {DT} s) of the same body with a random "
        "velocity and spin; each world lists only the effects named (thrusters get a random "
        'command); "all of them" = gravity, drag with offset centre of pressure, both '
        "dampings and the thrusters.",
        f"Ratio: time per step over the no-effects world's (lower is faster). "
        f'"{NOISE_FLOOR}" is a second, identical no-effects world measured in the same '
        "rounds: its distance from 1 is the noise floor.",
    ]


# --------------------------------------------------------------------------------------------
# 5. Training: PPO with our adapter, DummyVecEnv and SubprocVecEnv
# --------------------------------------------------------------------------------------------

PPO_ADAPTER = "RigidBodySB3VecEnv"
PPO_DUMMY = "DummyVecEnv"
PPO_SUBPROC = "SubprocVecEnv"


def make_detumble() -> gym.Env:
    """``gym.make("RigidEnv/Detumble-v0")`` (module level, so SubprocVecEnv can pickle it by
    reference; importing this module registers the ids in the worker)."""
    return gym.make(DETUMBLE)


def _time_ppo(cfg: Config, venvs: dict[str, Any], ppo: type) -> dict[str, Timing]:
    """Time ``learn(cfg.ppo_timesteps)`` of one PPO model per VecEnv, in rounds."""
    models = {
        name: ppo(
            "MlpPolicy",
            venv,
            n_steps=cfg.ppo_n_steps,
            batch_size=cfg.ppo_batch_size,
            n_epochs=cfg.ppo_epochs,
            policy_kwargs={"net_arch": [64, 64]},
            device="cpu",
            seed=0,
            verbose=0,
        )
        for name, venv in venvs.items()
    }
    if cfg.ppo_warmup:
        for name, model in models.items():
            model.learn(cfg.ppo_n_steps * venvs[name].num_envs)
    cases = [
        Case(
            name,
            lambda m=model: m.learn(cfg.ppo_timesteps, reset_num_timesteps=True),
            cfg.ppo_timesteps,
            calls=1,
        )
        for name, model in models.items()
    ]
    return measure(cases, min_time=0.0, repeats=cfg.ppo_repeats, warmup=False)


def bench_ppo(cfg: Config, res: Results) -> None:
    """PPO environment steps per second with each VecEnv."""
    import multiprocessing

    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    from rigid_env.agents.vec_adapter import RigidBodySB3VecEnv

    threads = torch.get_num_threads()
    # One thread: the policy is a [64, 64] MLP; on a small machine more threads only contend
    # with the environment (and the SubprocVecEnv workers) for cores.
    torch.set_num_threads(1)
    start = "fork" if "fork" in multiprocessing.get_all_start_methods() else None
    try:
        for n_envs in cfg.ppo_n_envs:
            venvs: dict[str, Any] = {}
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    venvs[PPO_ADAPTER] = RigidBodySB3VecEnv(DETUMBLE, num_envs=n_envs)
                    venvs[PPO_DUMMY] = DummyVecEnv([make_detumble] * n_envs)
                    venvs[PPO_SUBPROC] = SubprocVecEnv([make_detumble] * n_envs, start_method=start)
                    timings = _time_ppo(cfg, venvs, PPO)
            finally:
                for venv in venvs.values():
                    venv.close()
            _env_step_rows(res, "ppo", n_envs, timings, PPO_DUMMY)
    finally:
        torch.set_num_threads(threads)
    sizes = ", ".join(map(str, cfg.ppo_n_envs))
    res.notes["ppo"] = [
        f"PPO (`MlpPolicy` [64, 64], n_steps {cfg.ppo_n_steps}, batch {cfg.ppo_batch_size}, "
        f"{cfg.ppo_epochs} epoch(s), CPU, torch 1 thread) on `{DETUMBLE}` with n_envs = {sizes}:"
        f" `{PPO_ADAPTER}(id, num_envs=n_envs)`, `{PPO_DUMMY}` and `{PPO_SUBPROC}` (start "
        f"method {start or 'default'}) over `gym.make(id)`. Timed: `learn({cfg.ppo_timesteps})`"
        f" (rollouts and updates), {cfg.ppo_repeats} repeat(s)"
        + (" after one untimed rollout-and-update." if cfg.ppo_warmup else ", no warm-up.")
        + " Making the envs is not timed.",
        f"Ratio: env-steps/s over `{PPO_DUMMY}`'s at the same n_envs (higher is faster). "
        "PPO's own work per step (the policy, the rollout buffer, the update) is the same for "
        "every VecEnv, so the ratio grows with n_envs; the target is read at "
        f"n_envs = {cfg.ppo_target_n_envs}, what our Detumble baseline trains with "
        "(`configs/agents/ppo_detumble.yaml`).",
    ]
    _log("  ppo: done")


# --------------------------------------------------------------------------------------------
# Targets (informational)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Target:
    """One informational target: ``measured`` against ``threshold`` in direction ``op``.

    Attributes:
        name: what is compared, for the Markdown.
        short: the same in a few words, for the figure.
        measured: the ratio measured (NaN if not measured in this run).
        op: ``">="`` or ``"<="``.
        threshold: the ratio aimed at.
        note: how the measured value or the threshold came about, if not plain.
    """

    name: str
    short: str
    measured: float
    op: str
    threshold: float
    note: str = ""

    @property
    def status(self) -> str:
        """``pass``, ``fail`` or ``n/a`` (not measured)."""
        if not math.isfinite(self.measured):
            return "n/a"
        ok = self.measured >= self.threshold if self.op == ">=" else self.measured <= self.threshold
        return "pass" if ok else "fail"


def _ratio(res: Results, section: str, case: str, n: int, peer: str) -> float:
    a, b = res.get(section, case, n), res.get(section, peer, n)
    if a is None or b is None or not (math.isfinite(a.value) and math.isfinite(b.value)):
        return math.nan
    return a.value / b.value


def targets(res: Results) -> list[Target]:
    """The targets of the issue, each with its measured ratio."""
    out = [
        Target(
            "core N=4096: symplectic_euler / MuJoCo Euler rollout (body-steps/s)",
            "core 4096: sympl. Euler / MJ Euler",
            _ratio(res, "core", "symplectic_euler", 4096, "MuJoCo Euler rollout"),
            ">=",
            15.0,
        ),
        Target(
            "core N=4096: rk4 / MuJoCo RK4 rollout (body-steps/s)",
            "core 4096: rk4 / MJ RK4",
            _ratio(res, "core", "rk4", 4096, "MuJoCo RK4 rollout"),
            ">=",
            5.0,
        ),
        Target(
            f"Detumble env.step time / {ENV_REFERENCE}'s",
            "Detumble step time / InvPend",
            _ratio(res, "env", DETUMBLE, 1, ENV_REFERENCE),
            "<=",
            0.7,
        ),
        Target(
            f"vector Detumble N=4096 / {CARTPOLE_CASE} (env-steps/s)",
            "vec 4096: Detumble / CartPole",
            _ratio(res, "vec", "Detumble", 4096, CARTPOLE_CASE),
            ">=",
            0.35,
        ),
        Target(
            "vector Detumble N=4096 / Detumble under SyncVectorEnv (env-steps/s)",
            "vec 4096: Detumble / SyncVectorEnv",
            _ratio(res, "vec", "Detumble", 4096, SYNC_CASE),
            ">=",
            20.0,
            note=_sync_note(res, 4096),
        ),
    ]
    effect_sizes = sorted({r.n for r in res.section("effects")})
    for n in effect_sizes:
        all_cost = _ratio(res, "effects", "all of them", n, NO_EFFECTS)
        floor = abs(_ratio(res, "effects", NOISE_FLOOR, n, NO_EFFECTS) - 1.0)
        margin = max(0.05, 3.0 * floor)
        out.append(
            Target(
                f"effects N={n}: all-effects step time / no-effects'",
                f"effects {n}: all / none (time)",
                all_cost,
                ">=",
                1.0 + margin,
                note=f"measurably: above 1 by max(5 %, 3 x noise floor {floor:.1%})",
            )
        )
    if not effect_sizes:
        out.append(
            Target(
                "effects: all-effects step time / no-effects'",
                "effects: all / none (time)",
                math.nan,
                ">=",
                1.05,
            )
        )
    out.append(
        Target(
            f"PPO: adapter / {PPO_DUMMY} (env-steps/s), {res.config.ppo_target_n_envs} envs",
            f"PPO: adapter / Dummy, {res.config.ppo_target_n_envs} envs",
            _ratio(res, "ppo", PPO_ADAPTER, res.config.ppo_target_n_envs, PPO_DUMMY),
            ">=",
            1.5,
        )
    )
    return out


def _sync_note(res: Results, n: int) -> str:
    row = res.get("vec", SYNC_CASE, n)
    return row.note if row is not None else ""


# --------------------------------------------------------------------------------------------
# Output: Markdown, CSV, figure
# --------------------------------------------------------------------------------------------


def _si(x: float, digits: int = 3) -> str:
    """``1234567 -> '1.23 M'``."""
    if not math.isfinite(x):
        return "-"
    for scale, suffix in ((1e9, " G"), (1e6, " M"), (1e3, " k")):
        if abs(x) >= scale:
            return f"{x / scale:.{digits}g}{suffix}"
    return f"{x:.{digits}g}"


def _x(r: float) -> str:
    return "-" if not math.isfinite(r) else (f"{r:.3g}x" if r < 100 else f"{r:.0f}x")


def _table(header: Sequence[str], rows: Sequence[Sequence[str]], align: str = "") -> list[str]:
    """A Markdown table; ``align`` has one ``l``/``r`` per column (default: the first left,
    the others right)."""
    align = align or "l" + "r" * (len(header) - 1)
    lines = [
        "| " + " | ".join(header) + " |",
        "|" + "|".join("---" if a == "l" else "---:" for a in align) + "|",
    ]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return lines


def _paragraphs(notes: Sequence[str]) -> list[str]:
    return [line for note in notes for line in (note, "")]


def _md_core(res: Results) -> list[str]:
    rows = res.section("core")
    sizes = sorted({r.n for r in rows})
    names = list(dict.fromkeys(r.case for r in rows))
    lines = ["## 1. Core: `World.step` throughput against batch size", ""]
    lines += _paragraphs(res.notes.get("core", []))
    lines += ["Body-steps per second (ratio to the MuJoCo `rollout` peer at the same N):", ""]
    table = []
    for name in names:
        cells = [name]
        for n in sizes:
            r = res.get("core", name, n)
            cells.append("" if r is None else f"{_si(r.value)} ({_x(r.ratio)})")
        table.append(cells)
    lines += _table(["integrator / engine", *[f"N={n}" for n in sizes]], table)
    lines += ["", "Same-kind pairs (ours over MuJoCo, body-steps/s):", ""]
    pair_rows = []
    for n in sizes:
        cells = [str(n)]
        for mj, ours in MJ_INTEGRATORS.items():
            a, b = res.get("core", ours, n), res.get("core", f"MuJoCo {mj} rollout", n)
            cells += [
                _si(a.value) if a else "-",
                _si(b.value) if b else "-",
                _x(a.value / b.value) if a and b else "-",
            ]
        pair_rows.append(cells)
    lines += _table(
        [
            "N",
            "symplectic_euler",
            "MuJoCo Euler rollout",
            "ratio",
            "rk4",
            "MuJoCo RK4 rollout",
            "ratio",
        ],
        pair_rows,
    )
    loops = [r for r in rows if "mj_step loop" in r.case]
    if loops:
        lines += ["", "N = 1 beside `mj_step` in a Python loop:", ""]
        loop_rows = []
        for mj, ours in MJ_INTEGRATORS.items():
            a, b = res.get("core", ours, 1), res.get("core", f"MuJoCo {mj} mj_step loop", 1)
            if a and b:
                loop_rows.append(
                    [
                        ours,
                        f"{a.median_s * 1e6:.3g}",
                        f"MuJoCo {mj}",
                        f"{b.median_s * 1e6:.3g}",
                        _x(a.value / b.value),
                    ]
                )
        lines += _table(
            ["ours", "us/step", "peer", "us/step", "ours/peer (steps/s)"], loop_rows, "lrlrr"
        )
    return [*lines, ""]


def _md_env(res: Results) -> list[str]:
    lines = ["## 2. Single environment: `env.step` through `gym.make`", ""]
    lines += _paragraphs(res.notes.get("env", []))
    table = [
        [
            f"`{r.case}`",
            f"{r.value:.1f}" if math.isfinite(r.value) else "n/a",
            _si(1e6 / r.value) if math.isfinite(r.value) else "-",
            _x(r.ratio),
        ]
        for r in res.section("env")
    ]
    lines += _table(["env", "us/step", "steps/s", f"time / {ENV_REFERENCE}"], table)
    return [*lines, ""]


def _md_vec(res: Results) -> list[str]:
    lines = ["## 3. Vector environment: env-steps per second", ""]
    lines += _paragraphs(res.notes.get("vec", []))
    table = []
    for r in res.section("vec"):
        sync = res.get("vec", SYNC_CASE, r.n)
        vs_sync = r.value / sync.value if sync is not None and r.case != SYNC_CASE else math.nan
        label = r.case + (" *extrapolated*" if r.note.startswith("extrapolated") else "")
        table.append(
            [str(r.n), label, _si(r.value), f"{1e6 / r.value:.3g}", _x(r.ratio), _x(vs_sync)]
        )
    lines += _table(
        ["N", "env", "env-steps/s", "us/env-step", f"x {CARTPOLE_CASE}", "x Detumble Sync"],
        table,
        "rlrrrr",
    )
    return [*lines, ""]


def _md_effects(res: Results) -> list[str]:
    rows = res.section("effects")
    sizes = sorted({r.n for r in rows})
    names = list(dict.fromkeys(r.case for r in rows))
    lines = ["## 4. Effects: only what the scene calls for", ""]
    lines += _paragraphs(res.notes.get("effects", []))
    header = ["effects"]
    for n in sizes:
        header += [f"N={n} us/step", f"N={n} / none", f"N={n} extra us"]
    table = []
    for name in names:
        cells = [name]
        for n in sizes:
            r, base = res.get("effects", name, n), res.get("effects", NO_EFFECTS, n)
            if r is None or base is None:
                cells += ["-", "-", "-"]
                continue
            cells += [f"{r.value:.4g}", _x(r.ratio), f"{r.value - base.value:+.3g}"]
        table.append(cells)
    lines += _table(header, table)
    return [*lines, ""]


def _md_ppo(res: Results) -> list[str]:
    lines = ["## 5. Training: PPO environment steps per second", ""]
    lines += _paragraphs(res.notes.get("ppo", []))
    steps = res.config.ppo_timesteps
    table = [
        [f"`{r.case}`", str(r.n), _si(r.value), f"{steps / r.value:.2f}", _x(r.ratio)]
        for r in res.section("ppo")
    ]
    lines += _table(
        ["VecEnv", "n_envs", "env-steps/s", f"s per learn({steps})", f"x {PPO_DUMMY}"], table
    )
    return [*lines, ""]


def _md_targets(res: Results) -> list[str]:
    lines = ["## Targets (informational, never asserted)", ""]
    table = [
        [
            t.name,
            _x(t.measured) if math.isfinite(t.measured) else "not measured",
            f"{t.op} {t.threshold:.3g}x",
            t.status,
            t.note,
        ]
        for t in targets(res)
    ]
    lines += _table(["target", "measured", "goal", "status", "note"], table, "lrrll")
    return [*lines, ""]


def _clock_text(clock: str) -> str:
    if clock == "cpu":
        return (
            "CPU time of the timing thread (`time.thread_time`, `--clock cpu`; PPO: "
            "`time.perf_counter`)"
        )
    return "`time.perf_counter`"


CONTENDED = 0.9
"""Below this median CPU share the header warns that the machine was busy."""


def _shares(res: Results) -> list[float]:
    return [r.cpu_share for r in res.rows if r.section != "ppo" and math.isfinite(r.cpu_share)]


def _cpu_share(res: Results) -> float:
    """Median CPU share of the timed blocks (PPO left out), NaN if none."""
    shares = _shares(res)
    return float(np.median(shares)) if shares else math.nan


def _is_busy(res: Results) -> bool:
    """Whether the run shared its cores: a low CPU share or a load above the core count."""
    load = max(float(res.context.get("load1_start", "0")), _load_1min())
    return _cpu_share(res) < CONTENDED or load > (os.cpu_count() or 1)


def _contention(res: Results) -> list[str]:
    """Header line on how much of the wall time the timing thread actually ran."""
    shares = _shares(res)
    if not shares:
        return []
    med, low = float(np.median(shares)), min(shares)
    line = (
        f"- CPU share (thread CPU time / wall time while timing, PPO left out): median "
        f"{med:.0%}, lowest {low:.0%}; below 100 % other processes took the core from the "
        "benchmark while it was timing (a shared core's slowdown, e.g. a busy hyperthread "
        "sibling, does not show here: compare the load average with the core count)"
    )
    if _is_busy(res):
        line += (
            ". **The machine was busy: wall times are inflated and their ratios noisier "
            "than the repeats suggest; rerun on an idle machine, or with `--clock cpu`, "
            "before drawing conclusions.**"
        )
    return [line]


def write_markdown(res: Results, path: Path) -> None:
    """``speed.md``: the header, one table per measured section, the targets."""
    c = res.context
    lines = [
        "# Speed benchmark",
        "",
        f"- Date: {c['date']}",
        f"- Machine: {c['cpu']}, {c['cores']}; load average {c['load_start']} at the start, "
        f"{c['load_end']} at the end",
        f"- Versions: {c['versions']}",
        f"- Run: `{c['command']}` ({res.config.name}: {c['sections']}), {c['wall']} s",
        f"- Method: {_clock_text(res.config.clock)}, warm-up, then {res.config.repeats} repeats of "
        f">= {res.config.min_time:g} s per case (PPO: {res.config.ppo_repeats}), the peers of "
        "a table interleaved round by round; medians; ratios only between peers of the same "
        "run. `speed.csv` also has the fastest and slowest repeat of every case and the "
        "median CPU time of the timing thread (steadier than wall time on a busy machine).",
        *_contention(res),
        "",
    ]
    writers = {
        "core": _md_core,
        "env": _md_env,
        "vec": _md_vec,
        "effects": _md_effects,
        "ppo": _md_ppo,
    }
    for name in SECTIONS:
        if res.section(name):
            lines += writers[name](res)
    lines += _md_targets(res)
    path.write_text("\n".join(lines), encoding="utf-8")


def write_csv(res: Results, path: Path) -> None:
    """``speed.csv``: one row per case, columns :data:`CSV_COLUMNS`."""
    import csv

    with open(path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=CSV_COLUMNS)
        writer.writeheader()
        for r in res.rows:
            d = asdict(r)
            for k, v in d.items():
                if isinstance(v, float):
                    d[k] = "" if not math.isfinite(v) else f"{v:.6g}"
            writer.writerow(d)


def _n_ticks(ax: Any, sizes: Sequence[int]) -> None:
    """Label a log axis at the measured sizes only."""
    ax.xaxis.set_major_locator(matplotlib.ticker.FixedLocator(sizes))
    ax.xaxis.set_major_formatter(matplotlib.ticker.FixedFormatter([str(n) for n in sizes]))
    ax.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())


def _panel_core(ax: Any, res: Results) -> None:
    rows = res.section("core")
    names = list(dict.fromkeys(r.case for r in rows if not r.case.startswith("MuJoCo")))
    colors = matplotlib.colormaps["tab10"]
    for k, name in enumerate(names):
        pts = sorted((r.n, r.value) for r in rows if r.case == name)
        ax.plot(*zip(*pts, strict=True), "o-", color=colors(k % 10), ms=3, lw=1.2, label=name)
    for mj, style in (("Euler", "s--"), ("RK4", "D:")):
        pts = sorted((r.n, r.value) for r in rows if r.case == f"MuJoCo {mj} rollout")
        if pts:
            ax.plot(
                *zip(*pts, strict=True),
                style,
                color="black",
                ms=4,
                lw=1.5,
                label=f"MuJoCo {mj} rollout",
            )
        loop = res.get("core", f"MuJoCo {mj} mj_step loop", 1)
        if loop is not None:
            ax.plot(
                [1],
                [loop.value],
                "x" if mj == "Euler" else "+",
                color="black",
                ms=8,
                mew=1.5,
                label=f"MuJoCo {mj} mj_step loop",
            )
    ax.set(
        xscale="log",
        yscale="log",
        xlabel="bodies N",
        ylabel="body-steps / s",
        title="(1) core: World.step vs MuJoCo (one thread)",
    )
    _n_ticks(ax, sorted({r.n for r in rows}))
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=6, ncol=2, loc="lower right")


def _panel_env(ax: Any, res: Results) -> None:
    rows = [r for r in res.section("env") if math.isfinite(r.value)]
    labels = [_short(r.case) for r in rows]
    colors = ["tab:blue" if r.case.startswith("RigidEnv/") else "0.55" for r in rows]
    y = np.arange(len(rows))
    ax.barh(y, [r.value for r in rows], color=colors)
    for k, r in enumerate(rows):
        ax.text(r.value, k, f" {r.value:.0f} us ({_x(r.ratio)})", va="center", fontsize=7)
    ax.set_yticks(y, labels, fontsize=8)
    ax.invert_yaxis()
    ax.set_xlim(0, 1.45 * max([r.value for r in rows], default=1.0))
    ax.set(
        xlabel="us per env.step (lower is faster)",
        title=f"(2) single env via gym.make (x = time / {ENV_REFERENCE})",
    )
    ax.grid(True, axis="x", alpha=0.3)


def _panel_vec(ax: Any, res: Results) -> None:
    rows = res.section("vec")
    names = list(dict.fromkeys(r.case for r in rows))
    colors = matplotlib.colormaps["tab10"]
    k = 0
    for name in names:
        pts = sorted((r.n, r.value, r.note) for r in rows if r.case == name)
        measured = [(n, v) for n, v, note in pts if not note]
        if name == CARTPOLE_CASE:
            style, color = "s--", "black"
        elif name == SYNC_CASE:
            style, color = "o-", "0.5"
        else:
            style, color = "o-", colors(k % 10)
            k += 1
        if measured:
            ax.plot(*zip(*measured, strict=True), style, color=color, ms=4, lw=1.3, label=name)
        extra = [(n, v) for n, v, note in pts if note]
        if extra and measured:
            xs = [measured[-1][0]] + [n for n, _ in extra]
            ys = [measured[-1][1]] + [v for _, v in extra]
            ax.plot(xs, ys, ":", color=color, lw=1.3)
            ax.plot(
                [n for n, _ in extra],
                [v for _, v in extra],
                "o",
                mfc="none",
                color=color,
                ms=5,
                label=f"{name} (extrapolated)",
            )
    ax.set(
        xscale="log",
        yscale="log",
        xlabel="num_envs N",
        ylabel="env-steps / s",
        title="(3) vector envs: native, CartPole's, SyncVectorEnv",
    )
    _n_ticks(ax, sorted({r.n for r in rows}))
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=6, loc="upper left")


def _panel_effects(ax: Any, res: Results) -> None:
    rows = res.section("effects")
    sizes = sorted({r.n for r in rows})
    names = list(dict.fromkeys(r.case for r in rows))
    y = np.arange(len(names))
    height = 0.8 / max(len(sizes), 1)
    for j, n in enumerate(sizes):
        vals = [getattr(res.get("effects", name, n), "ratio", math.nan) for name in names]
        ax.barh(
            y + (j - (len(sizes) - 1) / 2) * height,
            vals,
            height=height,
            label=f"N={n}",
            color=matplotlib.colormaps["tab10"](j + 2),
        )
    ax.axvline(1.0, color="black", lw=0.8)
    ax.set_yticks(y, names, fontsize=7)
    ax.invert_yaxis()
    ax.set(
        xlabel="step time / no-effects step time",
        title=f"(4) effects ({res.config.effect_integrator}): pay only for what is listed",
    )
    ax.grid(True, axis="x", alpha=0.3)
    ax.legend(fontsize=7, loc="center right")


def _panel_ppo(ax: Any, res: Results) -> None:
    rows = res.section("ppo")
    x = np.arange(len(rows))
    ax.bar(
        x,
        [r.value for r in rows],
        color=["tab:blue" if r.case == PPO_ADAPTER else "0.55" for r in rows],
    )
    for k, r in enumerate(rows):
        ax.text(k, r.value, f"{r.value:.0f}\n({_x(r.ratio)})", ha="center", va="bottom", fontsize=7)
    short = {PPO_ADAPTER: "adapter", PPO_DUMMY: "Dummy", PPO_SUBPROC: "Subproc"}
    ax.set_xticks(x, [f"{short.get(r.case, r.case)}\n{r.n} envs" for r in rows], fontsize=7)
    ax.set_ylim(0, 1.25 * max([r.value for r in rows], default=1.0))
    ax.set(
        ylabel="env-steps / s",
        title=f"(5) PPO on Detumble (x = vs {PPO_DUMMY}, same n_envs)",
    )
    ax.grid(True, axis="y", alpha=0.3)


def _panel_targets(ax: Any, res: Results) -> None:
    ax.axis("off")
    items = targets(res)
    cells = [
        [
            t.short,
            _x(t.measured) if math.isfinite(t.measured) else "-",
            f"{t.op} {t.threshold:.3g}x",
            t.status,
        ]
        for t in items
    ]
    colors = {"pass": "#c8e6c9", "fail": "#ffcdd2", "n/a": "#eeeeee"}
    table = ax.table(
        cellText=cells,
        colLabels=["target", "measured", "goal", ""],
        cellColours=[["white"] * 3 + [colors[t.status]] for t in items],
        colWidths=[0.56, 0.16, 0.16, 0.12],
        loc="center",
        cellLoc="left",
    )
    table.auto_set_font_size(False)
    table.set_fontsize(8)
    table.scale(1.0, 1.6)
    ax.set_title("targets (informational)")


def write_figure(res: Results, path: Path) -> None:
    """``speed.png``: one panel per measured section and the targets."""
    fig = Figure(figsize=(17, 10), layout="constrained")
    axes = fig.subplots(2, 3)
    panels = {
        "core": _panel_core,
        "env": _panel_env,
        "vec": _panel_vec,
        "effects": _panel_effects,
        "ppo": _panel_ppo,
    }
    for ax, name in zip(axes.flat, SECTIONS, strict=False):
        if res.section(name):
            panels[name](ax, res)
        else:
            ax.axis("off")
            ax.set_title(f"{name}: not measured in this run")
    _panel_targets(axes.flat[5], res)
    c = res.context
    share = _cpu_share(res)
    busy = ""
    if _is_busy(res):
        busy = " - busy machine: " + (f"CPU share {share:.0%}, " if math.isfinite(share) else "")
        busy += f"load {c.get('load1_start', '?')}"
    fig.suptitle(
        f"rigid_env speed ({res.config.name}, {res.config.clock} clock) - {c['cpu']}, "
        f"{c['cores']} - {c['date']}{busy}",
        fontsize=11,
    )
    fig.savefig(path, dpi=110)


# --------------------------------------------------------------------------------------------
# Command
# --------------------------------------------------------------------------------------------


def _version(dist: str) -> str:
    """Installed version of a distribution, read without importing it (torch is slow to)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(dist)
    except PackageNotFoundError:
        return "not installed"


def _versions() -> str:
    return (
        f"Python {platform.python_version()}, numpy {np.__version__}, mujoco "
        f"{mujoco.__version__}, gymnasium {gym.__version__}, stable-baselines3 "
        f"{_version('stable-baselines3')}, torch {_version('torch')}"
    )


def _cores() -> str:
    total = os.cpu_count() or 0
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = total
    return f"{total} logical cores" + (f" ({usable} usable)" if usable != total else "")


def _load_1min() -> float:
    try:
        return os.getloadavg()[0]
    except OSError:
        return 0.0


def _load() -> str:
    try:
        return " / ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "n/a"


def _sections(text: str) -> tuple[str, ...]:
    names = tuple(s.strip() for s in text.split(",") if s.strip())
    bad = [s for s in names if s not in SECTIONS]
    if bad or not names:
        raise argparse.ArgumentTypeError(
            f"unknown section {', '.join(bad) or repr(text)}; choose from {', '.join(SECTIONS)}"
        )
    return names


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``rigid-env bench speed``."""
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("results/speed"),
        metavar="DIR",
        help="output folder for speed.png, speed.md and speed.csv (default: results/speed)",
    )
    parser.add_argument(
        "--quick", action="store_true", help="fewer sizes, integrators and repeats (about a minute)"
    )
    parser.add_argument(
        "--only",
        type=_sections,
        default=SECTIONS,
        metavar="S1,S2",
        help=f"measure only these sections: {', '.join(SECTIONS)} (default: all)",
    )
    parser.add_argument(
        "--repeats",
        type=int,
        default=None,
        metavar="K",
        help="repeats per case (default: 7, quick 5)",
    )
    parser.add_argument(
        "--clock",
        choices=("wall", "cpu"),
        default="wall",
        help="wall: time.perf_counter (default); cpu: CPU time of the timing "
        "thread, steadier on a busy machine (PPO always uses wall time)",
    )
    parser.add_argument("--force", action="store_true", help="overwrite earlier results in --out")
    parser.add_argument("--smoke", action="store_true", help=argparse.SUPPRESS)


def run(args: argparse.Namespace) -> int:
    """Measure, then write ``speed.png``, ``speed.md`` and ``speed.csv`` into ``args.out``."""
    cfg = SMOKE if args.smoke else QUICK if args.quick else FULL
    if args.repeats is not None:
        if args.repeats < 1:
            raise ValueError(f"--repeats: must be an integer >= 1, got {args.repeats}")
        cfg = replace(cfg, repeats=args.repeats)
    cfg = replace(cfg, clock=args.clock)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(
            f"--out: {out} is a file; give a folder for speed.png, speed.md and speed.csv"
        )
    refuse_overwrite([out / "speed.md", out / "speed.csv", out / "speed.png"], args.force)
    out.mkdir(parents=True, exist_ok=True)
    sections = [s for s in SECTIONS if s in args.only]
    flags = " --quick" if args.quick else " --smoke" if args.smoke else ""
    flags += " --clock cpu" if cfg.clock == "cpu" else ""
    res = Results(
        cfg,
        context={
            "date": datetime.now(timezone.utc).astimezone().strftime("%Y-%m-%d %H:%M %Z"),
            "cpu": cpu_model(),
            "cores": _cores(),
            "versions": _versions(),
            "load_start": _load(),
            "load1_start": f"{_load_1min():.2f}",
            "sections": ", ".join(sections),
            "command": f"rigid-env bench speed{flags}"
            + ("" if tuple(sections) == SECTIONS else f" --only {','.join(sections)}"),
        },
    )
    benches = {
        "core": bench_core,
        "env": bench_env,
        "vec": bench_vec,
        "effects": bench_effects,
        "ppo": bench_ppo,
    }
    start = time.perf_counter()
    _log(f"speed benchmark ({cfg.name}): {', '.join(sections)}")
    for name in sections:
        t0 = time.perf_counter()
        benches[name](cfg, res)
        _log(f"{name}: {time.perf_counter() - t0:.1f} s")
    res.context["wall"] = f"{time.perf_counter() - start:.0f}"
    res.context["load_end"] = _load()
    write_markdown(res, out / "speed.md")
    write_csv(res, out / "speed.csv")
    t0 = time.perf_counter()
    write_figure(res, out / "speed.png")
    _log(f"  figure: {time.perf_counter() - t0:.1f} s")
    print("\n".join(_md_targets(res)))
    print(
        f"wrote {out / 'speed.md'}, {out / 'speed.csv'}, {out / 'speed.png'} "
        f"({res.context['wall']} s)"
    )
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m rigid_env.bench.speed [flags]``: the same as ``rigid-env bench speed``."""
    from rigid_env.cli import main as cli_main

    return cli_main(["bench", "speed", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    raise SystemExit(main())
