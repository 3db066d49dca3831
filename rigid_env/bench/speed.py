"""Speed: throughput of the core, the environments and training, beside their peers.

    rigid-env bench speed [--out DIR] [--quick] [--force] [--only core,env,vec,effects,ppo]
                          [--repeats K] [--clock wall|cpu]

writes ``speed.md`` (one table per measurement), ``speed.csv`` (one row per measured case) and
``speed.png`` (one panel per measurement). What is measured, each beside its peer:

1. ``core``: body-steps per second of :meth:`World.step` against the batch size ``N`` for
   every integrator (``--quick`` too: all ten at N = 1, 256 and 4096) on a torque-free
   asymmetric body (principal moments (1, 2, 3)) with random spins; beside MuJoCo on the same
   body (one free joint, no gravity, no contacts), stepped by ``mujoco.mj_step`` in a Python
   loop (one body) and by ``mujoco.rollout.rollout`` on the calling thread (``N`` initial
   states), with MuJoCo's ``Euler`` and ``RK4`` integrators; and the same bodies with three
   reaction wheels (rk4) beside ``rk4`` without them.
2. ``env``: microseconds per ``env.step`` of every task through ``gym.make`` (default
   wrappers), beside Gymnasium's ``Pendulum-v1`` and MuJoCo's ``InvertedPendulum-v5``.
3. ``vec``: env-steps per second of every task's native vector env
   (``vectorization_mode="vector_entry_point"``) against ``N``, beside Gymnasium's
   ``CartPoleVectorEnv`` and Detumble under Gymnasium's ``SyncVectorEnv``.
4. ``effects``: cost of one :meth:`World.step` with no effect, each effect alone and all of
   them; the no-effect world is measured twice (the noise floor).
5. ``ppo``: PPO's environment steps per second with our SB3 adapter, ``DummyVecEnv`` and
   ``SubprocVecEnv`` (same PPO settings and number of environments).
6. ``random``: env-steps per second of the vector env of every task (its newest version) and
   every shipped policy's env, with its shipped randomisation and sensors (its PPO config's,
   over a variant's own), and the cost of a reset per env, each beside the same env without
   those draws.

Timing is :mod:`rigid_env.bench.timing`'s (peers interleaved round by round, medians, ratios
within a run); writing is :mod:`rigid_env.bench.report`'s. This module holds the cases, and
what each table and panel shows. MuJoCo and matplotlib are imported only when used.
"""

from __future__ import annotations

import argparse
import gc
import math
import sys
import time
import warnings
from collections.abc import Sequence
from dataclasses import replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, NamedTuple

import gymnasium as gym
import numba
import numpy as np
from numpy.typing import NDArray

import rigid_env.envs  # noqa: F401  (registers the RigidEnv ids)
from rigid_env.bench import report
from rigid_env.bench.speed_report import write
from rigid_env.bench.speed_rows import (
    CARTPOLE_CASE,
    ENV_REFERENCE,
    MJ_INTEGRATORS,
    NO_EFFECTS,
    NOISE_FLOOR,
    PPO_ADAPTER,
    PPO_DUMMY,
    PPO_SUBPROC,
    RANDOMISED,
    RESET,
    SECTIONS,
    SYNC_CASE,
    WORLD_STEPS,
    Config,
    Results,
    Row,
    short_id,
)
from rigid_env.bench.timing import CLOCKS, Case, Timing, measure
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
from rigid_env.core.actuator import specs
from rigid_env.core.effects import (
    AerodynamicDrag,
    GravityGradient,
    ReactionWheels,
    SolarRadiationPressure,
)
from rigid_env.core.facets import facets
from rigid_env.core.orbit import EARTH_EQUATORIAL_RADIUS, kepler_orbit
from rigid_env.core.orbit_state import OrbitMotion
from rigid_env.core.threads import THREAD_MIN_BODIES
from rigid_env.envs import ENV_IDS
from rigid_env.resources import scene_path
from rigid_env.scene import load_scene

FloatArray = NDArray[np.float64]

OUTPUTS = ("speed.md", "speed.csv", "speed.png")

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
WHEELS_CASE = "rk4 + 3 reaction wheels"
"""The core row of the benchmark body carrying three reaction wheels, beside ``rk4`` without."""


def bench_wheels() -> ReactionWheels:
    """Three reaction wheels along the body's principal axes, a CubeSat's (J 1e-5 kg m^2,
    2e-3 N m, limit 628 rad/s)."""
    return ReactionWheels(np.eye(3), inertia=1.0e-5, max_torque=2.0e-3, max_speed=628.0)


