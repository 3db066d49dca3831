"""The package as a user gets it from an index: a wheel, installed outside the repository.

The wheel is built from a copy of the checkout (so the build writes nothing here), installed with
``--no-deps`` into a temporary folder, and used from another temporary folder by a Python that
sees only that folder and the dependencies (``python -S``, ``PYTHONPATH`` = the folder plus this
venv's site-packages, so neither the checkout nor the editable install can stand in for it).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import textwrap
from pathlib import Path

import pytest

import rigid_env
from agents.shipped import POLICIES
from rigid_env.envs import TASKS
from rigid_env.resources import SCENE_DIR, data_path, data_roots, pretrained_path, scene_path

ROOT = Path(__file__).resolve().parents[1]
# What a build does not read: version control, environments, build and run outputs, docs, tests.
NOT_BUILT = (".git", ".venv", "build", "dist", "runs", "results", "docs", "tests", "*.egg-info")
NOT_BUILT += ("__pycache__", ".pytest_cache", ".ruff_cache", ".hypothesis", "videos")

# Run inside the installed copy: every env with a shipped policy under it, every agent config.
USE_INSTALLED = """
import json, sys
from pathlib import Path

import gymnasium as gym
import numpy as np

import rigid_env
from rigid_env.agents.config import load_config
from rigid_env.agents.evaluate import load_policy, resolve_env_kwargs
from rigid_env.agents.shipped import POLICIES
from rigid_env.agents.vec_adapter import RigidBodySB3VecEnv
from rigid_env.resources import SCENE_DIR, data_path

out = {"rigid_env": rigid_env.__file__, "scene_dir": str(SCENE_DIR)}
try:
    import agents  # noqa: F401
    out["top_level_agents"] = agents.__file__
except ModuleNotFoundError:
    out["top_level_agents"] = None
pretrained = {json.loads(p.read_text())["env_id"]: p.with_suffix(".zip")
              for p in sorted(data_path("agents/pretrained").glob("*.json"))}
out["pretrained"] = sorted(str(p) for p in pretrained.values())
steps = {}
for env_id in POLICIES:
    model = pretrained[env_id]
    kwargs = resolve_env_kwargs(model)  # the task as its sidecar records it
    env = gym.make(env_id, **kwargs)
    obs, _ = env.reset(seed=0)
    policy = load_policy(model, env_id, kwargs)
    for _ in range(3):
        obs, *_ = env.step(policy(obs[None])[0])
    venv = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point", **kwargs)
    vobs, _ = venv.reset(seed=0)
    vobs, *_ = venv.step(policy(vobs))
    sb3 = RigidBodySB3VecEnv(env_id, num_envs=2, **kwargs)
    sb3.reset()
    sb3.step(np.zeros((2, *env.action_space.shape), np.float32))
    steps[env_id] = bool(np.isfinite(obs).all() and np.isfinite(vobs).all())
out["steps"] = steps
out["configs"] = sorted(
    load_config(p).env_id for p in sorted(data_path("configs/agents").glob("*.yaml"))
)
print(json.dumps(out))
"""


def _ignore(folder: str, names: list[str]) -> set[str]:
    return set(shutil.ignore_patterns(*NOT_BUILT)(folder, names))


def _python_outside(target: Path) -> tuple[list[str], dict[str, str]]:
    """A Python command and environment that see ``target`` and the dependencies only."""
    deps = sysconfig.get_paths()["purelib"]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = os.pathsep.join([str(target), deps])
    return [sys.executable, "-S"], env


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The wheel built from a copy of this checkout, installed with --no-deps into a folder."""
    base = tmp_path_factory.mktemp("wheel")
    source = base / "src"
    shutil.copytree(ROOT, source, ignore=_ignore)
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    build = [*pip, "wheel", "--no-deps", "--no-build-isolation", "-w", str(base / "dist")]
    subprocess.run([*build, str(source)], check=True, capture_output=True, timeout=300)
    (wheel,) = (base / "dist").glob("rigid_env-*.whl")
    target = base / "site"
    install = [*pip, "install", "--no-deps", "--no-index", "--target", str(target), str(wheel)]
    subprocess.run(install, check=True, capture_output=True, timeout=300)
    return target


