"""The tasks that ship a training configuration per algorithm (``configs/agents/<algo>_<task>
.yaml``) and a pretrained policy (``agents/pretrained/ppo_<task>.zip``): what the demo, the
baselines and their tests loop over. A registered task not listed here (a new one, before
anyone trains it) is an environment like any other, and the suite stays green without it."""

from __future__ import annotations

from rigid_env.envs import TASKS as REGISTERED

SHIPPED = ("Detumble", "SpinStabilize", "Reorient", "TumblingFall")
"""Task names (as in :data:`rigid_env.envs.TASKS`) with configs and a pretrained policy."""

TASKS: dict[str, tuple[str, int, int]] = {name: REGISTERED[name] for name in SHIPPED}
"""(task module, max_episode_steps, newest version) of each shipped task."""

ENV_IDS = [f"RigidEnv/{name}-v{newest}" for name, (_, _, newest) in TASKS.items()]
"""The newest id of each shipped task: the one its policy was trained on."""
