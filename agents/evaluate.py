"""Evaluate a trained policy beside the analytic, zero and random controllers on the same seeds.

    python -m agents.evaluate MODEL.zip --env RigidEnv/Detumble-v0 --episodes 100 --seed 12345
                              [--env-kwargs JSON|KEY=VALUE ...] [--json] [--video out.gif]
                              [--force] [--only model,pd,zero,random]

``MODEL`` may also be ``none`` (controllers only). What a model was trained on comes from its
JSON sidecar ``<model>.json`` (``agents.train`` writes one beside every model it saves: the
final ``model.zip``, ``eval/best_model.zip``, each checkpoint): the env id, the ``env_kwargs``
and the file of its ``VecNormalize`` statistics. One rule for every model, a user's run and a
pretrained policy alike: it is evaluated on the sidecar's ``env_kwargs``, which
``agents.train`` writes as the task it was trained on *without* the training randomisation
(``trained_env_kwargs`` keeps what it trained under), with ``--env-kwargs`` merged over that (so
``--env-kwargs '{"randomization": {"inertia": 0.9}}'`` evaluates under +-90 % inertia); every
policy, the controllers too, runs with the merged set. A model without a sidecar (from
elsewhere) gets its statistics from ``<model>_vecnormalize.pkl``,
``model_vecnormalize_<N>_steps.pkl`` (checkpoint ``model_<N>_steps.zip``) or
``vecnormalize.pkl`` (``model.zip``), and a warning if none exists.
A sidecar that names statistics which are missing, corrupted or for another observation shape
is an error, never a silent evaluation on raw observations; so is an env on which an action
means something else than the model's (:mod:`agents.meaning`: the actuators, their limits,
BdotDetumble's ``command``), as the record inside the model file says (``agents.train`` writes
one; a model without it falls back on its sidecar's env, and is played with a warning where
it has neither). A save that a kill interrupted
after its commit (sidecar with ``staged``) is evaluated from its staging folder.

SB3 model files are pickles: load only files you trust.

Episode ``k`` of every policy uses seed ``seed + k`` (the environment's reset draw), so the
policies face exactly the same initial spins and targets. Metrics per policy:
``success_rate`` (``info["success"]`` at the episode's last step), ``mean_final_angular_speed``
[rad/s], ``mean_fuel`` [N s], ``mean_return``, ``mean_time_to_success`` [s] (first step with
``success``, averaged over the episodes that end in success; ``null`` in JSON and ``-`` in the
table when none does), ``numerical_errors``.
"""

from __future__ import annotations

import json
import os
import pickle
import re
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import rigid_env  # noqa: F401  (registers the ids)
from rigid_env.envs import ALL_ENV_IDS
from rigid_env.resources import find_data

from ._cli import OneLineParser, integer, path
from .controllers import CONTROLLERS
from .env_kwargs import check_env_kwargs, merge_env_kwargs, parse_env_kwargs
from .meaning import meaning_of, mismatch, recorded_meaning

Policy = Callable[[np.ndarray], np.ndarray]


class EvaluationError(ValueError):
    """A user mistake (missing model, model for another env, ...); one line."""


