"""The ``rigid-env`` command line: simulate's output file, one-line errors, exit codes."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from rigid_env import __version__
from rigid_env.cli import main
from rigid_env.core.integrators import INTEGRATORS

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "configs" / "scenes" / "asymmetric_spin.yaml"
KEYS = {
    "t",
    "position",
    "velocity",
    "orientation",
    "angular_velocity_body",
    "angular_velocity_world",
    "energy",
    "angular_momentum_world",
}
# rk4 on a torque-free asymmetric body with |w| dt ~ 0.015: the relative energy error stays
# below 1e-9 over 2000 steps (measured 3e-13; explicit Euler drifts 6e-4 on the same run).
RK4_ENERGY_RTOL = 1.0e-9


def torque_free_scene(tmp_path: Path) -> Path:
    path = tmp_path / "torque_free.yaml"
    path.write_text(
        yaml.safe_dump(
            {
                "name": "torque_free",
                "dt": 0.01,
                "integrator": "rk4",
                "body": {"mass": 1.0, "shape": {"box": [0.3, 0.2, 0.1]}},
                "initial": {"angular_velocity": [0.3, 1.5, 0.2], "velocity": [1.0, 0.0, 0.0]},
            }
        )
    )
    return path


def assert_one_line_error(err: str, *words: str) -> None:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("rigid-env: error: "), err
    assert "Traceback" not in err
    for word in words:
        assert word in lines[0], (word, lines[0])


def test_simulate_writes_arrays_with_shapes(tmp_path, capsys):
    out = tmp_path / "deep" / "dir" / "traj.npz"  # parent directories are created
    steps = 50
    rc = main(
        ["simulate", str(EXAMPLE), "--steps", str(steps), "--out", str(out), "--action", "0.5"]
    )
    assert rc == 0
    summary = capsys.readouterr().out
    assert "asymmetric_spin: 50 steps" in summary and "rk4" in summary and str(out) in summary
    with np.load(out) as data:
        assert set(data.files) == KEYS
        assert data["t"].shape == (steps + 1,)
        np.testing.assert_allclose(data["t"], 0.01 * np.arange(steps + 1), rtol=1e-14)
        assert data["energy"].shape == (steps + 1,)
        for key in KEYS - {"t", "energy", "orientation"}:
            assert data[key].shape == (steps + 1, 3), key
        assert data["orientation"].shape == (steps + 1, 4)
        np.testing.assert_allclose(np.linalg.norm(data["orientation"], axis=1), 1.0, rtol=1e-14)
        np.testing.assert_array_equal(data["angular_velocity_body"][0], [1.0, 0.0, 2.0])
        # angular_momentum_world = R (I w) with the file's inertia (1, 2, 3).
        np.testing.assert_allclose(data["angular_momentum_world"][0], [1.0, 0.0, 6.0])


def test_simulate_rk4_torque_free_conserves_energy_and_momentum(tmp_path, capsys):
    out = tmp_path / "tf.npz"
    assert (
        main(["simulate", str(torque_free_scene(tmp_path)), "--steps", "2000", "--out", str(out)])
        == 0
    )
    with np.load(out) as data:
        energy = data["energy"]
        l_world = data["angular_momentum_world"]
        position = data["position"]
        w_body = data["angular_velocity_body"]
    assert np.max(np.abs(energy - energy[0])) <= RK4_ENERGY_RTOL * energy[0]
    np.testing.assert_allclose(
        l_world,
        np.broadcast_to(l_world[0], l_world.shape),
        rtol=0,
        atol=RK4_ENERGY_RTOL * np.linalg.norm(l_world[0]),
    )
    # Nothing acts on the centre of mass: uniform motion, x = v t.
    np.testing.assert_allclose(position[-1], [20.0, 0.0, 0.0], rtol=1e-12)
    # The spin about the intermediate axis (y) is unstable: the body does tumble (w_y flips).
    assert w_body.shape == (2001, 3) and np.ptp(w_body[:, 1]) > 2.0


def test_overrides_change_the_run(tmp_path, capsys):
    out = tmp_path / "o.npz"
    rc = main(
        [
            "simulate",
            str(torque_free_scene(tmp_path)),
            "--steps",
            "10",
            "--dt",
            "0.002",
            "--integrator",
            "splitting",
            "--substeps",
            "3",
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    assert "splitting (3 substeps per step)" in capsys.readouterr().out
    with np.load(out) as data:
        assert data["t"][-1] == pytest.approx(0.02, rel=1e-14)


def test_negative_action_value_is_accepted(tmp_path, capsys):
    out = tmp_path / "neg.npz"
    assert (
        main(["simulate", str(EXAMPLE), "--steps", "5", "--action", "-0.5", "--out", str(out)]) == 0
    )
    with np.load(out) as data:
        # Thruster at (0.15, 0, 0) along +y with 0.5 N backwards: torque -0.075 about z.
        assert data["angular_velocity_body"][1, 2] < 2.0


@pytest.mark.parametrize(
    ("action", "words"),
    [
        ("nan", ["--action", "not a finite number"]),
        ("inf", ["--action", "not a finite number"]),
        ("1.5", ["--action", "outside [-1, 1]"]),
        ("-2", ["--action", "outside [-1, 1]"]),
        ("0.1,abc", ["--action", "'abc'"]),
        ("0.1,0.2", ["--action", "1 actuator component", "got 2"]),
    ],
)
def test_bad_action_exits_2_with_one_line(tmp_path, capsys, action, words):
    out = tmp_path / "a.npz"
    rc = main(["simulate", str(EXAMPLE), "--steps", "3", "--action", action, "--out", str(out)])
    assert rc == 2
    assert_one_line_error(capsys.readouterr().err, *words)
    assert not out.exists()


@pytest.mark.parametrize(
    ("flags", "words"),
    [
        (["--dt", "0"], ["--dt", "> 0"]),
        (["--dt", "nan"], ["--dt", "finite"]),
        (["--substeps", "0"], ["--substeps", ">= 1"]),
        (["--steps", "x"], ["--steps", "integer"]),
        (["--integrator", "rk5"], ["--integrator", "rk5", *INTEGRATORS]),
        (["--bogus"], ["unrecognized arguments: --bogus"]),
    ],
)
def test_bad_flag_exits_2_with_one_line(tmp_path, capsys, flags, words):
    argv = ["simulate", str(EXAMPLE), "--steps", "3", "--out", str(tmp_path / "f.npz")]
    if "--steps" in flags:
        argv[3] = flags[1]
        flags = []
    assert main(argv + flags) == 2
    assert_one_line_error(capsys.readouterr().err, *words)


def test_bad_scene_exits_2_naming_file_and_field(tmp_path, capsys):
    scene = tmp_path / "bad.yaml"
    scene.write_text("body: {mass: -1.0, shape: {sphere: 0.1}}\n")
    rc = main(["simulate", str(scene), "--steps", "3", "--out", str(tmp_path / "x.npz")])
    assert rc == 2
    assert_one_line_error(
        capsys.readouterr().err, str(scene), "body.mass", "must be greater than 0"
    )


def test_missing_scene_file_exits_2(tmp_path, capsys):
    missing = tmp_path / "nope.yaml"
    rc = main(["simulate", str(missing), "--steps", "3", "--out", str(tmp_path / "x.npz")])
    assert rc == 2
    assert_one_line_error(capsys.readouterr().err, str(missing), "file not found")


def test_refuses_to_overwrite_without_force(tmp_path, capsys):
    out = tmp_path / "mine.npz"
    out.write_bytes(b"something the user wrote")
    rc = main(["simulate", str(EXAMPLE), "--steps", "3", "--out", str(out)])
    assert rc == 2
    assert_one_line_error(capsys.readouterr().err, str(out), "--force")
    assert out.read_bytes() == b"something the user wrote"
    assert main(["simulate", str(EXAMPLE), "--steps", "3", "--out", str(out), "--force"]) == 0
    with np.load(out) as data:
        assert data["t"].shape == (4,)
    assert [p.name for p in tmp_path.iterdir()] == ["mine.npz"]  # no temporary left behind


def test_instability_exits_1_with_one_line(tmp_path, capsys):
    scene = tmp_path / "blow.yaml"
    scene.write_text(
        yaml.safe_dump(
            {
                "dt": 1.0,
                "integrator": "explicit_euler",
                "body": {
                    "mass": 1.0,
                    "shape": {"box": [0.3, 0.2, 0.1]},
                    "inertia": [1.0, 2.0, 3.0],
                },
                "initial": {"angular_velocity": [100.0, 100.0, 100.0]},
            }
        )
    )
    out = tmp_path / "blow.npz"
    assert main(["simulate", str(scene), "--steps", "100", "--out", str(out)]) == 1
    assert_one_line_error(capsys.readouterr().err, "non-finite", "explicit_euler")
    assert not out.exists()


def test_bench_without_module_exits_2(monkeypatch, capsys):
    # None in sys.modules makes the import fail as if the module were absent.
    monkeypatch.setitem(sys.modules, "rigid_env.bench.accuracy", None)
    assert main(["bench", "accuracy", "--quick"]) == 2
    assert_one_line_error(capsys.readouterr().err, "bench accuracy")
    assert main(["bench"]) == 2
    assert_one_line_error(capsys.readouterr().err, "accuracy, speed")


def test_bench_passes_its_flags_to_the_module(monkeypatch, capsys):
    import types

    seen = {}
    fake = types.ModuleType("rigid_env.bench.speed")

    def add_arguments(parser):
        parser.add_argument("--out", default="x")
        parser.add_argument("--quick", action="store_true")

    def run(args):
        seen.update(vars(args))
        return 0

    fake.add_arguments = add_arguments
    fake.run = run
    monkeypatch.setitem(sys.modules, "rigid_env.bench.speed", fake)
    assert main(["bench", "speed", "--out", "dir", "--quick"]) == 0
    assert seen == {"out": "dir", "quick": True}
    assert main(["bench", "speed", "--nope"]) == 2
    assert_one_line_error(capsys.readouterr().err, "--nope", "bench speed")


def test_listing_commands_and_version(capsys):
    assert main(["integrators"]) == 0
    out = capsys.readouterr().out
    for name, info in INTEGRATORS.items():
        assert any(line.split()[:2] == [name, str(info.order)] for line in out.splitlines())
    assert main(["scenes"]) == 0
    out = capsys.readouterr().out
    assert "asymmetric_spin" in out and "free_fall" in out and "invalid" not in out
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"rigid-env {__version__}"


def run_cli(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "rigid_env.cli", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


@pytest.mark.slow
def test_subprocess_simulate_example(tmp_path):
    out = tmp_path / "traj.npz"
    proc = run_cli(
        "simulate", "configs/scenes/asymmetric_spin.yaml", "--steps", "1000", "--out", str(out)
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    assert "1000 steps" in proc.stdout and "final |w|" in proc.stdout
    with np.load(out) as data:
        assert data["position"].shape == (1001, 3)
        assert np.all(np.isfinite(data["position"]))


@pytest.mark.slow
def test_subprocess_bad_input_one_line_no_traceback(tmp_path):
    scene = tmp_path / "typo.yaml"
    scene.write_text("body: {mass: 1.0, shape: {box: [0.3, 0.2, 0.1]}}\nintegrater: rk4\n")
    proc = run_cli("simulate", str(scene), "--steps", "3", "--out", str(tmp_path / "o.npz"))
    assert proc.returncode == 2
    assert_one_line_error(proc.stderr, "integrater", "unknown key", "integrator")
    proc = run_cli(
        "simulate", str(scene), "--steps", "3", "--action", "nan", "--out", str(tmp_path / "o.npz")
    )
    assert proc.returncode == 2
    assert_one_line_error(proc.stderr, "--action")


@pytest.mark.slow
def test_simulate_does_not_import_benchmark_dependencies(tmp_path):
    code = (
        "import sys\n"
        "from rigid_env.cli import main\n"
        f"rc = main(['simulate', {str(EXAMPLE)!r}, '--steps', '2', "
        f"'--out', {str(tmp_path / 'x.npz')!r}])\n"
        "heavy = [m for m in ('matplotlib', 'mujoco', 'rigid_env.bench.accuracy', "
        "'rigid_env.bench.speed') if m in sys.modules]\n"
        "print('HEAVY', heavy, rc)\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        cwd=ROOT,
    )
    assert "HEAVY [] 0" in proc.stdout, proc.stdout + proc.stderr
