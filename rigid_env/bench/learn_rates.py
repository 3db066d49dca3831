"""Three rates of each learner on one task, in one run: env step; step + inference; step +
inference + training (issue 45).

    rigid-env bench learn --rates-only [--tasks detumble] [--learners sb3 rsl_rl skrl sbx]
                          [--repeats 3] [--threads 1] [--out DIR] [--force]

Learners: ``sb3`` (the SB3 path with the task's shipped config, ``configs/agents/ppo_<task>
.yaml``: its own n_envs and rollout), ``rsl_rl`` (``configs/agents/rsl_ppo_<task>.yaml``, the
learner of :mod:`rigid_env.agents.parallel`), ``skrl`` (skrl's PPO, the peer rsl-rl was chosen
against, on the rsl_rl config's envs and PPO arguments) and ``sbx`` (sbx-rl's PPO, whose update
is one JIT-compiled function per minibatch, on the same config). Each learner steps its own env
stack (SB3's ``VecNormalize`` over the batched task, same-step resets), with zero commands for
the first rate, over one whole episode of every env (the body coasts and its episode ends at the
time limit, so each env's reset, costly under randomisation, counts once per episode; uniform
random commands spin it past the task's bounds and resets would set the rate) and its own policy
for the others; *+ inference* is what a rollout does per step (the policy and value forward,
sampling, the step), *full* is the learner's own training loop over whole rollouts, updates
included. Every learner runs on ``--threads`` torch and Numba threads (default 1: on a shared
machine a second thread that finds its core busy spins and costs more than it gives). Each rate
is the median of ``--repeats`` timed stretches of at least 2 s (whole rollouts), the learners
interleaved (a stretch of each in turn), after a warm-up stretch that compiles the kernels;
every stretch also spans at least the task's time limit in vector steps (whole rollouts), so
that each rate pays the resets once per env and episode (under the training randomisation a
reset rebuilds the env's model, about 1 ms per env here: a stretch of one rollout would count
them in one stretch and miss them in the next). *update's share* is the part of the full rate's
wall-clock spent in the learner's update (SB3's and sbx-rl's ``train``, rsl-rl's and skrl's
``update``: every epoch's forward, backward and optimiser step); the rest is the rollout.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rigid_env.resources import data_path, find_data

LEARNERS = ("sb3", "rsl_rl", "skrl", "sbx")
STRETCH_S = 2.0
"""Least wall-clock of one timed stretch (whole rollouts, repeated until it is reached)."""
RATES = ("env", "inference", "full")


@dataclass(frozen=True)
class RateRow:
    """The three rates of one learner on one task [env-steps/s]."""

    task: str
    learner: str
    config: str
    n_envs: int
    n_steps: int
    batch_size: int
    threads: int
    env: float
    inference: float
    full: float
    update_share: float  # of the full rate's wall-clock, the update's (median of the stretches)


UPDATE_SECONDS = [0.0]
"""Wall-clock spent in the learners' updates so far (:func:`_time_calls`)."""


def _time_calls(obj: Any, name: str) -> None:
    """Add the wall-clock of every call of ``obj.name`` (the learner's update: SB3's and
    sbx-rl's ``train``, rsl-rl's and skrl's ``update``) to :data:`UPDATE_SECONDS`."""
    method = getattr(obj, name)

    def timed(*args: Any, **kwargs: Any) -> Any:
        t = time.perf_counter()
        try:
            return method(*args, **kwargs)
        finally:
            UPDATE_SECONDS[0] += time.perf_counter() - t

    setattr(obj, name, timed)


def _episode(cfg: Any) -> int:
    """The task's time limit in steps: one env-rate stretch, so that every env's reset counts
    once per episode (coasting envs all end together, at the limit)."""
    import gymnasium as gym

    return int(gym.spec(cfg.env_id).max_episode_steps)


def _coasting(step: Callable[[Any], Any], action: Any, n: int, episode: int) -> Callable[[], int]:
    """The env rate's stretch: ``episode`` steps of the ``n`` envs under the fixed ``action``
    (zero commands: no policy in the loop); returns the env-steps it made."""

    def env() -> int:
        for _ in range(episode):
            step(action)
        return n * episode

    return env


def _sb3(cfg: Any) -> dict[str, Callable[[], int]]:
    """Stretches of the SB3 path, each returning the env-steps it made."""
    import torch
    from stable_baselines3.common.utils import obs_as_tensor

    from rigid_env.agents.train import _new_model, make_vec_env

    venv = make_vec_env(cfg, cfg.n_envs, cfg.seed)
    model = _new_model(cfg, venv, Path("/nonexistent"), 0)
    _time_calls(model, "train")
    model.tensorboard_log = None
    n, steps, episode = cfg.n_envs, model.n_steps, _episode(cfg)
    low, high = venv.action_space.low, venv.action_space.high
    coast = np.zeros((n, len(low)), dtype=np.float32)
    state = {"obs": venv.reset()}

    env = _coasting(venv.step, coast, n, episode)

    def inference() -> int:
        obs = state["obs"]
        for _ in range(steps):
            with torch.no_grad():
                actions, _, _ = model.policy(obs_as_tensor(obs, model.device))
            obs, *_ = venv.step(np.clip(actions.numpy(), low, high))
        state["obs"] = obs
        return n * steps

    def full() -> int:
        before = model.num_timesteps
        model.learn(n * steps, reset_num_timesteps=False)
        return model.num_timesteps - before

    return {"env": env, "inference": inference, "full": full}