def run_episodes(
    env_id: str, policy: Policy, episodes: int, seed: int, env_kwargs: dict[str, Any] | None = None
) -> dict[str, np.ndarray]:
    """Run ``episodes`` episodes at once in the native vector env (episode ``k`` resets with
    ``seed + k``); per-episode arrays ``(episodes,)``: ``success``, ``final_angular_speed``
    [rad/s], ``fuel`` [N s], ``return``, ``length`` [steps], ``time_to_success`` [s] (the end of
    the step in which success first holds, a step lasting ``k dt`` where an action is held for
    ``k`` world steps; NaN where the episode does not end in success) and
    ``numerical_error``; on an env that draws thruster faults also ``fault_kind`` (index in
    :data:`~rigid_env.envs.hardware.FAULT_KINDS`, -1: none) and ``fault_active`` (the fault
    had started when the episode ended), as its last ``info`` reports them."""
    env = gym.make_vec(
        env_id, num_envs=episodes, vectorization_mode="vector_entry_point", **(env_kwargs or {})
    )
    task = env.unwrapped.task if hasattr(env.unwrapped, "task") else env.task
    dt = task.dt
    obs, info = env.reset(seed=seed)
    n = episodes
    returns = np.zeros(n)
    done = np.zeros(n, dtype=bool)
    length = np.zeros(n, dtype=np.int64)
    final_speed = np.zeros(n)
    fuel = np.zeros(n)
    success = np.zeros(n, dtype=bool)
    first_success = np.full(n, np.nan)
    numerical = np.zeros(n, dtype=bool)
    faults = "fault_kind" in info
    fault_kind = np.full(n, -1, dtype=np.int64)
    fault_active = np.zeros(n, dtype=bool)
    step = 0
    world_steps = np.zeros(n, dtype=np.int64)  # of dt each: a step holds its action repeats
    while not done.all():
        action = policy(obs)
        step += 1
        world_steps += task.repeats  # the episode's (an autoreset draws anew only after its end)
        obs, reward, terminated, truncated, info = env.step(action)
        live = ~done
        returns[live] += reward[live]
        hit = live & info["success"] & np.isnan(first_success)
        first_success[hit] = world_steps[hit] * dt
        ended = live & (terminated | truncated)
        length[ended] = step
        final_speed[ended] = info["angular_speed"][ended]
        fuel[ended] = info["fuel"][ended]
        success[ended] = info["success"][ended]
        numerical[ended] = info["numerical_error"][ended]
        if faults:
            fault_kind[ended] = info["fault_kind"][ended]
            fault_active[ended] = info["fault_active"][ended]
        done |= ended
    env.close()
    # An episode that touched success and lost it again has no time to success.
    first_success[~success] = np.nan
    out = {
        "success": success,
        "final_angular_speed": final_speed,
        "fuel": fuel,
        "return": returns,
        "length": length,
        "time_to_success": first_success,
        "numerical_error": numerical,
    }
    if faults:
        out.update(fault_kind=fault_kind, fault_active=fault_active)
    return out


def rollout(
    env_id: str, policy: Policy, episodes: int, seed: int, env_kwargs: dict[str, Any] | None = None
) -> dict[str, Any]:
    """The metrics of :func:`run_episodes`, averaged."""
    ep = run_episodes(env_id, policy, episodes, seed, env_kwargs)
    success = ep["success"]
    return {
        "episodes": episodes,
        "success_rate": float(success.mean()),
        "mean_final_angular_speed": float(ep["final_angular_speed"].mean()),
        "mean_fuel": float(ep["fuel"].mean()),
        "mean_return": float(ep["return"].mean()),
        "mean_time_to_success": (
            float(ep["time_to_success"][success].mean()) if success.any() else None
        ),
        "numerical_errors": int(ep["numerical_error"].sum()),
    }


def read_sidecar(model_path: Path) -> dict[str, Any] | None:
    """The model's JSON sidecar (``<stem>.json``; ``model.json`` for ``model.zip``), or None.

    Raises:
        EvaluationError: the sidecar is not valid JSON or has wrong fields.
    """
    path = model_path.with_suffix(".json")
    if not path.exists():
        return None
    try:
        meta = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise EvaluationError(
            f"{path}: not a valid JSON sidecar ({exc}); restore it, or delete it to evaluate "
            "the model without its record"
        ) from None
    problems = [
        f"{key} must be {kind}"
        for key, kind, ok in (
            ("env_id", "a string", lambda v: isinstance(v, str)),
            ("env_kwargs", "a mapping", lambda v: isinstance(v, dict)),
            ("algo", "one of ppo, sac, td3", lambda v: v in ("ppo", "sac", "td3")),
            ("vecnormalize", "a file name or null", lambda v: v is None or isinstance(v, str)),
        )
        if not isinstance(meta, dict) or (key in meta and not ok(meta[key]))
    ]
    if problems:
        raise EvaluationError(
            f"{path}: {problems[0]}; fix the sidecar agents.train wrote, or delete it"
        )
    return meta


