"""The ``rigid-env`` command line.

    rigid-env simulate SCENE.yaml --steps N [--dt H] [--integrator NAME] [--substeps K]
                       [--rtol R] [--atol A]
                       [--action A1,A2,...] --out FILE.npz [--force]
    rigid-env bench accuracy [...]      work-precision benchmark (rigid_env.bench.accuracy)
    rigid-env bench speed [...]         throughput benchmark (rigid_env.bench.speed)
    rigid-env bench stability [...]     hard cases against their bounds (rigid_env.bench.stability)
    rigid-env bench peers [...]         the same models in Basilisk (rigid_env.bench.peers)
    rigid-env scenes [--dir DIR]        the example scenes with a one-line summary each
    rigid-env integrators               the integrator registry
    rigid-env demo [--task T] [--episodes K] [--out DIR] [--force]
                                        the main job: pretrained policies beside the PD
                                        controller (agents.demo: a table and a GIF per task)
    rigid-env export MODEL --onnx OUT [--force]
                                        a policy as ONNX, normalisation folded in
                                        (agents.export)

A user's mistake (a bad file, scene or flag value) ends with exit status 2 and one line on
stderr, ``rigid-env: error: ...``; a simulation that turns non-finite ends with status 1 and one
line. No traceback is printed for either (set ``RIGID_ENV_DEBUG=1`` to get one). The benchmark
modules are imported only when their command runs, so ``simulate`` never loads matplotlib or
MuJoCo.
"""

from __future__ import annotations

import argparse
import importlib
import math
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

import numpy as np
from numpy.typing import NDArray

from rigid_env import __version__
from rigid_env.core.actuator import kinds, stores_momentum
from rigid_env.core.integrators import INTEGRATORS
from rigid_env.core.world import NumericalInstabilityError
from rigid_env.resources import SCENE_DIR, folder_problem
from rigid_env.scene import SceneError, load_scene
from rigid_env.trajectory import simulate

PROG = "rigid-env"
BENCHMARKS = {
    "accuracy": "work-precision: error against cost for every integrator (figure + tables)",
    "speed": "throughput: body-steps per second against batch size, peers in the same run",
    "stability": "hard cases at full length (flips, fast spin, thin bodies, separatrix)",
    "learn": "time to the bar: the shipped PPO configs beside the previous ones, per task and seed",
    "peers": "the same models here and in Basilisk, side by side (needs the [peers] extra)",
}


class UsageError(Exception):
    """A user's mistake on the command line; the message is one line."""


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (no usage block) raised as :class:`UsageError`."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{message} (see '{self.prog} --help')")


# --------------------------------------------------------------------------------------------
# Flag value types: each raises ArgumentTypeError with what to do
# --------------------------------------------------------------------------------------------


def _positive_float(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}") from None
    if not (math.isfinite(x) and x > 0.0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text!r}")
    return x


def _int_at_least(low: int) -> Callable[[str], int]:
    def parse(text: str) -> int:
        try:
            k = int(text)
        except ValueError:
            try:  # 1e6, 2.5e3: an integer written in exponent notation
                x = float(text)
            except ValueError:
                x = math.nan
            if not (math.isfinite(x) and x.is_integer()):
                raise argparse.ArgumentTypeError(
                    f"expected an integer >= {low}, got {text!r}"
                ) from None
            k = int(x)
        if k < low:
            raise argparse.ArgumentTypeError(f"must be an integer >= {low}, got {k}")
        return k

    parse.__name__ = f"integer >= {low}"
    return parse


def _integrator(text: str) -> str:
    if text not in INTEGRATORS:
        raise argparse.ArgumentTypeError(
            f"unknown integrator {text!r}; choose one of: {', '.join(INTEGRATORS)}"
        )
    return text


def _action(text: str) -> list[float]:
    """``A1,A2,...``: finite numbers in [-1, 1]."""
    values = []
    for item in text.split(","):
        try:
            x = float(item)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected comma-separated numbers in [-1, 1], got {item.strip()!r} in {text!r}"
            ) from None
        if not math.isfinite(x):
            raise argparse.ArgumentTypeError(
                f"{item.strip()!r} is not a finite number; give commands in [-1, 1]"
            )
        if not -1.0 <= x <= 1.0:
            raise argparse.ArgumentTypeError(
                f"{x:g} is outside [-1, 1]; every command is a fraction of the actuator's max_force"
            )
        values.append(x)
    return values


