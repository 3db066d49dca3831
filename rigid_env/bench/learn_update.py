"""What one PPO minibatch update costs per sample: torch eager against ``jax.jit`` (issue 45).

    python -m rigid_env.bench.learn_update [256 1024 4096 16384]
    python -m rigid_env.bench.learn_update --split [CONFIG]

The update of the learners here (SB3, rsl-rl and skrl run it eagerly in torch; sbx-rl as one
``jax.jit``-compiled function): the clipped surrogate and the value loss of two [64, 64] tanh
MLPs (actor and critic; Detumble's 10 observations, 3 actions), backward, the gradient clipped
to norm 0.5, one Adam step, on one thread each (``torch.set_num_threads(1)``; XLA on the calling
thread). The two are interleaved, five stretches of 0.5 s each per minibatch size; printed are
the medians of wall-clock and process CPU time per sample (on a shared machine CPU time says
more: a busy neighbour stretches wall-clock, not CPU time). Needs
``pip install 'rigid_env[bench]'``.

``--split`` trains SB3's PPO and sbx-rl's on one config (default SB3's shipped Detumble one)
and prints, in process CPU time, the first iteration (sbx-rl: XLA compiles) and then, over 12
iterations, the rollout (``collect_rollouts``) and the update (``train``) per iteration.
"""

from __future__ import annotations

import sys
import time

import numpy as np

OBS, ACT, HIDDEN = 10, 3, 64


def measure(minibatches: list[int], stretch_s: float = 0.5, repeats: int = 5) -> list[str]:
    """One line per minibatch size: wall-clock and CPU microseconds per sample of each."""
    from rigid_env.bench.learn_sbx import one_xla_thread

    one_xla_thread()
    import jax
    import jax.numpy as jnp
    import optax
    import torch

    torch.set_num_threads(1)

    def mlp(out: int) -> torch.nn.Sequential:
        return torch.nn.Sequential(torch.nn.Linear(OBS, HIDDEN), torch.nn.Tanh(),
                                   torch.nn.Linear(HIDDEN, HIDDEN), torch.nn.Tanh(),
                                   torch.nn.Linear(HIDDEN, out))  # fmt: skip

    actor, critic = mlp(ACT), mlp(1)
    log_std = torch.nn.Parameter(torch.zeros(ACT))
    weights = [*actor.parameters(), *critic.parameters(), log_std]
    opt = torch.optim.Adam(weights, lr=1e-3)

    def torch_update(obs, act, adv, ret, old_log_prob) -> None:
        log_prob = torch.distributions.Normal(actor(obs), log_std.exp()).log_prob(act).sum(-1)
        ratio = (log_prob - old_log_prob).exp()
        a = (adv - adv.mean()) / (adv.std() + 1e-8)
        policy = -torch.min(a * ratio, a * ratio.clamp(0.8, 1.2)).mean()
        loss = policy + 0.5 * ((critic(obs).squeeze(-1) - ret) ** 2).mean()
        opt.zero_grad()
        loss.backward()
        torch.nn.utils.clip_grad_norm_(weights, 0.5)
        opt.step()

    def init(key: jax.Array, out: int) -> list[tuple[jax.Array, jax.Array]]:
        shapes = [(OBS, HIDDEN), (HIDDEN, HIDDEN), (HIDDEN, out)]
        keys = jax.random.split(key, len(shapes))
        return [(jax.random.normal(k, s) / np.sqrt(s[0]), jnp.zeros(s[1]))
                for k, s in zip(keys, shapes, strict=True)]  # fmt: skip

    def forward(layers, x):
        for w, b in layers[:-1]:
            x = jnp.tanh(x @ w + b)
        w, b = layers[-1]
        return x @ w + b

    def loss(p, obs, act, adv, ret, old_log_prob):
        z = (act - forward(p["actor"], obs)) / jnp.exp(p["log_std"])
        log_prob = (-0.5 * z**2 - p["log_std"] - 0.5 * np.log(2 * np.pi)).sum(-1)
        ratio = jnp.exp(log_prob - old_log_prob)
        a = (adv - adv.mean()) / (adv.std() + 1e-8)
        policy = -jnp.minimum(a * ratio, a * jnp.clip(ratio, 0.8, 1.2)).mean()
        return policy + 0.5 * ((forward(p["critic"], obs)[:, 0] - ret) ** 2).mean()

    tx = optax.chain(optax.clip_by_global_norm(0.5), optax.adam(1e-3))
    params = {"actor": init(jax.random.PRNGKey(0), ACT), "critic": init(jax.random.PRNGKey(1), 1),
              "log_std": jnp.zeros(ACT)}  # fmt: skip
    state = [params, tx.init(params)]

    @jax.jit
    def jax_step(p, s, *batch):
        updates, s = tx.update(jax.grad(loss)(p, *batch), s, p)
        return optax.apply_updates(p, updates), s

    def jax_update(*batch) -> None:
        state[:] = jax_step(*state, *batch)
        jax.block_until_ready(state[0])

    rng = np.random.default_rng(0)
    lines = []
    for mb in minibatches:
        shapes = [(mb, OBS), (mb, ACT), (mb,), (mb,), (mb,)]
        batch = [rng.normal(size=s).astype(np.float32) for s in shapes]
        tensors = [torch.from_numpy(b) for b in batch]
        runs = {"torch": (torch_update, tensors), "jax.jit": (jax_update, batch)}
        for fn, args in runs.values():  # warm-up (XLA compiles here)
            for _ in range(3):
                fn(*args)
        wall: dict[str, list[float]] = {k: [] for k in runs}
        cpu: dict[str, list[float]] = {k: [] for k in runs}
        for _ in range(repeats):
            for k, (fn, args) in runs.items():
                t, c, n = time.perf_counter(), time.process_time(), 0
                while time.perf_counter() - t < stretch_s:
                    fn(*args)
                    n += 1
                wall[k].append((time.perf_counter() - t) / n / mb * 1e6)
                cpu[k].append((time.process_time() - c) / n / mb * 1e6)
        w = {k: float(np.median(v)) for k, v in wall.items()}
        c = {k: float(np.median(v)) for k, v in cpu.items()}
        lines.append(f"| {mb} | {w['torch']:.2f} | {w['jax.jit']:.2f} | {c['torch']:.2f} | "
                     f"{c['jax.jit']:.2f} | {c['torch'] / c['jax.jit']:.1f}x |")  # fmt: skip
    return lines