def find_normalization(model_path: Path, meta: dict[str, Any] | None) -> Path | None:
    """The ``VecNormalize`` statistics a run wrote for ``model_path`` (None: there are none).

    Raises:
        EvaluationError: the sidecar names statistics that are not there.
    """
    if meta is not None and "vecnormalize" in meta:
        if meta["vecnormalize"] is None:
            return None
        path = model_path.parent / meta["vecnormalize"]
        if not path.exists():
            raise EvaluationError(
                f"{path}: missing; {model_path.name} was trained on normalised observations "
                "and evaluating it without these statistics would be wrong; restore the file"
            )
        return path
    stem = model_path.with_suffix("").name
    candidates = [model_path.parent / f"{stem}_vecnormalize.pkl"]
    m = re.fullmatch(r"(.*)_(\d+)_steps", stem)
    if m is not None:
        candidates.append(model_path.parent / f"{m.group(1)}_vecnormalize_{m.group(2)}_steps.pkl")
    if stem == "model":
        candidates.append(model_path.parent / "vecnormalize.pkl")
    found = next((p for p in candidates if p.exists()), None)
    if found is None:
        print(
            f"agents.evaluate: warning: {model_path}: no sidecar and no VecNormalize statistics "
            f"({candidates[0].name}); evaluating on raw observations",
            file=sys.stderr,
        )
    return found


def _load_normalization(path: Path, obs_shape: tuple[int, ...]) -> Any:
    from stable_baselines3.common.vec_env import VecNormalize

    try:
        with open(path, "rb") as fh:
            norm = pickle.load(fh)  # trusted: written by agents.train
    except Exception as exc:  # a truncated or foreign pickle raises almost anything
        raise EvaluationError(
            f"{path}: not readable VecNormalize statistics ({type(exc).__name__}); "
            "restore the file agents.train wrote for this model"
        ) from None
    if not isinstance(norm, VecNormalize):
        raise EvaluationError(
            f"{path}: holds a {type(norm).__name__}, not VecNormalize statistics; "
            "restore the file agents.train wrote for this model"
        )
    shape = tuple(np.shape(norm.obs_rms.mean)) if norm.norm_obs else obs_shape
    if shape != obs_shape:
        raise EvaluationError(
            f"{path}: statistics for observations of shape {shape}, the model sees {obs_shape}; "
            "use the statistics saved with this model"
        )
    return norm


def load_policy(model_path: Path, env_id: str, env_kwargs: dict[str, Any] | None = None) -> Policy:
    """A deterministic policy function from an SB3 zip (+ its ``VecNormalize`` statistics).

    Raises:
        EvaluationError: the model or its companions are missing or wrong, or the model was
            trained on another env or on observations of another shape.
    """
    if not model_path.exists():
        shipped = find_data("agents/pretrained")  # where this install keeps them
        use = f" or use a shipped policy, {shipped}/*.zip" if shipped is not None else ""
        raise EvaluationError(
            f"{model_path}: model file not found; train one with `python -m agents.train`{use}"
        )
    meta = read_sidecar(model_path)
    staged = model_path.parent / str((meta or {}).get("staged", ""))
    if meta is not None and "staged" in meta and staged.is_dir():
        model_path = staged / model_path.name  # saved whole, not yet moved in (a killed run)
    algo = None
    if meta is not None:
        if meta.get("env_id") not in (None, env_id):
            raise EvaluationError(
                f"{model_path}: trained on {meta['env_id']}, not {env_id}; "
                f"pass --env {meta['env_id']}"
            )
        algo = meta.get("algo")
    from stable_baselines3 import PPO, SAC, TD3

    classes = {"ppo": PPO, "sac": SAC, "td3": TD3}
    model = None
    for cls in [classes[algo]] if algo in classes else list(classes.values()):
        try:
            model = cls.load(str(model_path), device="cpu")
            break
        except Exception:
            continue
    if model is None:
        raise EvaluationError(f"{model_path}: not a loadable SB3 PPO/SAC/TD3 model file")
    kwargs = env_kwargs or {}
    probe = _probe(env_id, kwargs)
    if (
        model.observation_space.shape != probe.observation_space.shape
        or model.action_space.shape != probe.action_space.shape
    ):
        recorded = f" (its sidecar records env_kwargs {meta['env_kwargs']})" if meta else ""
        if kwargs.get("observe_control_period") and model.action_space.shape == (
            probe.action_space.shape
        ):
            recorded += (
                "; observe_control_period=True appends the control period to the observation, "
                "one number the model was not trained to observe: leave the option out"
            )
        raise EvaluationError(
            f"{model_path}: observes {model.observation_space.shape} and acts "
            f"{model.action_space.shape}, but {env_id} with env_kwargs {kwargs} gives "
            f"{probe.observation_space.shape} and {probe.action_space.shape}; use the env and "
            f"env_kwargs it was trained with{recorded}"
        )
    try:
        _check_action_meaning(model_path, meta, env_id, probe)
    finally:
        probe.close()
    norm_path = find_normalization(model_path, meta)
    norm = (
        None if norm_path is None else _load_normalization(norm_path, model.observation_space.shape)
    )
    width = int(np.prod(model.observation_space.shape))

    def policy(obs: np.ndarray) -> np.ndarray:
        obs = np.asarray(obs)
        if obs.ndim not in (1, 2) or obs.shape[-1] != width:
            raise EvaluationError(
                f"{model_path.name}: observes {width} numbers per env, got an observation of "
                f"shape {obs.shape}; give (N, {width}) or ({width},), from the env and "
                "env_kwargs it was trained with"
            )
        if norm is not None and norm.norm_obs:
            obs = np.clip(
                (obs - norm.obs_rms.mean) / np.sqrt(norm.obs_rms.var + norm.epsilon),
                -norm.clip_obs,
                norm.clip_obs,
            ).astype(np.float32)
        action, _ = model.predict(obs, deterministic=True)
        return action

    return policy


