"""PPO over thousands of envs at once (issue 45): rsl-rl's PPO on the native batched task.

``vec.py`` hands the task, normalised by SB3's own ``VecNormalize``, to rsl-rl as torch tensors;
``learner.py`` builds rsl-rl's runner from a training config and copies its networks into an
SB3 ``PPO`` (the zip every tool of ours reads); ``train.py`` is the run folder around it.
``python -m agents.train CONFIG`` runs it when the config says ``learner: rsl_rl``.
``skrl_peer.py`` is skrl's PPO on the same env stack, the peer ``rigid-env bench learn
--rates-only`` measures beside it; ``sbx_peer.py`` is sbx-rl's PPO (a ``jax.jit``-compiled
update), the third peer (``pip install 'rigid_env[bench]'``).
"""