@pytest.mark.slow
def test_wheel_ships_packages_and_data_under_our_own_name(installed: Path) -> None:
    top_level = {p.name for p in installed.iterdir() if not p.name.endswith(".dist-info")}
    assert top_level - {"bin"} == {"rigid_env"}  # no top-level `agents`, `configs`, ...
    packages = [p.parent.relative_to(ROOT) for p in (ROOT / "rigid_env").rglob("__init__.py")]
    packages += [
        Path("rigid_env") / p.parent.relative_to(ROOT) for p in ROOT.glob("agents/**/__init__.py")
    ]
    for package in packages:
        assert (installed / package / "__init__.py").is_file(), f"{package} missing from wheel"
    data = [*ROOT.glob("configs/*/*.yaml"), *ROOT.glob("agents/pretrained/*")]
    for path in data:
        shipped = installed / "rigid_env" / path.relative_to(ROOT)
        assert shipped.is_file(), f"{path.relative_to(ROOT)} missing from the wheel"
        assert shipped.read_bytes() == path.read_bytes()
    assert (installed / "rigid_env" / "py.typed").is_file()
    for task in TASKS.values():  # the registry's tasks: each one's module and scene ship
        assert (installed / "rigid_env" / "envs" / f"{task.module}.py").is_file(), task.name
        scene = installed / "rigid_env" / "configs" / "scenes" / f"{task.scene}.yaml"
        assert scene.is_file(), task.name


@pytest.mark.slow
def test_installed_wheel_makes_steps_and_loads_policies_and_configs(
    installed: Path, tmp_path: Path
) -> None:
    """From a folder outside the checkout: every env with a shipped policy
    (``agents.shipped.POLICIES``: the tasks' and the variants') steps in its single, native
    vector and SB3 adapter forms under that policy; every agent config loads."""
    python, env = _python_outside(installed)
    proc = subprocess.run(
        [*python, "-c", textwrap.dedent(USE_INSTALLED)],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert Path(out["rigid_env"]).is_relative_to(installed)
    assert Path(out["scene_dir"]).is_relative_to(installed)
    assert out["top_level_agents"] is None
    assert out["steps"] == dict.fromkeys(POLICIES, True)
    assert len(out["pretrained"]) == len(POLICIES)
    assert all(Path(p).is_relative_to(installed) for p in out["pretrained"])
    assert len(out["configs"]) == len(list(ROOT.glob("configs/agents/*.yaml")))


@pytest.mark.slow
def test_installed_commands_find_the_shipped_data(installed: Path, tmp_path: Path) -> None:
    """``python -m rigid_env.cli scenes`` lists the wheel's scenes; ``python -m
    rigid_env.agents.evaluate`` runs a shipped policy."""
    python, env = _python_outside(installed)
    run = dict(cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    scenes = subprocess.run([*python, "-m", "rigid_env.cli", "scenes"], **run)
    assert scenes.returncode == 0, scenes.stderr[-2000:]
    assert str(installed) in scenes.stdout and "detumble" in scenes.stdout
    model = installed / "rigid_env" / "agents" / "pretrained" / "ppo_detumble.zip"
    evaluate = [*python, "-m", "rigid_env.agents.evaluate", str(model)]
    evaluate += ["--env", "RigidEnv/Detumble-v0", "--episodes", "4", "--only", "model", "--json"]
    proc = subprocess.run(evaluate, **run)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert json.loads(proc.stdout)["episodes"] == 4


def test_checkout_finds_its_data_through_the_same_paths() -> None:
    """In the checkout (editable install or PYTHONPATH=.) the data stay at the repository root."""
    assert Path(rigid_env.__file__) == ROOT / "rigid_env" / "__init__.py"
    assert ROOT in data_roots()
    assert scene_path("detumble") == ROOT / "configs" / "scenes" / "detumble.yaml"
    assert SCENE_DIR == ROOT / "configs" / "scenes"
    assert pretrained_path("ppo_detumble") == ROOT / "agents" / "pretrained" / "ppo_detumble.zip"
    import rigid_env.agents.vec_adapter as installed_name

    assert Path(installed_name.__file__) == ROOT / "agents" / "vec_adapter.py"
    with pytest.raises(FileNotFoundError) as exc:
        data_path("configs/scenes/nope.yaml")
    assert "configs/scenes/nope.yaml" in str(exc.value) and "\n" not in str(exc.value)