def _check_action_meaning(
    model_path: Path, meta: dict[str, Any] | None, env_id: str, probe: gym.Env
) -> None:
    """Refuse an env whose actions mean other things than the model's (:mod:`agents.meaning`:
    its actuators, their limits, BdotDetumble's ``command``; the shapes are checked apart).
    The record inside the model file rules; a model saved without one falls back on its
    sidecar's env, and one with neither is played with a warning."""
    want, source = recorded_meaning(model_path), ""
    if want is None and meta is not None:
        trained = meta.get("env_kwargs") or {}
        try:
            recorded = check_env_kwargs(str(meta.get("env_id") or env_id), trained)
        except ValueError as exc:
            raise EvaluationError(
                f"{model_path.with_suffix('.json')}: its env_kwargs do not make an env ({exc})"
            ) from None
        want, source = meaning_of(recorded), " (the model's record: its sidecar's env)"
        recorded.close()
    if want is None:
        print(
            f"agents.evaluate: warning: {model_path}: no record of what its actions mean (no "
            f"action_meaning inside, no sidecar); played as {env_id} reads them",
            file=sys.stderr,
        )
        return
    problem = mismatch(want, meaning_of(probe))
    if problem is None:
        return
    siblings = [  # the same task's other ids: one may play the model as registered
        e
        for e in ALL_ENV_IDS
        if e != env_id and gym.spec(e).entry_point == gym.spec(env_id).entry_point
    ]
    fits = next((e for e in siblings if _means(want, e)), None)
    also = f", or use {fits}, whose default it is" if fits is not None else ""
    raise EvaluationError(f"{model_path}: {problem}{also}{source}")


def _means(want: dict[str, Any], env_id: str) -> bool:
    """Whether ``env_id``, made with its registered defaults, means what ``want`` does."""
    env = gym.make(env_id)
    try:
        return mismatch(want, meaning_of(env)) is None
    finally:
        env.close()


def _probe(env_id: str, env_kwargs: dict[str, Any]) -> gym.Env:
    try:
        return check_env_kwargs(env_id, env_kwargs)
    except ValueError as exc:
        raise EvaluationError(f"env_kwargs: {exc}") from None


def resolve_env_kwargs(
    model: Path | None, env_kwargs: dict[str, Any] | None = None
) -> dict[str, Any]:
    """The env kwargs an evaluation runs with: the model's recorded ones (its sidecar's
    ``env_kwargs``: ``agents.train`` records the training ones less the randomisation, by
    :func:`agents.bar.evaluation_env_kwargs`), with ``env_kwargs`` merged over them (a
    registered variant such as DetumbleFaults-v0 merges them into its own defaults in turn,
    :func:`rigid_env.envs.variant_kwargs`)."""
    meta = read_sidecar(model) if model is not None and model.exists() else None
    return merge_env_kwargs((meta or {}).get("env_kwargs") or {}, env_kwargs or {})