def _rsl(cfg: Any) -> dict[str, Callable[[], int]]:
    import gymnasium as gym
    import torch

    from rigid_env.agents.parallel.learner import make_runner, ppo_arguments
    from rigid_env.agents.train import make_vec_env

    venv = make_vec_env(cfg, cfg.n_envs, cfg.seed)
    runner = make_runner(cfg, venv, int(gym.spec(cfg.env_id).max_episode_steps))
    _time_calls(runner.alg, "update")
    env_ = runner.env
    n, steps, episode = cfg.n_envs, ppo_arguments(cfg)["n_steps"], _episode(cfg)

    env = _coasting(env_.step, torch.zeros(n, env_.num_actions), n, episode)

    def inference() -> int:
        obs = env_.get_observations()
        with torch.inference_mode():
            for _ in range(steps):
                actions = runner.alg.act(obs)
                obs, *_ = env_.step(actions)
                runner.alg.transition.clear()
        return n * steps

    def full() -> int:
        runner.learn(1)
        return n * steps

    return {"env": env, "inference": inference, "full": full}


def _skrl(cfg: Any) -> dict[str, Callable[[], int]]:
    import torch

    from rigid_env.agents.parallel.learner import ppo_arguments
    from rigid_env.agents.parallel.skrl_peer import make_skrl, train_steps
    from rigid_env.agents.train import make_vec_env

    venv = make_vec_env(cfg, cfg.n_envs, cfg.seed)
    agent, env_ = make_skrl(cfg, venv)
    _time_calls(agent, "update")
    n, steps, episode = cfg.n_envs, ppo_arguments(cfg)["n_steps"], _episode(cfg)
    state = {"obs": env_.reset()[0]}

    env = _coasting(env_.step, torch.zeros(n, len(venv.action_space.low)), n, episode)

    def inference() -> int:
        obs = state["obs"]
        with torch.no_grad():
            for t in range(steps):
                actions, _ = agent.act(obs, None, timestep=t, timesteps=steps)
                obs, *_ = env_.step(actions)
        state["obs"] = obs
        return n * steps

    def full() -> int:
        state["obs"] = train_steps(agent, env_, steps, state["obs"])
        return n * steps

    return {"env": env, "inference": inference, "full": full}


def _sbx(cfg: Any) -> dict[str, Callable[[], int]]:
    from rigid_env.agents.parallel.learner import ppo_arguments
    from rigid_env.agents.parallel.sbx_peer import make_sbx, sample
    from rigid_env.agents.train import make_vec_env

    venv = make_vec_env(cfg, cfg.n_envs, cfg.seed)
    model = make_sbx(cfg, venv)
    _time_calls(model, "train")
    n, steps, episode = cfg.n_envs, ppo_arguments(cfg)["n_steps"], _episode(cfg)
    coast = np.zeros((n, len(venv.action_space.low)), dtype=np.float32)
    state = {"obs": venv.reset()}

    env = _coasting(venv.step, coast, n, episode)

    def inference() -> int:
        obs = state["obs"]
        for _ in range(steps):
            actions, _ = sample(model, obs)
            obs, *_ = venv.step(actions)
        state["obs"] = obs
        return n * steps

    def full() -> int:
        before = model.num_timesteps
        model.learn(n * steps, reset_num_timesteps=False)
        return model.num_timesteps - before

    return {"env": env, "inference": inference, "full": full}


BUILDERS = {"sb3": _sb3, "rsl_rl": _rsl, "skrl": _skrl, "sbx": _sbx}


CONFIG_STEMS = {"shipped": "ppo_", "previous": "previous/ppo_", "rsl_rl": "rsl_ppo_"}
"""The file name's stem of each kind of PPO config a task may have in ``configs/agents/``: the
shipped SB3 config, the one before issue 24, and the rsl-rl learner's."""


def config_file(task: str, kind: str) -> str:
    """``configs/agents/<stem><task>.yaml`` of ``kind`` (:data:`CONFIG_STEMS`), in the data."""
    return f"configs/agents/{CONFIG_STEMS[kind]}{task}.yaml"


def config_of(task: str, learner: str) -> Path:
    """The config a learner runs ``task`` with (skrl and sbx: the rsl_rl one); ValueError (one
    line) where the task has none for it."""
    relative = config_file(task, "shipped" if learner == "sb3" else "rsl_rl")
    if find_data(relative) is None:
        raise ValueError(f"--learners: {learner} has no config for {task} ({relative}); leave "
                         f"{task} out of --tasks or {learner} out of --learners")  # fmt: skip
    return data_path(relative)