# --------------------------------------------------------------------------------------------
# Parser
# --------------------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser (the benchmark commands add their own flags when run)."""
    parser = _Parser(prog=PROG, description="Rigid-body simulation, benchmarks and scenes.")
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    sim = sub.add_parser(
        "simulate",
        help="integrate a scene and write its trajectory (.npz)",
        description="Integrate one body of a scene with a constant command and write the "
        "trajectory: t (N+1,), position, velocity, orientation (w, x, y, z), "
        "angular_velocity_body, angular_velocity_world (N+1, 3|4), energy (N+1,), "
        "angular_momentum_world (N+1, 3); with reaction wheels also wheel_momentum and "
        "wheel_speed (N+1, K) (energy and angular momentum then count the wheels').",
    )
    sim.add_argument("scene", metavar="SCENE.yaml", help="scene file (see configs/scenes/)")
    sim.add_argument(
        "--steps", type=_int_at_least(1), required=True, metavar="N", help="number of steps of dt"
    )
    sim.add_argument(
        "--dt", type=_positive_float, metavar="H", help="time per step [s] (default: the scene's)"
    )
    sim.add_argument(
        "--integrator",
        type=_integrator,
        metavar="NAME",
        help=f"one of {', '.join(INTEGRATORS)} (default: the scene's)",
    )
    sim.add_argument(
        "--substeps",
        type=_int_at_least(1),
        metavar="K",
        help="integrator steps per dt (default: the scene's)",
    )
    sim.add_argument(
        "--rtol",
        type=_positive_float,
        metavar="R",
        help="relative tolerance of each substep's error, 0 < R < 1, for an error-controlled "
        "integrator (dop853) (default: the scene's, else 1e-10)",
    )
    sim.add_argument(
        "--atol",
        type=_positive_float,
        metavar="A",
        help="absolute tolerance, > 0, likewise (default: the scene's, else 1e-10)",
    )
    sim.add_argument(
        "--action",
        type=_action,
        metavar="A1,A2,...",
        help="constant command, one number in [-1, 1] per actuator component (default: zeros)",
    )
    sim.add_argument(
        "--seed",
        type=_int_at_least(0),
        default=0,
        metavar="S",
        help="seed of the thrust noise of thrusters with `noise` (default 0; unused without)",
    )
    sim.add_argument("--out", required=True, metavar="FILE.npz", help="output file")
    sim.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    sim.set_defaults(handler=_cmd_simulate)

    bench = sub.add_parser(
        "bench",
        help="accuracy and speed benchmarks",
        description="Benchmarks; each writes a figure and tables.",
    )
    bench_sub = bench.add_subparsers(dest="benchmark", metavar="BENCHMARK")
    for name, text in BENCHMARKS.items():
        # add_help=False: `--help` and every flag go to the benchmark's own parser.
        b = bench_sub.add_parser(name, help=text, add_help=False)
        b.set_defaults(handler=_cmd_bench, takes_extra=True)
    bench.set_defaults(handler=_cmd_bench_missing)

    scenes = sub.add_parser(
        "scenes",
        help="list the example scenes",
        description="List scene files with a one-line summary each.",
    )
    scenes.add_argument(
        "--dir",
        type=Path,
        default=None,
        metavar="DIR",
        help=f"directory of .yaml scenes (default: {SCENE_DIR})",
    )
    scenes.set_defaults(handler=_cmd_scenes)

    integ = sub.add_parser(
        "integrators",
        help="list the integrators",
        description="Name, order and a note for every integrator.",
    )
    integ.set_defaults(handler=_cmd_integrators)

    demo = sub.add_parser(
        "demo",
        help="the main job: pretrained PPO beside the PD controller (table + GIF)",
        description="Evaluate the pretrained policies shipped with the package beside the PD "
        "controller on fixed seeds never used in training (20261201 + k), print the table, and "
        "write results.md, results.csv, episodes.csv and a side-by-side GIF per task to --out.",
    )
    # The tasks the demo plays (those that ship a pretrained policy): a table of the registry's
    # records, light to import (agents' training modules load only when the command runs).
    from rigid_env.agents.shipped import ENV_IDS as SHIPPED_IDS
    from rigid_env.agents.shipped import TASKS as SHIPPED

    demo.add_argument(
        "--task",
        metavar="T",
        help=f"one task: {', '.join(SHIPPED)}, or the id its pretrained policy plays: "
        f"{', '.join(SHIPPED_IDS)} (default: all {len(SHIPPED)})",
    )
    demo.add_argument(
        "--episodes",
        type=_int_at_least(1),
        metavar="K",
        help="episodes per task and policy, 1 to 1000 (default: 10)",
    )
    demo.add_argument(
        "--out",
        type=Path,
        default=Path("runs/demo"),
        metavar="DIR",
        help="output directory (default: runs/demo)",
    )
    demo.add_argument("--force", action="store_true", help="overwrite earlier results in --out")
    demo.set_defaults(handler=_cmd_demo)

    export = sub.add_parser(
        "export",
        help="a trained policy as ONNX, normalisation folded in, for use off Python",
        description="Write MODEL (an SB3 PPO zip with its sidecar and VecNormalize statistics, "
        "e.g. agents/pretrained/ppo_detumble.zip) as one ONNX graph from raw observations to "
        "deterministic actions (rigid_env.agents.export; needs the [export] extra).",
    )
    export.add_argument("model", type=Path, metavar="MODEL", help="the model zip")
    export.add_argument(
        "--onnx", type=Path, required=True, metavar="OUT", help="the ONNX file to write"
    )
    export.add_argument("--force", action="store_true", help="replace OUT if it exists")
    export.set_defaults(handler=_cmd_export)
    return parser