def evaluate(
    model: Path | None,
    env_id: str,
    episodes: int,
    seed: int,
    only: list[str] | None = None,
    env_kwargs: dict[str, Any] | None = None,
) -> dict[str, dict[str, Any]]:
    """Metrics per policy name (``model`` plus the controllers), every policy on the env with
    the model's recorded ``env_kwargs`` and ``env_kwargs`` merged over them.

    Raises:
        EvaluationError: one line, for any input that cannot give a true result.
    """
    if episodes < 1:
        raise EvaluationError(f"--episodes: must be an integer >= 1, got {episodes}")
    if seed < 0:
        raise EvaluationError(f"--seed: must be an integer >= 0, got {seed}")
    names = only or (["model"] if model is not None else []) + list(CONTROLLERS)
    unknown = [n for n in names if n != "model" and n not in CONTROLLERS]
    if unknown:
        raise EvaluationError(
            f"--only: unknown policy {unknown[0]!r}; use model, {', '.join(CONTROLLERS)}"
        )
    if model is None and "model" in names:
        raise EvaluationError(
            "--only: model asks for the model, but MODEL is 'none'; give a model file, or "
            f"leave model out of --only ({', '.join(CONTROLLERS)})"
        )
    kwargs = resolve_env_kwargs(model, env_kwargs)
    if "render_mode" in kwargs:  # gym.make takes it; the evaluation's vector env would not
        raise EvaluationError(
            f"--env-kwargs: render_mode={kwargs['render_mode']}: an evaluation runs all episodes "
            "at once and draws nothing; leave render_mode out, and record an episode with "
            "--video FILE.gif"
        )
    _probe(env_id, kwargs).close()
    results: dict[str, dict[str, Any]] = {}
    try:
        probe = gym.make_vec(
            env_id, num_envs=episodes, vectorization_mode="vector_entry_point", **kwargs
        )
    except (TypeError, ValueError) as exc:  # a keyword the single env takes, the batch not
        raise EvaluationError(f"--env-kwargs: {' '.join(str(exc).split())}") from None
    for name in names:
        if name == "model":
            if model is None:
                continue
            policy = load_policy(model, env_id, kwargs)
        else:
            policy = CONTROLLERS[name](probe)
        results[name] = rollout(env_id, policy, episodes, seed, kwargs)
    unit = probe.unwrapped.task.view().fuel_unit  # a coil's dipole-time, or thrust's impulse
    probe.close()
    return {name: {**r, "fuel_unit": unit} for name, r in results.items()}


def markdown_table(results: dict[str, dict[str, Any]]) -> str:
    """Results as a Markdown table (fuel in the task's unit: the coils' dipole-time on
    magnetorquers)."""
    unit = next(iter(results.values()), {}).get("fuel_unit", "N s")
    lines = [
        f"| policy | success rate | final |w| [rad/s] | fuel [{unit}] | return | time to success "
        "[s] |",
        "|---|---|---|---|---|---|",
    ]
    for name, r in results.items():
        t = "-" if r["mean_time_to_success"] is None else f"{r['mean_time_to_success']:.2f}"
        lines.append(
            f"| {name} | {r['success_rate']:.2f} | {r['mean_final_angular_speed']:.4f} | "
            f"{r['mean_fuel']:.3f} | {r['mean_return']:.2f} | {t} |"
        )
    for name, r in results.items():  # said below the table only when it happened
        if r.get("numerical_errors"):
            lines.append(
                f"\n{name}: {r['numerical_errors']} of {r['episodes']} episodes ended in a "
                "numerical error (the state turned non-finite; the body was frozen): its row "
                "averages those too"
            )
    return "\n".join(lines)


def check_video_path(path: Path, force: bool) -> None:
    """Refuse a ``--video`` path that cannot be written, before any work is done.

    Raises:
        EvaluationError: wrong suffix, an existing file without ``force``, or a folder that
            cannot be created or written.
    """
    if path.suffix.lower() not in (".gif", ".mp4"):
        raise EvaluationError(f"--video: {path}: give a .gif or .mp4 file name")
    if path.is_dir():
        raise EvaluationError(f"--video: {path} is a folder; give a file name such as out.gif")
    if path.is_symlink() or (path.exists() and not path.is_file()):  # renamed over, not into
        raise EvaluationError(f"--video: {path} is a link, device or pipe; give a file name")
    if path.exists() and not force:
        raise EvaluationError(f"--video: {path} exists; pass --force to overwrite it")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path.parent, prefix=".probe-"):
            pass
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise EvaluationError(
            f"--video: cannot write {path} ({reason}); choose a folder you can write to"
        ) from None