WHEELS_ON_ORBIT = "RigidEnv/WheelPointing-v1"
"""Measured beside every task's newest id: the wheel world whose vector env is held to at least
BdotDetumble-v2's integrator steps per second (issue 42; the same orbit, field, coils and rk4,
with three wheels and the gravity gradient). Its newer version adds sunlight, air and sensors."""


FULL = Config(
    name="full", min_time=0.1, repeats=7, core_sizes=(1, 16, 256, 4096, 65536),
    core_integrators=tuple(INTEGRATORS), env_ids=(*ENV_IDS, WHEELS_ON_ORBIT),
    vec_sizes=(64, 1024, 4096),
    sync_sizes=(64, 1024), effect_sizes=(1, 4096), ppo_timesteps=16384, ppo_repeats=3,
)  # fmt: skip
QUICK = replace(
    FULL, name="quick", min_time=0.02, repeats=5, core_sizes=(1, 256, 4096), sync_sizes=(64,),
    ppo_timesteps=4096, ppo_repeats=1,
)  # fmt: skip
"""About a minute: every integrator still, at N = 1, 256 and 4096."""
SMOKE = replace(
    FULL, name="smoke", min_time=0.0, repeats=1, core_sizes=(1, 8),
    core_integrators=("symplectic_euler", "rk4"), env_ids=(DETUMBLE,), vec_sizes=(4, 8),
    sync_sizes=(4,), effect_sizes=(1, 8), ppo_timesteps=64, ppo_repeats=1, ppo_warmup=False,
    ppo_n_envs=(2,), ppo_n_steps=32, ppo_batch_size=64, random_size=8,
)  # fmt: skip
"""A tiny run of all the machinery, for the test-suite (numbers meaningless)."""


# --------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------


def _row(
    section: str, case: str, n: int, metric: str, unit: str, t: Timing, value: float, **kw: Any
) -> Row:
    """The CSV row of a timed case whose table shows ``value`` [``unit``]."""
    per = [p / t.work for p in t.seconds]
    return Row(
        section, case, n, metric, value, unit, t.per_unit, min(per), max(per), t.clock,
        float(np.median(t.per_call)) / t.work, len(t.per_call), t.calls, t.cpu_share,
        float(np.median(t.cpu_per_call)) / t.work, **kw,
    )  # fmt: skip


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


def mujoco_model(integrator: str) -> Any:
    """The benchmark body as a ``mujoco.MjModel`` with ``integrator`` (``Euler`` or ``RK4``)."""
    import mujoco

    i1, i2, i3 = INERTIA
    return mujoco.MjModel.from_xml_string(
        MJCF.format(dt=DT, integrator=integrator, i1=i1, i2=i2, i3=i3)
    )


