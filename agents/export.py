"""A trained policy as one ONNX file, normalisation folded in, for use off Python.

    rigid-env export MODEL.zip --onnx OUT.onnx [--force]

The graph maps raw observations ``obs`` (batch, obs_dim) float32, as the env returns them, to
the policy's deterministic actions ``actions`` (batch, act_dim) float32, exactly as
:func:`agents.evaluate.load_policy` acts: the ``VecNormalize`` statistics the model's sidecar
names, ``clip((obs - mean) / sqrt(var + eps), -clip_obs, clip_obs)`` computed in float64 as SB3
computes it, then cast to float32, then SB3's network (features, actor MLP, action head) and its
deterministic action, clipped to the action space as SB3's ``predict`` clips it. The model's
env id, env kwargs and the source file travel in the ONNX metadata (``metadata_props``).

Only PPO's Gaussian policies (every shipped one) are exported; SAC and TD3 squash through
tanh and rescale, which this exporter does not yet write (refused in one line).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import torch

OPSET = 18


class ExportError(ValueError):
    """A model that cannot be exported, or an OUT that may not be written (one line)."""


def deployable(model_path: Path) -> tuple[Any, dict[str, Any]]:
    """``(module, metadata)``: a torch module from raw observations to actions, and what the
    ONNX file records. Raises :class:`ExportError` (or ``agents.evaluate.EvaluationError``)."""
    from stable_baselines3 import PPO

    from .evaluate import _load_normalization, find_normalization, read_sidecar

    if not model_path.is_file():
        raise ExportError(f"{model_path}: model file not found; give an SB3 zip "
                          "(agents/pretrained/*.zip or a run's model.zip)")  # fmt: skip
    meta = read_sidecar(model_path) or {}
    if meta.get("algo", "ppo") != "ppo":
        raise ExportError(f"{model_path}: a {meta['algo']} model; the exporter writes PPO "
                          "policies only (SAC and TD3 squash their actions)")  # fmt: skip
    try:
        model = PPO.load(str(model_path), device="cpu")
    except Exception:
        raise ExportError(f"{model_path}: not a loadable SB3 PPO model zip") from None
    policy = model.policy
    if policy.squash_output or getattr(policy, "use_sde", False):
        raise ExportError(f"{model_path}: gSDE or squashed policies are not exported")
    obs_shape = model.observation_space.shape
    norm_path = find_normalization(model_path, meta or None)
    norm = None if norm_path is None else _load_normalization(norm_path, obs_shape)
    module = DeployedPolicy(policy, norm, model.action_space)
    record = {
        "env_id": str(meta.get("env_id", "")),
        "env_kwargs": json.dumps(meta.get("env_kwargs", {})),
        "source": model_path.name,
        "vecnormalize": norm_path.name if norm_path is not None else "",
    }
    return module.eval(), record


class DeployedPolicy(torch.nn.Module):
    """Raw observation -> deterministic action of an SB3 ``ActorCriticPolicy`` (see the module
    docstring); ``norm`` None: the policy reads raw observations."""

    def __init__(self, policy: Any, norm: Any, action_space: Any) -> None:
        super().__init__()
        self.policy = policy
        use = norm is not None and norm.norm_obs
        dim = int(np.prod(policy.observation_space.shape))
        mean = norm.obs_rms.mean if use else np.zeros(dim)
        var = norm.obs_rms.var if use else np.ones(dim)
        eps = norm.epsilon if use else 0.0
        self.normalise = use
        self.clip_obs = float(norm.clip_obs) if use else np.inf
        self.register_buffer("mean", torch.as_tensor(np.asarray(mean, np.float64)))
        self.register_buffer("std", torch.sqrt(torch.as_tensor(np.asarray(var, np.float64)) + eps))
        self.register_buffer("low", torch.as_tensor(action_space.low, dtype=torch.float32))
        self.register_buffer("high", torch.as_tensor(action_space.high, dtype=torch.float32))

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        x = obs
        if self.normalise:
            z = (obs.to(torch.float64) - self.mean) / self.std
            x = torch.clamp(z, -self.clip_obs, self.clip_obs).to(torch.float32)
        features = self.policy.extract_features(x, self.policy.pi_features_extractor)
        latent = self.policy.mlp_extractor.forward_actor(features)
        action = self.policy.action_net(latent)
        return torch.maximum(torch.minimum(action, self.high), self.low)


def export_onnx(model_path: Path, out: Path, force: bool = False) -> Path:
    """Write ``model_path``'s policy to ``out`` as ONNX; returns ``out``.

    Raises:
        ExportError: a missing or foreign model, or ``out`` exists and ``force`` is not set.
    """
    import onnx

    companions = [model_path, model_path.with_suffix(".json")]
    companions += list(model_path.parent.glob(f"{model_path.stem}*vecnormalize*.pkl"))
    if out.exists() and any(p.exists() and out.samefile(p) for p in companions):
        raise ExportError(  # --force would replace the policy (or its companion) by its export
            f"{out}: is the model's own file ({model_path.name} or its sidecar/statistics); "
            "give the ONNX file another name, such as "
            f"{model_path.with_suffix('.onnx')}"
        )
    if out.is_dir() and not out.is_symlink():  # --force would not replace a folder
        raise ExportError(
            f"{out}: is a folder; give the ONNX file's name, such as {out / 'policy.onnx'}"
        )
    if (out.exists() or out.is_symlink()) and not force:
        raise ExportError(f"{out}: exists; pass --force to replace it, or choose another path")
    if out.is_dir():
        raise ExportError(f"{out}: is a folder; give a file name such as policy.onnx")
    module, record = deployable(model_path)
    dim = int(np.prod(module.policy.observation_space.shape))
    example = torch.zeros(2, dim, dtype=torch.float32)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".tmp-{out.name}")
    torch.onnx.export(
        module,
        (example,),
        str(tmp),
        input_names=["obs"],
        output_names=["actions"],
        dynamic_axes={"obs": {0: "batch"}, "actions": {0: "batch"}},
        opset_version=OPSET,
        dynamo=False,
    )
    graph = onnx.load(str(tmp))
    for key, value in record.items():
        entry = graph.metadata_props.add()
        entry.key, entry.value = key, value
    onnx.save(graph, str(tmp))
    tmp.replace(out)
    return out