def record_video(
    model: Path | None, env_id: str, seed: int, path: Path, env_kwargs: dict[str, Any] | None = None
) -> None:
    """One episode of the model (or the PD controller without a model) as a GIF or an MP4,
    written to exactly ``path`` (complete or not at all)."""
    kwargs = resolve_env_kwargs(model, env_kwargs)
    env = gym.make(env_id, render_mode="rgb_array", **kwargs)
    policy = load_policy(model, env_id, kwargs) if model is not None else CONTROLLERS["pd"](env)
    obs, _ = env.reset(seed=seed)
    frames = [env.render()]
    done = False
    while not done:
        obs, _, terminated, truncated, _ = env.step(policy(obs[None])[0])
        frames.append(env.render())
        done = terminated or truncated
    env.close()
    fps = env.metadata.get("render_fps", 20)
    with tempfile.TemporaryDirectory(dir=path.parent, prefix=".video-") as tmp:
        if path.suffix.lower() == ".gif":
            from PIL import Image

            out = Path(tmp) / path.name
            images = [Image.fromarray(f) for f in frames]
            images[0].save(
                out, save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0
            )
        else:
            from gymnasium.utils.save_video import save_video

            save_video(frames, tmp, fps=fps, name_prefix="video")
            out = next(Path(tmp).glob("*.mp4"))
        os.replace(out, path)


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    parser = OneLineParser(
        prog="python -m agents.evaluate", description="Evaluate a policy beside analytic baselines."
    )
    parser.add_argument("model", help="SB3 model .zip, or 'none' for the controllers only")
    parser.add_argument("--env", required=True, help="environment id, e.g. RigidEnv/Detumble-v0")
    parser.add_argument(
        "--env-kwargs",
        nargs="+",
        default=[],
        metavar="JSON|KEY=VALUE",
        help="""environment keyword arguments over the model's recorded ones: a JSON object
        ('{"randomization": {"inertia": 0.2}}') or KEY=VALUE pairs (dt=0.02 integrator=rk4
        randomization.inertia=0.2)""",
    )
    parser.add_argument("--episodes", type=integer, default=100)
    parser.add_argument(
        "--seed", type=integer, default=12345, help="episode k uses seed + k (>= 0)"
    )
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument("--video", type=path, help="record one episode (.gif or .mp4)")
    parser.add_argument("--force", action="store_true", help="overwrite an existing --video")
    parser.add_argument("--only", help="comma-separated subset of: model,pd,zero,random")
    args = parser.parse_args(argv)
    model = None if args.model.lower() == "none" else Path(args.model)
    try:
        if args.env not in gym.registry:
            known = ", ".join(k for k in gym.registry if k.startswith("RigidEnv/"))
            raise EvaluationError(f"--env: unknown id {args.env!r}; use one of {known}")
        try:
            env_kwargs = parse_env_kwargs(args.env_kwargs)
        except ValueError as exc:
            raise EvaluationError(f"--env-kwargs: {exc}") from None
        if args.video is not None:
            check_video_path(args.video, args.force)
        only = args.only.split(",") if args.only else None
        results = evaluate(model, args.env, args.episodes, args.seed, only, env_kwargs)
        used = resolve_env_kwargs(model, env_kwargs)
    except EvaluationError as exc:
        print(f"agents.evaluate: error: {exc}", file=sys.stderr)
        return 2
    except MemoryError:  # the episodes run at once, one row of every array each
        print(
            f"agents.evaluate: error: --episodes: {args.episodes} episodes at once do not fit "
            "in memory; give fewer (1000 estimate a success rate to +-3 %)",
            file=sys.stderr,
        )
        return 2
    if args.json:
        shown = {name: {**r, "env_kwargs": used} for name, r in results.items()}
        print(json.dumps(shown if len(shown) > 1 else next(iter(shown.values())), indent=2))
    else:
        if used:
            print(f"env_kwargs: {json.dumps(used)}")
        print(markdown_table(results))
    sys.stdout.flush()
    if args.video is not None:
        try:
            record_video(model, args.env, args.seed, args.video, env_kwargs)
        except ImportError as exc:
            print(
                f"agents.evaluate: error: --video: needs {exc.name}; "
                "pip install 'rigid_env[render]' (results above are complete)",
                file=sys.stderr,
            )
            return 1
        except (OSError, EvaluationError) as exc:
            text = " ".join(str(exc).split())
            print(f"agents.evaluate: error: --video: {text}", file=sys.stderr)
            return 1
        print(f"wrote {args.video}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