def _join_action_value(argv: list[str]) -> list[str]:
    """``--action -0.5,1`` -> ``--action=-0.5,1`` (argparse would take ``-0.5,1`` for a flag)."""
    out: list[str] = []
    i = 0
    while i < len(argv):
        if argv[i] == "--action" and i + 1 < len(argv) and argv[i + 1].startswith("-"):
            out.append(f"--action={argv[i + 1]}")
            i += 2
        else:
            out.append(argv[i])
            i += 1
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line.

    Args:
        argv: arguments without the program name (default: ``sys.argv[1:]``).

    Returns:
        Exit status: 0 on success, 2 for a user's mistake, 1 if a simulation turned
        non-finite.
    """
    args_in = _join_action_value(list(sys.argv[1:] if argv is None else argv))
    parser = build_parser()
    try:
        _refuse_empty_paths(args_in)
        args, extra = parser.parse_known_args(args_in)
        if extra and not getattr(args, "takes_extra", False):
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
        handler = getattr(args, "handler", None)
        if handler is None:
            parser.print_help(sys.stderr)
            return 2
        return int(handler(args, extra))
    except SystemExit as exc:  # --help, --version, or a benchmark that exits itself
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    except NumericalInstabilityError as exc:
        return _fail(exc, 1)
    except (UsageError, SceneError) as exc:
        return _fail(exc, 2)
    except ValueError as exc:  # a user's value the core rejected
        return _fail(exc, 2)
    except OSError as exc:  # a file error: the path and the reason, never a bare [Errno N]
        return _fail(_file_error(exc), 2)
    except MemoryError:  # past the sizing above: the room went to something else meanwhile
        print(
            f"{PROG}: error: out of memory (free memory or ulimit -v); ask for less "
            "(fewer --steps or --episodes) or raise the limit",
            file=sys.stderr,
        )
        return 2
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130


def _refuse_empty_paths(argv: list[str]) -> None:
    """An empty ``--out`` ('' from an unset shell variable) would mean the current folder; a
    flag given ``=--`` would reach its command as an empty list (argparse drops the ``--``)."""
    for i, arg in enumerate(argv):
        flag, eq, value = arg.partition("=")
        if flag.startswith("--") and eq and value == "--":
            raise UsageError(f"{flag}: expected a value, got '--'")
        if flag == "--out" and (
            (eq and not value.strip()) or (not eq and i + 1 < len(argv) and not argv[i + 1].strip())
        ):
            raise UsageError("--out: empty path; give a file or folder name (an unset variable?)")


def _file_error(exc: OSError) -> UsageError:
    """An OS error as one line naming the path and the reason (a missing folder above it, a
    dangling link, no permission)."""
    where = exc.filename if exc.filename is not None else "a file"
    reason = exc.strerror or type(exc).__name__
    return UsageError(
        f"{where}: {reason}; check the path (every folder above it must exist or be creatable, "
        "and be writable)"
    )


def _fail(exc: BaseException, status: int) -> int:
    if os.environ.get("RIGID_ENV_DEBUG"):
        raise exc
    text = " ".join(str(exc).split()) or type(exc).__name__
    print(f"{PROG}: error: {text}", file=sys.stderr)
    return status


# --------------------------------------------------------------------------------------------
# Commands
# --------------------------------------------------------------------------------------------


#: Float64 numbers recorded per step of one body: t, position (3), velocity (3), orientation (4),
#: angular_velocity_body (3), angular_velocity_world (3), energy, angular_momentum_world (3).
_NUMBERS_PER_STEP = 21
#: Steps simulated per call while filling the trajectory, so that memory holds the trajectory's
#: arrays and one chunk of the core's per-step records, never a list of the whole run.
_CHUNK_STEPS = 65_536
#: Seconds between progress lines of a long simulation (and the most one chunk takes).
_PROGRESS_EVERY_S = 10.0


def _cmd_simulate(args: argparse.Namespace, extra: list[str]) -> int:
    scene = load_scene(args.scene)
    world = scene.build_world(
        1, integrator=args.integrator, dt=args.dt, substeps=args.substeps, rtol=args.rtol,
        atol=args.atol,
    )  # fmt: skip
    action = _check_action(args.action, world.action_dim)
    out = Path(args.out)
    if out.is_dir():
        raise UsageError(
            f"--out: {out} is a directory; give a file name such as {out / 'trajectory.npz'}"
        )
    # The file is written beside --out and renamed over it: that would replace a device, a
    # pipe or a link (not write through it).
    if out.is_symlink():
        raise UsageError(
            f"--out: {out} is a symbolic link; give the file it points to, or another name"
        )
    if out.exists() and not out.is_file():
        raise UsageError(f"--out: {out} is not a regular file; give a file name such as run.npz")
    if out.exists() and not args.force:
        raise UsageError(
            f"--out: {out} exists; pass --force to overwrite it, or choose another file"
        )
    _check_writable_folder(out)
    size = 8 * _NUMBERS_PER_STEP * (args.steps + 1)
    _check_room(args.steps, size, out.parent)
    if size > 256 * 2**20:
        print(f"simulating {args.steps} steps: the trajectory takes {_bytes(size)}", flush=True)

    start = time.perf_counter()
    # A diverging run may overflow the recorded energy a step before the state itself turns
    # non-finite; the world's guard then reports it in one line, without NumPy warnings.
    with np.errstate(over="ignore", invalid="ignore"):
        rng = np.random.default_rng(args.seed)  # drawn from only for noisy thrusters
        arrays = _simulate_chunked(world, args.steps, action, _Progress(args.steps), rng)
    wall = time.perf_counter() - start
    _write_npz(out, arrays)
    print(_summary(scene.name, world, arrays, wall, out))
    _note_past_limit(scene, world, arrays)
    return 0


def _note_past_limit(scene: Any, world: Any, arrays: dict[str, Any]) -> None:
    """One stderr line where a wheel ran past its max_speed: only the law before issue 44 lets
    it (``pre_fix_law``, kept for WheelPointing-v0's history), and the run says so."""
    if "wheel_speed" not in arrays or world.wheels is None:
        return
    top = np.max(np.abs(arrays["wheel_speed"]), axis=0)
    past = np.flatnonzero(top > world.wheels.max_speed * (1.0 + 1e-12))
    if past.size:
        k = int(past[np.argmax(top[past] - world.wheels.max_speed[past])])
        section = kinds(stores_momentum)[0].name
        print(
            f"{PROG}: note: wheel {k} reached {top[k]:.6g} rad/s, beyond its max_speed "
            f"{world.wheels.max_speed[k]:g}: {scene.name} sets {section}.pre_fix_law: "
            "true (the law before issue 44, kept for WheelPointing-v0's history); leave it out "
            "for a limit that holds within each step",
            file=sys.stderr,
        )


class _Progress:
    """Chunk sizes that keep each call to about a second, and, for a run longer than
    :data:`_PROGRESS_EVERY_S`, its expected time up front and a line with the time left every
    :data:`_PROGRESS_EVERY_S` seconds."""

    def __init__(self, steps: int) -> None:
        self.steps = steps
        self.timed_from: tuple[int, float] | None = None  # (steps done, time) after compiling
        self.last_line: float | None = None

    def next_chunk(self, done: int) -> int:
        """Steps for the next call: 1 (it compiles), 16 (timed), then a second's worth."""
        now = time.perf_counter()
        left_steps = self.steps - done
        if done == 0:
            return 1
        if self.timed_from is None:
            self.timed_from = (done, now)
            return min(16, left_steps)
        rate = (done - self.timed_from[0]) / max(now - self.timed_from[1], 1e-9)  # steps/s
        left_s = left_steps / rate
        if self.last_line is None:
            if left_s > _PROGRESS_EVERY_S:
                print(f"simulating {self.steps} steps: about {left_s:.0f} s", flush=True)
            self.last_line = now
        elif now - self.last_line >= _PROGRESS_EVERY_S:
            print(f"  {done}/{self.steps} steps, about {left_s:.0f} s left", flush=True)
            self.last_line = now
        return int(min(_CHUNK_STEPS, left_steps, max(1.0, rate)))


def _simulate_chunked(
    world: Any,
    steps: int,
    action: NDArray[np.float64] | None,
    progress: _Progress | None = None,
    rng: np.random.Generator | None = None,
) -> dict[str, NDArray[np.float64]]:
    """:func:`simulate` of body 0 into arrays allocated once at their final size ``(steps + 1,
    ...)``, ``_CHUNK_STEPS`` steps at a time or as ``progress`` sizes them (the same steps as
    one call, bit for bit)."""
    t0 = world.time
    arrays: dict[str, NDArray[np.float64]] = {}
    done = 0
    while True:
        n = min(_CHUNK_STEPS, steps - done)
        if progress is not None:
            n = progress.next_chunk(done)
        chunk = simulate(world, n, action, rng)
        rows = slice(0, n + 1) if done == 0 else slice(1, n + 1)  # row 0 repeats the last one
        for key, val in chunk.items():
            if key == "t":
                continue
            if key not in arrays:
                arrays[key] = np.empty((steps + 1, *val.shape[2:]), dtype=val.dtype)
            arrays[key][done + rows.start : done + n + 1] = val[rows, 0]
        done += n
        if done == steps:
            break
    arrays["t"] = t0 + world.dt * np.arange(steps + 1)
    return {"t": arrays.pop("t"), **arrays}


def _check_writable_folder(out: Path) -> None:
    """Create ``out``'s folder and make sure a file can be written there, before simulating."""
    folder = out.parent
    problem = folder_problem(out)
    if problem is not None:
        raise UsageError(f"--out: cannot write {out}: {problem}; choose another folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, prefix=f".{out.name}.", suffix=".probe"):
            pass
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise UsageError(
            f"--out: cannot write {out} ({reason} in {folder}); choose a folder you can "
            "write to, or change its permissions"
        ) from None


def _check_room(steps: int, size: int, folder: Path) -> None:
    """Refuse a run whose trajectory cannot fit in the free memory or on the disk."""
    memory = _available_memory()
    if memory is not None:
        # Besides the trajectory: one chunk of the core's per-step records (a few arrays of
        # _CHUNK_STEPS rows) and the writer's buffers; 64 MB covers them with room to spare.
        memory = max(memory - 64 * 2**20, 0)
    disk = shutil.disk_usage(folder).free
    for room, where in (
        (memory, "memory available (free memory and ulimit -v / -d)"),
        (disk, f"free on the disk of {folder}"),
    ):
        if room is not None and size > room:
            most = int(0.98 * room) // (8 * _NUMBERS_PER_STEP) - 1  # 2 % slack
            fix = f"give at most --steps {most}" if most >= 1 else "free room, or raise the limit"
            raise UsageError(
                f"--steps: {steps} steps make a trajectory of {_bytes(size)} "
                f"({8 * _NUMBERS_PER_STEP} bytes a step), more than the {_bytes(room)} {where}; "
                f"{fix}"
            )


def _available_memory() -> int | None:
    """Bytes a new allocation may take: the least of the memory available (Linux
    ``MemAvailable``) and the room left under this process's limits on its address space
    (``ulimit -v``, ``RLIMIT_AS``) and data (``ulimit -d``, ``RLIMIT_DATA``); None if unknown."""
    rooms = [_free_memory(), *_room_under_limits()]
    known = [r for r in rooms if r is not None]
    return min(known) if known else None


def _free_memory() -> int | None:
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None


#: Address space a simulation maps after the size check besides its trajectory: compiling the
#: step and starting its threads took VmSize from 367 to 503 MB on a 1000-step run (Linux,
#: x86-64); twice that, rounded up.
_RUN_RESERVE = 320 * 2**20


def _room_under_limits() -> list[int | None]:
    """Per limit set (soft ``RLIMIT_AS``, ``RLIMIT_DATA``): the limit less what this process
    already uses of it (``VmSize``, ``VmData`` in ``/proc/self/status``) and less
    :data:`_RUN_RESERVE` for what the run maps besides the trajectory."""
    try:
        import resource
    except ImportError:  # not on POSIX
        return []
    used = {}
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                key, _, value = line.partition(":")
                if key in ("VmSize", "VmData"):
                    used[key] = int(value.split()[0]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    rooms: list[int | None] = []
    for limit, key in ((resource.RLIMIT_AS, "VmSize"), (resource.RLIMIT_DATA, "VmData")):
        soft = resource.getrlimit(limit)[0]
        if soft != resource.RLIM_INFINITY:
            rooms.append(max(soft - used.get(key, 0) - _RUN_RESERVE, 0))
    return rooms


def _bytes(n: float) -> str:
    for unit in ("bytes", "KB", "MB", "GB", "TB", "PB"):
        if n < 1000 or unit == "PB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.1f} {unit}"
        n /= 1000
    raise AssertionError  # unreachable


def _check_action(values: list[float] | None, action_dim: int) -> NDArray[np.float64] | None:
    if values is None:
        return None
    if len(values) != action_dim:
        have = (
            f"{action_dim} actuator component{'s' if action_dim != 1 else ''}"
            if action_dim
            else "no actuators"
        )
        raise UsageError(
            f"argument --action: the scene has {have}, got {len(values)} "
            "number(s); give one number in [-1, 1] per component"
            + ("" if action_dim else " or leave --action out")
        )
    return np.array(values, dtype=np.float64)


def _write_npz(out: Path, arrays: dict[str, Any]) -> None:
    """Write next to ``out`` and rename into place, so a failed write leaves no partial file.

    Raises:
        UsageError: the write failed (a full disk, permissions), naming ``out``.
    """
    tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)
        os.replace(tmp, out)
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise UsageError(
            f"--out: writing {out} failed ({reason}); nothing was written: free space or "
            "choose another folder"
        ) from None
    finally:
        if tmp.exists():
            tmp.unlink()


def _drift(series: NDArray[np.float64]) -> str:
    """``start -> end (change, relative change)``."""
    a, b = float(series[0]), float(series[-1])
    rel = f", {(b - a) / abs(a):+.3e} relative" if a != 0.0 else ""
    return f"{a:.6g} -> {b:.6g} (change {b - a:+.3e}{rel})"


def _summary(
    name: str, world: Any, arrays: dict[str, NDArray[np.float64]], wall: float, out: Path
) -> str:
    integrator, dt, substeps = world.integrator.name, world.dt, world.substeps
    stepping = f"{substeps} substep{'s' if substeps != 1 else ''} per step"
    if world.tolerances is not None:
        stepping = f"rtol {world.tolerances.rtol:g}, atol {world.tolerances.atol:g}"
    steps = arrays["t"].shape[0] - 1
    l_norm = np.linalg.norm(arrays["angular_momentum_world"], axis=1)
    w_final = float(np.linalg.norm(arrays["angular_velocity_body"][-1]))
    rate = f" ({steps / wall:,.0f} steps/s)" if wall > 0.0 else ""
    return "\n".join(
        [
            f"{name}: {steps} steps of {dt:g} s = {steps * dt:g} s simulated with {integrator}"
            f" ({stepping})",
            f"  energy [J]:          {_drift(arrays['energy'])}",
            f"  |L| [kg m^2/s]:      {_drift(l_norm)}",
            f"  final |w| [rad/s]:   {w_final:.6g}",
            f"  wall time:           {wall:.3f} s{rate}",
            f"  wrote {out}",
        ]
    )


def _cmd_bench_missing(args: argparse.Namespace, extra: list[str]) -> int:
    raise UsageError(
        f"bench: choose a benchmark: {', '.join(BENCHMARKS)} (e.g. '{PROG} bench accuracy --quick')"
    )


def _cmd_bench(args: argparse.Namespace, extra: list[str]) -> int:
    name = args.benchmark
    module_name = f"rigid_env.bench.{name}"
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name == module_name:
            raise UsageError(
                f"bench {name}: not available in this installation ({module_name} is missing)"
            ) from None
        raise UsageError(
            f"bench {name}: needs the package {exc.name!r}; install the "
            "benchmark extras with: pip install -e '.[bench]'"
        ) from None
    parser = _Parser(prog=f"{PROG} bench {name}", description=BENCHMARKS[name])
    module.add_arguments(parser)
    return int(module.run(parser.parse_args(extra)))


def _header_sentence(path: Path) -> str:
    """The first sentence of the ``#`` comment block that opens a file ("" if none)."""
    lines = []
    try:
        with open(path, encoding="utf-8") as fh:
            for line in fh:
                if not line.strip().startswith("#"):
                    break
                lines.append(line.strip().lstrip("#").strip())
    except (OSError, UnicodeDecodeError):
        return ""
    text = " ".join(lines)
    end = text.find(". ")
    return text if end < 0 else text[: end + 1]


def _cmd_scenes(args: argparse.Namespace, extra: list[str]) -> int:
    folder: Path = args.dir if args.dir is not None else SCENE_DIR
    if not folder.is_dir():
        raise UsageError(f"--dir: {folder} is not a directory; give the folder of the .yaml scenes")
    files = sorted(folder.glob("*.yaml"))
    if not files:
        print(f"no .yaml scenes in {folder}")
        return 0
    rows = []
    for path in files:
        try:
            scene = load_scene(path)
            rows.append((scene.name, _header_sentence(path) or scene.summary(), scene.summary()))
        except SceneError as exc:
            rows.append((path.stem, f"(invalid: {exc.problem}; {exc.fix})", ""))
    width = max(len(r[0]) for r in rows)
    print(f"scenes in {folder}:")
    for name, text, detail in rows:
        print(f"  {name:<{width}}  {text}")
        if detail and detail != text:
            print(f"  {'':<{width}}  {detail}")
    return 0


def _cmd_integrators(args: argparse.Namespace, extra: list[str]) -> int:
    width = max(len(n) for n in INTEGRATORS)
    print(f"{'name':<{width}}  order  note")
    for name, info in INTEGRATORS.items():
        print(f"{name:<{width}}  {info.order:>5}  {info.note}")
    return 0


def _cmd_demo(args: argparse.Namespace, extra: list[str]) -> int:
    # agents sits above rigid_env (DESIGN.md): imported only when the command runs.
    from rigid_env.agents import demo

    return demo.run(args.task, args.episodes, args.out, args.force)


def _cmd_export(args: argparse.Namespace, extra: list[str]) -> int:
    try:
        import onnx  # noqa: F401

        from rigid_env.agents import export
    except ImportError as exc:
        raise UsageError(
            f"export needs {exc.name or 'onnx'}; pip install 'rigid_env[export]'"
        ) from None
    out = export.export_onnx(args.model, args.onnx, args.force)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
