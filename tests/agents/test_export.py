"""`rigid-env export MODEL --onnx OUT`: every shipped policy as ONNX, acting as in Python."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("onnxruntime")

from agents.evaluate import load_policy
from agents.export import export_onnx
from agents.shipped import POLICIES
from rigid_env.cli import main

ROOT = Path(__file__).resolve().parents[2]
PRETRAINED = ROOT / "agents" / "pretrained"
OBSERVATIONS = 10_000
ENVS = 100
# ONNX Runtime and torch compute the same float32 layers on the same float64-normalised inputs;
# they differ only in the order of the sums inside each matrix product: a relative rounding of
# about sqrt(64) * 6e-8 = 5e-7 of an O(1) pre-activation per layer (tanh contracts it), so the
# actions, in [-1, 1], agree to ~1e-6; the 1e-5 leaves 10x margin.
SAME_ACTIONS = 1e-5


def task_observations(env_id: str, env_kwargs: dict, policy) -> np.ndarray:
    """10k observations the policy meets on its task: ENVS episodes at once, the policy
    acting with noise (so the states leave its own narrow path), reset as they end."""
    env = gym.make_vec(env_id, num_envs=ENVS, vectorization_mode="vector_entry_point",
                       **env_kwargs)  # fmt: skip
    rng = np.random.default_rng(0)
    obs, _ = env.reset(seed=7)
    seen = []
    for _ in range(OBSERVATIONS // ENVS):
        seen.append(obs.copy())
        action = policy(obs) + rng.normal(0.0, 0.3, size=env.action_space.shape)
        obs, *_ = env.step(np.clip(action, -1.0, 1.0).astype(np.float32))
    env.close()
    return np.concatenate(seen).astype(np.float32)


@pytest.mark.parametrize("env_id", sorted(POLICIES))
def test_onnx_actions_equal_torch(env_id: str, tmp_path: Path) -> None:
    import onnxruntime as ort

    model = PRETRAINED / f"ppo_{POLICIES[env_id]}.zip"
    env_kwargs = json.loads(model.with_suffix(".json").read_text())["env_kwargs"]
    torch_policy = load_policy(model, env_id, env_kwargs)
    out = export_onnx(model, tmp_path / "policy.onnx")
    session = ort.InferenceSession(str(out), providers=["CPUExecutionProvider"])
    obs = task_observations(env_id, env_kwargs, torch_policy)
    assert obs.shape[0] == OBSERVATIONS
    onnx_actions = session.run(["actions"], {"obs": obs})[0]
    torch_actions = torch_policy(obs)
    assert onnx_actions.shape == torch_actions.shape
    assert np.abs(onnx_actions - torch_actions).max() <= SAME_ACTIONS
    # the statistics matter: without them the actions differ (the test could fail)
    assert np.abs(session.run(["actions"], {"obs": obs * 0})[0] - torch_policy(obs * 0)).max() \
        <= SAME_ACTIONS  # fmt: skip
    meta = session.get_modelmeta().custom_metadata_map
    assert meta["env_id"] == env_id
    assert json.loads(meta["env_kwargs"]) == env_kwargs


def test_onnx_runs_without_torch(tmp_path: Path) -> None:
    """The docs' recipe: NumPy and ONNX Runtime only (torch made unimportable)."""
    model = PRETRAINED / "ppo_detumble.zip"
    out = export_onnx(model, tmp_path / "policy.onnx")
    dim = gym.spec("RigidEnv/Detumble-v0").make().observation_space.shape[0]
    obs = np.linspace(-1.0, 1.0, 4 * dim, dtype=np.float32).reshape(4, dim)
    expected = load_policy(model, "RigidEnv/Detumble-v0")(obs)
    np.save(tmp_path / "obs.npy", obs)
    script = (
        "import sys; sys.modules['torch'] = None\n"
        "import numpy as np, onnxruntime as ort\n"
        f"s = ort.InferenceSession({str(out)!r})\n"
        f"a = s.run(['actions'], {{'obs': np.load({str(tmp_path / 'obs.npy')!r})}})[0]\n"
        f"np.save({str(tmp_path / 'a.npy')!r}, a)\n"
    )
    subprocess.run([sys.executable, "-c", script], check=True, timeout=120)
    assert np.abs(np.load(tmp_path / "a.npy") - expected).max() <= SAME_ACTIONS


def test_export_refuses_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["export", str(tmp_path / "nope.zip"), "--onnx", str(tmp_path / "p.onnx")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "model file not found" in err
    out = tmp_path / "p.onnx"
    out.write_text("mine")
    model = str(PRETRAINED / "ppo_detumble.zip")
    assert main(["export", model, "--onnx", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--force" in err
    assert out.read_text() == "mine"
    not_a_model = tmp_path / "x.zip"
    not_a_model.write_text("not a zip")
    assert main(["export", str(not_a_model), "--onnx", str(tmp_path / "q.onnx")]) == 2
    assert "not a loadable" in capsys.readouterr().err
    assert main(["export", model, "--onnx", str(out), "--force"]) == 0
    assert out.stat().st_size > 1000
    assert not os.path.exists(tmp_path / "q.onnx")