def mujoco_states(model: Any, w_body: FloatArray) -> FloatArray:
    """(N, nstate) ``mjSTATE_FULLPHYSICS`` states at rest in translation spinning at ``w_body``.

    The free joint's ``qvel`` is (linear velocity, world; angular velocity, body frame).
    """
    import mujoco

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
    import mujoco
    import mujoco.rollout

    cases = []
    s0 = spinning_state(n)
    model = BodyModel.single(1.0, INERTIA)
    for name in cfg.core_integrators:
        world = World(model, integrator=name, dt=DT, state=s0)
        cases.append(Case(name, world.step, n, reset=lambda w=world: w.reset(s0)))
    if "rk4" in cfg.core_integrators:  # the same bodies carrying wheels, driven at random
        world = World(model, [bench_wheels()], integrator="rk4", dt=DT, state=s0)
        u = np.random.default_rng(5).uniform(-1.0, 1.0, (n, 3))

        def driven(w: World = world, u: FloatArray = u) -> None:
            w.step(u)

        cases.append(Case(WHEELS_CASE, driven, n, reset=lambda w=world: w.reset(s0)))
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS.value
    for mj_name in MJ_INTEGRATORS:
        m = mujoco_model(mj_name)
        d, d1 = mujoco.MjData(m), mujoco.MjData(m)
        init = mujoco_states(m, s0.w)
        nstep = min(1000, max(10, MJ_ROLLOUT_BODY_STEPS // n))
        out = np.empty((n, nstep, init.shape[1]))
        sens = np.empty((n, nstep, m.nsensordata))

        def roll(m=m, d=d, init=init, nstep=nstep, out=out, sens=sens) -> None:
            mujoco.rollout.rollout(m, d, init, nstep=nstep, state=out, sensordata=sens)

        def loop(m=m, d=d1, s=init[0], step=mujoco.mj_step) -> None:
            mujoco.mj_setState(m, d, s, spec)
            for _ in range(MJ_BLOCK):
                step(m, d)

        cases.append(Case(f"MuJoCo {mj_name} rollout", roll, n * nstep))
        if n == 1:
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
                peer = name.replace("mj_step loop", "rollout")
            elif name == WHEELS_CASE:
                peer = "rk4"
            else:
                peer = f"MuJoCo {'Euler' if INTEGRATORS[name].order == 1 else 'RK4'} rollout"
            ratio = t.rate / timings[peer].rate
            res.rows.append(
                _row("core", name, n, "body_steps_per_s", "1/s", t, t.rate, peer=peer, ratio=ratio)
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
        f"`{WHEELS_CASE}`: the same bodies (rk4) each carrying three reaction wheels along its "
        "principal axes (J 1e-5 kg m^2, 2e-3 N m, 628 rad/s), each body driving them at its own "
        "random levels in [-1, 1]; its ratio is to `rk4` without wheels at the same N (the "
        "cost of the wheels' momenta riding through the same passes; must hold: >= 0.5x at "
        "N = 4096).",
        f"From N = {THREAD_MIN_BODIES} on, `World.step` splits the bodies over the process's "
        f"cores (Numba threads, {numba.get_num_threads()} here); MuJoCo's `rollout` runs on one "
        "thread, so at N = 4096 the ratio counts our threads too.",
    ]


# --------------------------------------------------------------------------------------------
# 2. Single environment: env.step through gym.make
# --------------------------------------------------------------------------------------------

ENV_PEERS = ("Pendulum-v1", "InvertedPendulum-v5")


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
        ratio = t.per_unit / ref.per_unit if ref else math.nan
        peer = ENV_REFERENCE if ref else ""
        value = t.per_unit * 1e6
        res.rows.append(_row("env", name, 1, "us_per_step", "us", t, value, peer=peer, ratio=ratio))
    for name, why in missing.items():
        res.rows.append(
            Row("env", name, 1, "us_per_step", math.nan, "us", note=f"not available: {why}")
        )
    res.notes["env"] = [
        "`env.step` through `gym.make` (default wrappers: TimeLimit, OrderEnforcing, "
        "PassiveEnvChecker), random actions drawn beforehand, reset when an episode ends "
        "(the reset is part of the cost).",
        f"Ratio: our time per step over `{ENV_REFERENCE}`'s (lower is faster).",
        *(f"`{name}` could not be made: {why}" for name, why in missing.items()),
    ]
    _log(f"  env: {len(timings)} envs")


# --------------------------------------------------------------------------------------------
# 3. Vector environment
# --------------------------------------------------------------------------------------------

CARTPOLE = "CartPole-v1"


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


def bench_vec(cfg: Config, res: Results) -> None:
    """Env-steps per second of the native vector envs, CartPole's and SyncVectorEnv."""
    sync_rate: dict[int, float] = {}
    rows: list[Row] = []
    for n in cfg.vec_sizes:
        cases = [_vec_case(short_id(e), e, n, "vector_entry_point") for e in cfg.env_ids]
        cases.append(_vec_case(CARTPOLE_CASE, CARTPOLE, n, "vector_entry_point"))
        if n in cfg.sync_sizes:
            cases.append(_vec_case(SYNC_CASE, DETUMBLE, n, "sync"))
        timings = measure(cases, min_time=cfg.min_time, repeats=cfg.repeats, clock=cfg.clock)
        if SYNC_CASE in timings:
            sync_rate[n] = timings[SYNC_CASE].rate
        base = timings[CARTPOLE_CASE].rate
        for name, t in timings.items():
            rows.append(
                _row("vec", name, n, "env_steps_per_s", "1/s", t, t.rate, peer=CARTPOLE_CASE,
                     ratio=t.rate / base)
            )  # fmt: skip
        del cases
        gc.collect()
        _log(f"  vec N={n}: done")
    # SyncVectorEnv steps its envs one by one: its cost per env-step does not fall with N, so
    # where it was not measured, its rate at the largest measured N stands in for it.
    unmeasured = [n for n in cfg.vec_sizes if n not in sync_rate]
    n_ref = max(sync_rate, default=0)
    for n in unmeasured if sync_rate else []:
        cart = next(r for r in rows if r.case == CARTPOLE_CASE and r.n == n)
        rate = sync_rate[n_ref]
        rows.append(
            Row("vec", SYNC_CASE, n, "env_steps_per_s", rate, "1/s", median_s=1.0 / rate,
                peer=CARTPOLE_CASE, ratio=rate / cart.value,
                note=f"extrapolated: per-env cost at N={n_ref}")
        )  # fmt: skip
    rows.sort(key=lambda r: r.n)  # stable: the N order of the tables
    res.rows += rows
    res.notes["vec"] = notes = [
        '`gym.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point")` for ours '
        'and CartPole; Detumble under `SyncVectorEnv` is `vectorization_mode="sync"`. '
        "Random actions drawn beforehand; autoreset as each env defines it.",
        f"Ratios: env-steps/s over `{CARTPOLE_CASE}`'s and over Detumble under "
        "`SyncVectorEnv` at the same N (higher is faster).",
    ]
    notes += _integrator_steps(cfg, rows)
    if sync_rate and unmeasured:
        notes.append(
            f"`SyncVectorEnv` was measured at N = {', '.join(map(str, sorted(sync_rate)))} only: "
            f"it steps its envs one after another, so one step at N = {max(unmeasured)} would "
            f"take ~{max(unmeasured) / sync_rate[n_ref]:.2f} s. At N = "
            f"{', '.join(map(str, unmeasured))} its per-env cost measured at N = {n_ref} is used "
            "(marked *extrapolated*)."
        )


def _integrator_steps(cfg: Config, rows: list[Row]) -> list[str]:
    """The note comparing the wheel world on an orbit with the coils' world by integrator steps
    per second (env-steps/s times the world's substeps per env step), where both were run."""
    coils = next((e for e in cfg.env_ids if short_id(e).startswith("BdotDetumble")), None)
    if coils is None or WHEELS_ON_ORBIT not in cfg.env_ids:
        return []
    substeps = {}
    for env_id in (WHEELS_ON_ORBIT, coils):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            env = gym.make(env_id)
        substeps[env_id] = env.unwrapped.task.world.substeps
        env.close()
    rate = {(r.case, r.n): r.value for r in rows}
    wheels, other = short_id(WHEELS_ON_ORBIT), short_id(coils)
    ratios = [
        f"{rate[wheels, n] * substeps[WHEELS_ON_ORBIT] / (rate[other, n] * substeps[coils]):.2f}x"
        for n in cfg.vec_sizes
    ]
    return [
        f"Integrator steps per second (env-steps/s times the substeps of an env step: "
        f"{wheels} {substeps[WHEELS_ON_ORBIT]}, {other} {substeps[coils]}; the same rk4, orbit, "
        f"field and coils, with three wheels and the gravity gradient), {wheels} over {other} at "
        f"N = {', '.join(map(str, cfg.vec_sizes))}: {', '.join(ratios)} (issue 42's bar: at least "
        "1x at N = 4096)."
    ]


# --------------------------------------------------------------------------------------------
# 4. Effects: only what a scene calls for
# --------------------------------------------------------------------------------------------


def detumble_thrusters() -> Thrusters:
    """Detumble's six thrusters (``configs/scenes/detumble.yaml``)."""
    effects = load_scene(scene_path("detumble")).effects()
    return specs(effects)[0]  # its only actuator


def effect_variants() -> dict[str, list[ForceEffect | StepMap]]:
    """Name -> the effects of that world."""
    thrusters = detumble_thrusters()
    gravity = Gravity(np.array([0.0, 0.0, -9.81]))
    drag = QuadraticDrag()
    drag_cp = QuadraticDrag(center_of_pressure=np.array([0.0, 0.0, 0.05]))
    lin, ang = LinearDamping(0.999), AngularDamping(0.999)
    gradient = GravityGradient(3.986e14, np.array([0.0, 0.0, -7.0e6]))  # the bodies in orbit
    # On an orbit (the position per substep, body by body), then the facets' effects on a
    # 0.1 x 0.1 x 0.34 m box's six faces (the sunlight's place and shadow, the air's density
    # and wind per substep; the plates summed per integrator stage).
    orbit = OrbitMotion(kepler_orbit(EARTH_EQUATORIAL_RADIUS + 5.0e5, inclination=0.9),
                        epoch=2025.2)  # fmt: skip
    faces = [(ax, sign) for ax in range(3) for sign in (1.0, -1.0)]
    sides = np.array([0.1, 0.1, 0.34])
    plates = facets(
        [sides[(a + 1) % 3] * sides[(a + 2) % 3] for a, _ in faces],
        [np.eye(3)[a] * sign for a, sign in faces],
        [np.eye(3)[a] * sign * 0.5 * sides[a] + [0.0, 0.0, 0.02] for a, sign in faces],
        0.05,
        0.1,
    )
    return {
        NO_EFFECTS: [],
        NOISE_FLOOR: [],
        "gravity": [gravity],
        "quadratic_drag (CoM)": [drag],
        "quadratic_drag (offset CoP)": [drag_cp],
        "linear_damping": [lin],
        "angular_damping": [ang],
        "gravity_gradient": [gradient],
        "orbit": [orbit],
        "orbit + solar_radiation_pressure": [orbit, SolarRadiationPressure(plates)],
        "orbit + aerodynamic_drag": [orbit, AerodynamicDrag(plates)],
        "thrusters (command)": [thrusters],
        **{f"thrusters + {name}": [hw] for name, hw in thruster_hardware(thrusters).items()},
        "all of them": [gravity, drag_cp, lin, ang, thrusters],
    }


def thruster_hardware(thrusters: Thrusters) -> dict[str, Thrusters]:
    """Each hardware option of the thrusters alone, and all of them (values of the
    ``realistic`` preset's order, :mod:`rigid_env.core.thrusters`)."""
    k = thrusters.max_force.shape[0]
    options = {
        "lag": {"lag": np.full(k, 0.02)},
        "min_impulse": {"min_impulse": 0.01 * thrusters.max_force * DT},
        "on_off": {"on_off": np.ones(k, bool)},
        "noise": {"noise": np.full(k, 0.05)},
    }
    options["all hardware"] = {key: v for option in options.values() for key, v in option.items()}
    return {name: replace(thrusters, **values) for name, values in options.items()}


def _effect_cases(n: int, integrator: str) -> list[Case]:
    s0 = spinning_state(n, seed=1)
    s0.v[:] = np.random.default_rng(2).normal(size=(n, 3))  # a wind for the drag to act on
    command = np.random.default_rng(3).uniform(-1.0, 1.0, size=(n, 6))  # six thrusters
    model = BodyModel.single(1.0, INERTIA)
    cases = []
    for name, effects in effect_variants().items():
        world = World(model, effects, integrator=integrator, dt=DT, state=s0)
        act = command if world.action_dim else None
        if world.parameters.noisy:  # the factors are drawn per step (an env's cost of noise)
            rng = np.random.default_rng(4)

            def noisy_step(
                w: World = world, a: FloatArray | None = act, g: np.random.Generator = rng
            ) -> None:
                w.draw_thrust_factors(g)
                w.step(a)

            cases.append(Case(name, noisy_step, n, reset=lambda w=world: w.reset(s0)))
            continue
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
            ratio = t.median / base.median
            res.rows.append(
                _row("effects", name, n, "us_per_step", "us", t, t.median * 1e6, peer=NO_EFFECTS,
                     ratio=ratio)
            )  # fmt: skip
        _log(f"  effects N={n}: done")
    res.notes["effects"] = [
        f"One `World.step` ({cfg.effect_integrator}, dt {DT} s) of the same body with a random "
        "velocity and spin; each world lists only the effects named (thrusters get a random "
        'command); "all of them" = gravity, drag with offset centre of pressure, both '
        'dampings and the ideal thrusters. "thrusters + X": the thrusters with one hardware '
        "option (lag 0.02 s, a minimum impulse bit of 1 % of max_force dt, on/off firing, "
        "noise 0.05 with the factors drawn each step); an ideal thruster takes the path it "
        'took before the options existed ("thrusters (command)"). "orbit": the bodies on a '
        "500 km orbit, their position evaluated per substep (stepped body by body); "
        '"orbit + X": with the sunlight or the air on the six faces of a 0.1 x 0.1 x 0.34 m box '
        "(centre of pressure 2 cm off the centre of mass), evaluated per substep and summed per "
        "integrator stage.",
        "Ratio: time per step over the no-effects world's (lower is faster). "
        f'"{NOISE_FLOOR}" is a second, identical no-effects world measured in the same '
        "rounds: its distance from 1 is the noise floor.",
    ]


# --------------------------------------------------------------------------------------------
# 5. Training: PPO with our adapter, DummyVecEnv and SubprocVecEnv
# --------------------------------------------------------------------------------------------


def make_detumble() -> gym.Env:
    """``gym.make("RigidEnv/Detumble-v0")`` (module level, so SubprocVecEnv can pickle it by
    reference; importing this module registers the ids in the worker)."""
    return gym.make(DETUMBLE)


def _time_ppo(cfg: Config, venvs: dict[str, Any]) -> dict[str, Timing]:
    """Time ``learn(cfg.ppo_timesteps)`` of one PPO model per VecEnv, in rounds."""
    from stable_baselines3 import PPO

    models = {
        name: PPO("MlpPolicy", venv, n_steps=cfg.ppo_n_steps, batch_size=cfg.ppo_batch_size,
                  n_epochs=1, policy_kwargs={"net_arch": [64, 64]}, device="cpu", seed=0,
                  verbose=0)
        for name, venv in venvs.items()
    }  # fmt: skip
    if cfg.ppo_warmup:
        for name, model in models.items():
            model.learn(cfg.ppo_n_steps * venvs[name].num_envs)
    cases = [
        Case(name, lambda m=m: m.learn(cfg.ppo_timesteps), cfg.ppo_timesteps, calls=1)
        for name, m in models.items()
    ]
    return measure(cases, min_time=0.0, repeats=cfg.ppo_repeats, warmup=False)


def bench_ppo(cfg: Config, res: Results) -> None:
    """PPO environment steps per second with each VecEnv."""
    import multiprocessing

    import torch
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
                    timings = _time_ppo(cfg, venvs)
            finally:
                for venv in venvs.values():
                    venv.close()
            base = timings[PPO_DUMMY].rate
            for name, t in timings.items():
                res.rows.append(
                    _row("ppo", name, n_envs, "env_steps_per_s", "1/s", t, t.rate, peer=PPO_DUMMY,
                         ratio=t.rate / base)
                )  # fmt: skip
    finally:
        torch.set_num_threads(threads)
    res.notes["ppo"] = [
        f"PPO (`MlpPolicy` [64, 64], n_steps {cfg.ppo_n_steps}, batch {cfg.ppo_batch_size}, "
        f"1 epoch, CPU, torch 1 thread) on `{DETUMBLE}` with n_envs = "
        f"{', '.join(map(str, cfg.ppo_n_envs))}: `{PPO_ADAPTER}(id, num_envs=n_envs)`, "
        f"`{PPO_DUMMY}` and `{PPO_SUBPROC}` (start method {start or 'default'}) over "
        f"`gym.make(id)`. Timed: `learn({cfg.ppo_timesteps})` (rollouts and updates), "
        f"{cfg.ppo_repeats} repeat(s)"
        + (" after one untimed rollout-and-update." if cfg.ppo_warmup else ", no warm-up.")
        + " Making the envs is not timed.",
        f"Ratio: env-steps/s over `{PPO_DUMMY}`'s at the same n_envs (higher is faster). "
        "PPO's own work per step (the policy, the rollout buffer, the update) is the same for "
        "every VecEnv, so the ratio grows with n_envs; our Detumble baseline trains with 16 "
        "(`configs/agents/ppo_detumble.yaml`).",
    ]
    _log("  ppo: done")


# --------------------------------------------------------------------------------------------
# 6. Randomisation and sensors: the vector env's steps and resets beside the nominal env's
# --------------------------------------------------------------------------------------------

RESET_EVERY = 16
"""A timed reset restarts every 16th env of the N (autoresets restart a few envs at a time)."""
RANDOM_MIN_TIME = 0.1
"""Least seconds per repeat of a case here (over a quick run's 0.02 s): a randomised env's step
costs 1-2 ms at N = 4096, so 0.02 s timed 2-8 steps per repeat, the first after its start, when
many episodes end at once (ratios from 0.38x to 0.62x in repeated runs of one tree)."""
STEP_BAR, RESET_BAR = 0.5, 20.0
"""Issue 45's bar: a randomised vector env steps at >= 0.5x its nominal env-steps/s, and its
reset costs <= 20x the nominal one per env."""


class Shipped(NamedTuple):
    """An env as it ships (:func:`shipped_randomisations`)."""

    env_id: str
    nominal: dict[str, Any]
    """Its shipped keyword arguments with ``randomization=None, sensors=None``."""
    shipped: dict[str, Any]
    """Its PPO config's ``env_kwargs`` (none where the task ships no config)."""
    draws: str
    """What it draws per episode or step (``randomization`` and ``sensors`` keys, over a
    variant's own), ``none`` if nothing."""


def _draws(kwargs: dict[str, Any]) -> str:
    """The ``randomization`` and ``sensors`` keys of ``kwargs`` that are on, or ``none``."""
    on = [k for k, v in (kwargs.get("randomization") or {}).items() if v]
    on += [f"sensors.{k}" for k, v in (kwargs.get("sensors") or {}).items() if v]
    return ", ".join(on) or "none"


def shipped_randomisations() -> dict[str, Shipped]:
    """Name -> :class:`Shipped` of every task's newest id and every shipped policy's id that
    draws (an older version a policy was trained on, a variant), each with its PPO config's
    ``env_kwargs`` (``configs/agents/ppo_<stem>.yaml``; none where the task ships no config).
    A task's newest id that draws nothing is measured too: its two rows are the same env (the
    noise floor)."""
    import yaml

    from rigid_env.agents.shipped import POLICIES
    from rigid_env.envs import TASKS, VARIANTS, merge_kwargs
    from rigid_env.resources import find_data

    newest = {task.env_id: task.module for task in TASKS.values()}
    stems = newest | POLICIES
    out = {}
    for env_id, stem in stems.items():
        path = find_data(f"configs/agents/ppo_{stem}.yaml")
        config = yaml.safe_load(path.read_text(encoding="utf-8")) if path else {}
        shipped = dict(config.get("env_kwargs") or {})
        variant = VARIANTS.get(env_id.split("/")[-1])
        drawn = merge_kwargs(variant.kwargs if variant else {}, shipped)
        if env_id not in newest and _draws(drawn) == "none":
            continue  # an older version's policy drawing nothing: its task's newest stands
        nominal = {**shipped, "randomization": None, "sensors": None}
        out[short_id(env_id)] = Shipped(env_id, nominal, shipped, _draws(drawn))
    return out


def _random_cases(name: str, env_id: str, kwargs: dict[str, Any], n: int) -> tuple[list[Case], Any]:
    """The step and the reset of ``env_id``'s vector env of ``n`` envs made with ``kwargs``,
    and its task batch."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(8)]
    env.reset(seed=0)
    task, rngs = env.unwrapped.task, env.unwrapped._rngs
    rows = np.arange(0, n, min(RESET_EVERY, n))
    own = [rngs[i] for i in rows]
    i = 0

    def step() -> None:
        nonlocal i
        env.step(actions[i % len(actions)])
        i += 1

    cases = [
        Case(name, step, n, close=env.close),
        Case(name + RESET, lambda: task.reset_envs(rows, own), rows.size),
    ]
    return cases, task


def bench_random(cfg: Config, res: Results) -> None:
    """Env-steps/s and the cost of a reset per env, with and without the shipped draws, of
    every task and shipped policy; the four cases of an env interleaved round by round."""
    n = cfg.random_size
    for name, env in shipped_randomisations().items():
        cases, nominal = _random_cases(name, env.env_id, env.nominal, n)
        more, shipped = _random_cases(name + RANDOMISED, env.env_id, env.shipped, n)
        cases += more
        least = max(cfg.min_time, RANDOM_MIN_TIME) if cfg.min_time else 0.0  # (smoke: none)
        timings = measure(cases, min_time=least, repeats=cfg.repeats, clock=cfg.clock)
        # World steps per env step: each env's action repeat in the episode it ended the run in.
        world_steps = {name: float(nominal.repeats.mean()),
                       name + RANDOMISED: float(shipped.repeats.mean())}  # fmt: skip
        for case in (name, name + RANDOMISED):
            draws = env.draws if case != name else ""
            t, peer = timings[case], timings[name]
            res.rows.append(
                _row("random", case, n, "env_steps_per_s", "1/s", t, t.rate, peer=name,
                     ratio=t.rate / peer.rate, note=draws)
            )  # fmt: skip
            res.rows.append(
                Row("random", case + WORLD_STEPS, n, "world_steps_per_env_step",
                    world_steps[case], "1", peer=name + WORLD_STEPS,
                    ratio=world_steps[case] / world_steps[name])
            )  # fmt: skip
            t, peer = timings[case + RESET], timings[name + RESET]
            res.rows.append(
                _row("random", case + RESET, n, "us_per_reset_env", "us", t, t.per_unit * 1e6,
                     peer=name + RESET, ratio=t.per_unit / peer.per_unit)
            )  # fmt: skip
        del cases, more, nominal, shipped
        gc.collect()
        _log(f"  random {name}: done")
    res.notes["random"] = [
        f'`gym.make_vec(id, num_envs={n}, vectorization_mode="vector_entry_point", '
        "**env_kwargs)` of every task's newest version and every shipped policy's env, with "
        "its PPO config's `env_kwargs` (*randomised*: `configs/agents/ppo_<task>.yaml`, over a "
        "variant's own; none where a task ships no config) and with the same "
        "`randomization=None, sensors=None` (nominal). *draws*: what the randomised env draws "
        "(none: both rows are the same env, the noise floor). "
        "Steps: random actions drawn beforehand, autoreset as the env does it (an episode's "
        f"reset is part of the step's cost). Resets: `reset_envs` of every {RESET_EVERY}th env, "
        "each drawing from its own generator; cost per reset env. The four cases of an env "
        f"are timed round by round, each repeat at least {RANDOM_MIN_TIME:g} s (tens of steps, "
        "not the few after the start). Each env draws its sensor noise from its own generator; "
        "at N >= 1024 the draws are split over the cores.",
        "Ratios: env-steps/s over the nominal env's (higher is faster); time per reset env "
        "over the nominal env's (lower is faster). An action repeat (TumblingFall's config "
        "draws 2-5 world steps per env step) makes an env step several world steps: *world "
        "steps / env step* is the mean of the envs' drawn repeats at the end of the run, and "
        "*per world step* the step ratio times it (the cost of the draws themselves).",
        f"Bar (issue 45): randomised >= {STEP_BAR:g}x the nominal env-steps/s and a reset <= "
        f"{RESET_BAR:g}x the nominal one per env.",
    ]


# --------------------------------------------------------------------------------------------
# Command
# --------------------------------------------------------------------------------------------


MEASUREMENTS = {
    "core": bench_core,
    "env": bench_env,
    "vec": bench_vec,
    "effects": bench_effects,
    "ppo": bench_ppo,
    "random": bench_random,
}
"""Section name -> the function that measures it into :class:`Results`."""


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
        "--out", type=Path, default=Path("results/speed"), metavar="DIR",
        help="output folder for speed.md, speed.csv and speed.png (default: results/speed)",
    )  # fmt: skip
    parser.add_argument(
        "--quick", action="store_true", help="fewer sizes and repeats (about a minute)"
    )
    parser.add_argument(
        "--only", type=_sections, default=SECTIONS, metavar="S1,S2",
        help=f"measure only these sections: {', '.join(SECTIONS)} (default: all)",
    )  # fmt: skip
    parser.add_argument(
        "--repeats", type=int, default=None, metavar="K",
        help="repeats per case (default: 7, quick 5)",
    )  # fmt: skip
    parser.add_argument(
        "--clock", choices=CLOCKS, default="wall",
        help="wall: time.perf_counter (default); cpu: CPU time of the process, steadier on a "
        "busy machine (PPO always uses wall time)",
    )  # fmt: skip
    parser.add_argument("--force", action="store_true", help="overwrite earlier results in --out")
    parser.add_argument("--smoke", action="store_true", help=argparse.SUPPRESS)


def run(args: argparse.Namespace) -> int:
    """Measure, then write ``speed.md``, ``speed.csv`` and ``speed.png`` into ``args.out``."""
    cfg = SMOKE if args.smoke else QUICK if args.quick else FULL
    if args.repeats is not None:
        if args.repeats < 1:
            raise ValueError(f"--repeats: must be an integer >= 1, got {args.repeats}")
        cfg = replace(cfg, repeats=args.repeats)
    cfg = replace(cfg, clock=args.clock)
    out = report.prepare_out(args.out, OUTPUTS, args.force)
    sections = [s for s in SECTIONS if s in args.only]
    command = "rigid-env bench speed" + (" --quick" if args.quick else " --smoke" * args.smoke)
    command += (" --clock cpu" if cfg.clock == "cpu" else "") + (
        "" if tuple(sections) == SECTIONS else f" --only {','.join(sections)}"
    )
    date = datetime.now(timezone.utc).astimezone().strftime("%Y-%m-%d %H:%M %Z")
    load_start = report.load()
    res = Results(cfg)
    start = time.perf_counter()
    _log(f"speed benchmark ({cfg.name}): {', '.join(sections)}")
    for name in sections:
        t0 = time.perf_counter()
        MEASUREMENTS[name](cfg, res)
        _log(f"{name}: {time.perf_counter() - t0:.1f} s")
    wall = time.perf_counter() - start
    write(res, out, sections, command=command, date=date, load_start=load_start, wall=wall)
    print(f"wrote {out / 'speed.md'}, {out / 'speed.csv'}, {out / 'speed.png'} ({wall:.0f} s)")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m rigid_env.bench.speed [flags]``: the same as ``rigid-env bench speed``."""
    from rigid_env.cli import main as cli_main

    return cli_main(["bench", "speed", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    raise SystemExit(main())