def measure(
    task: str,
    learners: tuple[str, ...],
    repeats: int,
    threads: int,
    n_envs: int | None = None,
    stretch_s: float = STRETCH_S,
    whole_episodes: bool = True,
    sbx_config: Path | None = None,
    sb3_threads: int | None = None,
) -> list[RateRow]:
    """The rates of ``learners`` on ``task``, interleaved, medians of ``repeats``; ``n_envs``
    replaces the rsl_rl config's (rsl_rl and skrl), its minibatch scaled with it (the same
    number of minibatches per rollout); ``sbx_config`` replaces sbx's config. A timed stretch
    lasts at least ``stretch_s`` and, with ``whole_episodes``, one episode's length of vector
    steps, so that every rate counts the resets at their rate in training (one per env and
    episode). Every learner runs on ``threads`` torch and Numba threads, the SB3 path on
    ``sb3_threads`` where given (the guide's allotment: one per SB3 run, two runs at once,
    while a parallel learner may take both cores); the process's counts are restored after."""
    import importlib.util

    from rigid_env.agents.config import load_config

    own = {k: sb3_threads if k == "sb3" and sb3_threads else threads for k in learners}
    if "sbx" in learners and own["sbx"] == 1:  # XLA's CPU client on one thread, like torch's
        from rigid_env.bench.learn_sbx import one_xla_thread

        one_xla_thread()
    for k, module in (("rsl_rl", "rsl_rl"), ("skrl", "skrl"), ("sbx", "sbx")):
        if k in learners and importlib.util.find_spec(module) is None:
            raise ValueError(f"--learners: {k} is not installed; pip install 'rigid_env[bench]', "
                             f"or leave {k} out of --learners")  # fmt: skip
    paths = {k: config_of(task, k) for k in learners}
    if sbx_config is not None and "sbx" in paths:
        paths["sbx"] = sbx_config
    cfgs = {k: load_config(paths[k], {"threads": own[k]}) for k in learners}
    for k in learners:
        if k != "sb3" and n_envs is not None:
            hp = cfgs[k].hyperparams.model_dump(exclude_none=True)
            hp["batch_size"] = hp["batch_size"] * n_envs // cfgs[k].n_envs
            wider = {"threads": own[k], "n_envs": n_envs, "hyperparams": hp}
            cfgs[k] = load_config(paths[k], wider)
    import numba
    import torch

    before = torch.get_num_threads(), numba.get_num_threads()
    try:
        return _interleaved(task, learners, repeats, own, paths, cfgs, stretch_s, whole_episodes)
    finally:
        torch.set_num_threads(before[0])
        numba.set_num_threads(before[1])


def _interleaved(
    task: str,
    learners: tuple[str, ...],
    repeats: int,
    own: dict[str, int],
    paths: dict[str, Path],
    cfgs: dict[str, Any],
    stretch_s: float,
    whole_episodes: bool,
) -> list[RateRow]:
    """:func:`measure`'s stretches, learner ``k`` on ``own[k]`` threads."""
    from rigid_env.agents.parallel.learner import ppo_arguments
    from rigid_env.agents.train import limit_threads

    stretches = {}
    for k in learners:
        limit_threads(own[k])
        stretches[k] = BUILDERS[k](cfgs[k])
    for k in learners:  # warm-up: compile the kernels, fill torch's caches
        limit_threads(own[k])
        for rate in RATES:
            stretches[k][rate]()
    seconds: dict[tuple[str, str], list[float]] = {}
    shares: dict[str, list[float]] = {}
    for _ in range(repeats):
        for rate in RATES:
            for k in learners:
                limit_threads(own[k])
                t, made, u = time.perf_counter(), 0, UPDATE_SECONDS[0]
                least = cfgs[k].n_envs * _episode(cfgs[k]) if whole_episodes else 1
                while made < least or time.perf_counter() - t < stretch_s:
                    made += stretches[k][rate]()
                wall = time.perf_counter() - t
                seconds.setdefault((k, rate), []).append(made / wall)
                if rate == "full":
                    shares.setdefault(k, []).append((UPDATE_SECONDS[0] - u) / wall)
    rows = []
    for k in learners:
        a = ppo_arguments(cfgs[k])
        rates = {rate: float(np.median(seconds[(k, rate)])) for rate in RATES}
        rows.append(RateRow(task, k, paths[k].name, cfgs[k].n_envs, a["n_steps"],
                            a["batch_size"], own[k], **rates,
                            update_share=float(np.median(shares[k]))))  # fmt: skip
    return rows


def markdown(rows: list[RateRow]) -> list[str]:
    """The rates table, with each learner's full rate against the SB3 path's."""
    lines = [
        "| task | learner | config | n_envs x n_steps | minibatch | threads | env [steps/s] | "
        "+ inference [steps/s] | full PPO [steps/s] | full / SB3's | update's share of full |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        sb3 = next((s.full for s in rows if s.task == r.task and s.learner == "sb3"), np.nan)
        lines.append(
            f"| {r.task} | {r.learner} | {r.config} | {r.n_envs} x {r.n_steps} | "
            f"{r.batch_size} | {r.threads} | {r.env:,.0f} | {r.inference:,.0f} | {r.full:,.0f} | "
            f"{r.full / sb3:.1f}x | {100 * r.update_share:.0f} % |"
        )
    return lines