def split(config: str, iterations: int = 12) -> list[str]:
    """CPU seconds of SB3's and sbx-rl's first iteration, then rollout and update per
    iteration, on ``config`` (one line each)."""
    from pathlib import Path

    from rigid_env.bench.learn_sbx import one_xla_thread

    one_xla_thread()
    from rigid_env.agents.config import load_config
    from rigid_env.agents.parallel.sbx_peer import make_sbx
    from rigid_env.agents.train import _new_model, limit_threads, make_vec_env

    limit_threads(1)
    cfg = load_config(Path(config), {"threads": 1})
    lines = []
    for who in ("sb3", "sbx"):
        venv = make_vec_env(cfg, cfg.n_envs, cfg.seed)
        if who == "sb3":
            model = _new_model(cfg, venv, Path("/nonexistent"), 0)
            model.tensorboard_log = None
        else:
            model = make_sbx(cfg, venv)
        spent = {"collect_rollouts": 0.0, "train": 0.0}
        for name in spent:
            method = getattr(model, name)

            def timed(*a, _method=method, _name=name, _spent=spent, **k):
                c = time.process_time()
                try:
                    return _method(*a, **k)
                finally:
                    _spent[_name] += time.process_time() - c

            setattr(model, name, timed)
        steps = cfg.n_envs * model.n_steps
        c = time.process_time()
        model.learn(steps)
        first = time.process_time() - c
        spent.update(dict.fromkeys(spent, 0.0))
        c = time.process_time()
        model.learn(steps * iterations, reset_num_timesteps=False)
        cpu = time.process_time() - c
        lines.append(f"{who}: first iteration {first:.2f} CPU-s; then "
                     f"{steps * iterations / cpu:,.0f} env-steps per CPU-s, rollout "
                     f"{spent['collect_rollouts'] / iterations * 1e3:.0f} ms + update "
                     f"{spent['train'] / iterations * 1e3:.0f} ms CPU per iteration of "
                     f"{steps} env-steps")  # fmt: skip
        venv.close()
    return lines


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if args[:1] == ["--split"]:
        from rigid_env.resources import data_path

        config = args[1] if len(args) > 1 else str(data_path("configs/agents/ppo_detumble.yaml"))
        print("\n".join(split(config)))
        return 0
    minibatches = [int(a) for a in args] or [256, 1024, 4096, 16384]
    if any(m < 2 for m in minibatches):
        print("learn_update: each minibatch size must be >= 2 (advantages are normalised)")
        return 2
    from rigid_env.bench import report

    print(f"{report.machine()}; load {report.load()}")
    print("| minibatch | torch wall [us/sample] | jax.jit wall | torch CPU [us/sample] | "
          "jax.jit CPU | CPU torch / jax.jit |\n|---|---|---|---|---|---|")  # fmt: skip
    for line in measure(minibatches):
        print(line, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
