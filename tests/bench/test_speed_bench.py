"""The speed benchmark's machinery in a tiny configuration: it runs every section and writes
the figure and tables with the documented columns. No timing is asserted (DESIGN.md,
"Measuring": timings live in the benchmark, never in tests)."""

from __future__ import annotations

import csv
import math
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from rigid_env.bench import speed, speed_rows, timing
from rigid_env.cli import main
from rigid_env.core.integrators import INTEGRATORS

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def smoke_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One ``--smoke`` run of every section through the command line."""
    out = tmp_path_factory.mktemp("speed")
    assert main(["bench", "speed", "--smoke", "--out", str(out)]) == 0
    return out


def read_csv(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    with open(path, newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        return list(reader.fieldnames or []), list(reader)


@pytest.mark.slow
def test_smoke_run_writes_figure_and_tables(smoke_out: Path) -> None:
    png = smoke_out / "speed.png"
    assert png.read_bytes()[:8] == PNG_MAGIC
    for name in ("speed.md", "speed.csv"):
        assert (smoke_out / name).stat().st_size > 0


@pytest.mark.slow
def test_csv_has_the_columns_and_every_section(smoke_out: Path) -> None:
    header, rows = read_csv(smoke_out / "speed.csv")
    assert tuple(header) == speed_rows.CSV_COLUMNS
    assert {"section", "case", "n", "value", "unit", "median_s", "peer", "ratio"} <= set(header)
    assert {r["section"] for r in rows} == set(speed.SECTIONS)
    assert {r["clock"] for r in rows if r["note"] == ""} == {"wall"}
    for r in rows:
        if r["note"].startswith("not available"):
            continue
        assert math.isfinite(float(r["value"])) and float(r["value"]) > 0.0, r
        assert r["peer"], r  # every measured row names the peer its ratio is taken against
        assert math.isfinite(float(r["ratio"])), r


@pytest.mark.slow
def test_csv_rows_compare_with_the_peers_of_the_issue(smoke_out: Path) -> None:
    _, rows = read_csv(smoke_out / "speed.csv")
    cases = {(r["section"], r["case"]) for r in rows}
    for mj in ("Euler", "RK4"):
        assert ("core", f"MuJoCo {mj} rollout") in cases
        assert ("core", f"MuJoCo {mj} mj_step loop") in cases
    assert {
        ("env", "Pendulum-v1"),
        ("env", "InvertedPendulum-v5"),
        ("env", speed.DETUMBLE),
    } <= cases
    assert {("vec", speed.CARTPOLE_CASE), ("vec", speed.SYNC_CASE), ("vec", "Detumble")} <= cases
    assert {
        ("effects", speed.NO_EFFECTS),
        ("effects", speed.NOISE_FLOOR),
        ("effects", "all of them"),
    } <= cases
    assert {
        ("ppo", speed.PPO_ADAPTER),
        ("ppo", speed.PPO_DUMMY),
        ("ppo", speed.PPO_SUBPROC),
    } <= cases
    # Every shipped policy that trains under draws is measured with and without them, steps
    # and resets (Detumble's config randomises; DetumbleFaults is a variant that does).
    for name in ("Detumble", "DetumbleFaults"):
        for case in (name, name + " randomised"):
            assert {("random", case), ("random", case + " reset")} <= cases
    # SyncVectorEnv is measured at the small sizes only; the others are marked extrapolated.
    sync = {int(r["n"]): r["note"] for r in rows if r["case"] == speed.SYNC_CASE}
    for n, note in sync.items():
        assert (n in speed.SMOKE.sync_sizes) == (note == ""), (n, note)


@pytest.mark.slow
def test_markdown_has_header_and_sections(smoke_out: Path) -> None:
    text = (smoke_out / "speed.md").read_text(encoding="utf-8")
    for key in (
        "- Date:",
        "- Machine:",
        "- Versions:",
        "numpy",
        "mujoco",
        "gymnasium",
        "stable-baselines3",
        "## 1. Core",
        "## 2. Single environment",
        "## 3. Vector environment",
        "## 4. Effects",
        "## 5. Training",
        "## 6. Randomisation and sensors",
    ):
        assert key in text, key
    assert "Traceback" not in text


def test_warm_up_leaves_a_slow_first_call_out_of_the_calls_per_repeat() -> None:
    """A first call that pays a one-time cost (a compiled step) must not make the warm-up
    think every call is slow: the repeats would then be one or two calls long, dominated by
    the cold start after the other cases."""
    import time

    first = [True]

    def fn() -> None:
        if first[0]:
            first[0] = False
            time.sleep(0.05)

    timings = timing.measure([timing.Case("a", fn, work=1.0)], min_time=0.01, repeats=1)
    assert timings["a"].calls > 10


def test_measure_interleaves_repeats_and_resets_before_each() -> None:
    log: list[str] = []
    cases = [
        timing.Case(
            name,
            lambda name=name: log.append(name),
            work=4.0,
            reset=lambda name=name: log.append(f"reset {name}"),
            calls=2,
        )
        for name in ("a", "b")
    ]
    timings = timing.measure(cases, min_time=0.0, repeats=3, warmup=False)
    assert set(timings) == {"a", "b"}
    for t in timings.values():
        assert len(t.per_call) == 3 and t.calls == 2 and t.work == 4.0
        assert t.rate == pytest.approx(t.work / t.median)
        assert len(t.cpu_per_call) == 3 and t.seconds == t.per_call  # wall clock by default
    # Round r starts with case r mod 2; each repeat is its reset and then its calls.
    assert log == [
        "reset a",
        "a",
        "a",
        "reset b",
        "b",
        "b",
        "reset b",
        "b",
        "b",
        "reset a",
        "a",
        "a",
        "reset a",
        "a",
        "a",
        "reset b",
        "b",
        "b",
    ]


def test_mujoco_states_spin_the_free_body_at_the_given_body_rates() -> None:
    model = speed.mujoco_model("RK4")
    w = speed.random_spins(5, seed=3)
    states = speed.mujoco_states(model, w)
    data = mujoco.MjData(model)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS.value
    for k in range(5):
        mujoco.mj_setState(model, data, states[k], spec)
        np.testing.assert_array_equal(data.qvel[3:], w[k])
        np.testing.assert_array_equal(data.qvel[:3], 0.0)


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--only", "nope"], "unknown section"),
        (["--repeats", "0"], "--repeats"),
    ],
)
def test_bad_flags_give_one_line_errors(
    argv: list[str], words: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["bench", "speed", "--smoke", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rigid-env") and words in err[0], err


def test_out_must_be_a_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "file.txt"
    target.write_text("x")
    assert main(["bench", "speed", "--smoke", "--only", "env", "--out", str(target)]) == 2
    assert "is a file" in capsys.readouterr().err


def test_cpu_clock_reports_process_cpu_time() -> None:
    case = timing.Case("spin", lambda: sum(range(1000)), work=1.0, calls=3)
    (t,) = timing.measure([case], min_time=0.0, repeats=2, warmup=False, clock="cpu").values()
    assert t.clock == "cpu" and t.seconds == t.cpu_per_call
    assert t.median == pytest.approx(float(np.median(t.cpu_per_call)))


def test_ppo_is_measured_at_the_baselines_n_envs() -> None:
    """PPO is measured at the n_envs of the Detumble PPO config it was written for, the
    previous one (16 envs x 256 steps; the README's target is read there), in every
    configuration but the smoke run's. The shipped configs' training speed is
    ``rigid-env bench learn``'s (issue 24), beside this one."""
    from agents.config import load_config

    repo = Path(__file__).resolve().parents[2]
    baseline = load_config(repo / "configs" / "agents" / "previous" / "ppo_detumble.yaml")
    for cfg in (speed.FULL, speed.QUICK):
        assert baseline.n_envs in cfg.ppo_n_envs


def test_quick_core_measures_every_integrator() -> None:
    assert speed.QUICK.core_integrators == tuple(INTEGRATORS)
    assert speed.QUICK.core_sizes == (1, 256, 4096)


@pytest.mark.slow
def test_heavy_extras_are_imported_only_when_used() -> None:
    """Importing the benchmarks loads neither MuJoCo nor matplotlib (the [bench] extras)."""
    code = (
        "import sys; import rigid_env.bench.speed, rigid_env.bench.accuracy, "
        "rigid_env.bench.stability; print(sorted({'mujoco', 'matplotlib'} & set(sys.modules)))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout
