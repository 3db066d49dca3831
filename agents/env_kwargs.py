"""Environment keyword arguments: parsed from the command line, checked by building the env once.

Both ``agents.train`` (a config's ``env_kwargs``) and ``agents.evaluate`` (``--env-kwargs``)
check them here before any work starts, so a wrong value ends in one line, not in a traceback
an hour into a run.
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from typing import Any

import gymnasium as gym

import rigid_env  # noqa: F401  (registers the ids)
from rigid_env.envs import merge_kwargs
from rigid_env.envs.params import EnvSettings, Randomization
from rigid_env.scene import SceneError


def parse_env_kwargs(items: Sequence[str]) -> dict[str, Any]:
    """``{"randomization": {"inertia": 0.2}}`` (a JSON object) or ``key=value`` pairs, merged in
    order; a dotted key nests (``randomization.inertia=0.2``) and a value is read as JSON when
    it parses (``dt=0.02`` is a number, ``integrator=rk4`` a string).

    Raises:
        ValueError: ``"problem; fix"`` for anything else.
    """
    out: dict[str, Any] = {}
    for item in items:
        text = item.strip()
        if text.startswith("{"):
            try:
                value = json.loads(text)
            except json.JSONDecodeError as exc:
                raise ValueError(
                    f"{text!r} is not valid JSON ({exc.msg} at column {exc.colno}); "
                    """quote keys and strings with ": '{"integrator": "rk4"}'"""
                ) from None
            if not isinstance(value, dict):
                raise ValueError(f'{text!r} is not a JSON object; write {{"key": value}}')
            out = merge_kwargs(out, value)
            continue
        key, sep, raw = text.partition("=")
        if not sep or not key.strip():
            raise ValueError(
                f"expected a JSON object or KEY=VALUE, got {text!r}; e.g. --env-kwargs dt=0.02 "
                """or --env-kwargs '{"randomization": {"inertia": 0.2}}'"""
            )
        try:
            value = json.loads(raw)
        except json.JSONDecodeError:
            value = raw
        nested: dict[str, Any] = {}
        for name in reversed(key.strip().split(".")):
            nested = {name: value}
            value = nested
        out = merge_kwargs(out, nested)
    return out


merge_env_kwargs = merge_kwargs
"""``over`` merged into a copy of ``base``, mappings key by key (so ``{"randomization":
{"inertia": 0.2}}`` keeps a recorded ``randomization.mass``): the envs' own merge
(:func:`rigid_env.envs.merge_kwargs`), which a registered variant applies to its defaults."""


def check_env_kwargs(env_id: str, env_kwargs: dict[str, Any]) -> gym.Env:
    """Build ``env_id`` with ``env_kwargs`` once; the caller closes it.

    Raises:
        ValueError: ``"field: problem; fix"`` naming the keyword (``integrator``,
            ``randomization.inertia``, ...).
    """
    if env_id not in gym.registry:
        known = ", ".join(k for k in gym.registry if k.startswith("RigidEnv/"))
        raise ValueError(f"unknown id {env_id!r}; known: {known}")
    try:
        return gym.make(env_id, **env_kwargs)
    except SceneError as exc:
        if exc.path and "(with overrides)" in exc.file:  # a keyword overrode a scene field
            raise ValueError(f"{exc.path}: {exc.problem}; {exc.fix}") from None
        raise ValueError(f"scene: {exc}") from None
    except TypeError as exc:
        m = re.search(r"(\w+)\.__init__\(\) got an unexpected keyword argument '(\w+)'", str(exc))
        if m is None:
            raise ValueError(f"{exc}; check the keyword arguments of {env_id}") from None
        owner, key = m.groups()
        if owner == "Randomization":
            raise ValueError(
                f"randomization.{key}: unknown key; use {', '.join(Randomization.model_fields)}"
            ) from None
        raise ValueError(
            f"{key}: unknown keyword; {env_id} takes {', '.join(EnvSettings.model_fields)} and "
            "its task's parameters"
        ) from None
    except ValueError as exc:
        text = " ".join(str(exc).split())
        raise ValueError(text if "; " in text else f"{text}; fix the value") from None
