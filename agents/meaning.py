"""What a policy's actions mean, carried inside its model file and checked by every loader.

An action component is a command in [-1, 1] to one actuator of the scene; what it does depends
on the actuator (its kind, axis or point and direction, its limit: the force, dipole or motor
torque at ``|u| = 1``) and on the task's keywords that change how actions become commands
(:data:`COMMAND_KEYS`: BdotDetumble's ``command``, coil dipoles or wanted torques over
``max_dipole |B|``). :func:`meaning_of` derives that record from an env; :func:`stamp` puts it on
a model, whose ``save`` then writes it into the zip's ``data`` entry (SB3 saves a model's
attributes there as JSON, and ``load`` sets them back: a plain ``PPO.load`` keeps it as
``model.action_meaning``); :func:`recorded_meaning` reads it back from the zip without torch;
:func:`mismatch` names the first thing that differs, for a one-line refusal.

What does not change the meaning is left out on purpose: the randomisation (draws about the
same nominal actuators), the step ``dt`` and the integrator, the sensors, the thrusters'
hardware (an on/off valve fires the commanded fraction of the step: the same mean force).
"""

from __future__ import annotations

import json
import math
import re
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from rigid_env.core.actuator import meaning_keys, meaning_rows, named, specs

ATTRIBUTE = "action_meaning"
"""The model attribute (and key of the zip's ``data`` JSON) that holds the record."""

COMMAND_KEYS = meaning_keys()
"""A task's keywords that change how an action becomes its actuators' commands (not its shape),
as the actuators declare them (:attr:`rigid_env.core.actuator.Actuator.meaning_keys`: the
magnetorquers' ``command``, BdotDetumble's)."""

RTOL = 1.0e-9
"""Relative tolerance of two records' numbers: both are derived by the same float64 arithmetic
from the scene's numbers (a direction normalised, a cross product), so a scene written with the
same values agrees to a few ulps (1e-15); 1e-9 leaves a million-fold margin and still tells any
change a user would make (a limit or an axis off by 1e-9 does not change a policy's play)."""


def meaning_of(env: Any) -> dict[str, Any]:
    """The record of what ``env``'s actions mean (a JSON mapping): the action's width, each
    actuator in the order of its components (kind, count, what a unit command does) and the
    task's :data:`COMMAND_KEYS` it sets. ``env`` is a single or vector env of this package (or
    a wrapper of one)."""
    task = env.unwrapped.task
    actuators = specs(task.world.force_effects)
    params = task.params
    return {
        "action_dim": int(task.action_dim),
        "actuators": [
            {"kind": a.name, "count": int(a.action_dim), **meaning_rows(a)} for a in actuators
        ],
        **{key: getattr(params, key) for key in COMMAND_KEYS if hasattr(params, key)},
    }


def stamp(model: Any, env_id: str, env_kwargs: dict[str, Any]) -> None:
    """Record on ``model`` what the actions of ``env_id`` made with ``env_kwargs`` mean (its
    ``save`` then writes the record inside the zip)."""
    import gymnasium as gym

    env = gym.make(env_id, **env_kwargs)
    try:
        setattr(model, ATTRIBUTE, meaning_of(env))
    finally:
        env.close()


def recorded_meaning(model_path: Path) -> dict[str, Any] | None:
    """The record inside an SB3 model zip (its ``data`` JSON), or None where it has none (a
    model saved before records, or from elsewhere) or is not a zip of SB3's."""
    try:
        with zipfile.ZipFile(model_path) as zf:
            data = json.loads(zf.read("data"))
    except (OSError, KeyError, ValueError, zipfile.BadZipFile):
        return None
    record = data.get(ATTRIBUTE) if isinstance(data, dict) else None
    return record if isinstance(record, dict) else None


def _describe(value: Any) -> str:
    """A value of a record in a few words: an actuator list by its kinds and counts, numbers
    by their first six."""
    if isinstance(value, list) and all(isinstance(x, dict) for x in value):
        kinds = ", ".join(f"{x.get('kind', '?')} x{x.get('count', '?')}" for x in value)
        return f"[{kinds}]"
    if isinstance(value, list):
        flat = np.asarray(value, dtype=np.float64).ravel()
        shown = ", ".join(f"{x:.4g}" for x in flat[:6])
        return f"[{shown}{', ...' if flat.size > 6 else ''}]"
    return repr(value)


def _first_difference(want: Any, got: Any, where: str) -> tuple[str, Any, Any] | None:
    if isinstance(want, dict) and isinstance(got, dict):
        for key in [*want, *(k for k in got if k not in want)]:
            if key not in want or key not in got:
                return f"{where}{key}", want.get(key, "(none)"), got.get(key, "(none)")
            found = _first_difference(want[key], got[key], f"{where}{key}.")
            if found is not None:
                return found
        return None
    if isinstance(want, list) and isinstance(got, list):
        if len(want) != len(got):
            return where.rstrip("."), want, got
        if all(isinstance(x, dict) for x in want + got):
            for k, (a, b) in enumerate(zip(want, got, strict=True)):
                kind = f" ({a['kind']})" if isinstance(a.get("kind"), str) else ""
                found = _first_difference(a, b, f"{where.rstrip('.')}[{k}]{kind}.")
                if found is not None:
                    return found
            return None
        a, b = np.asarray(want, dtype=np.float64), np.asarray(got, dtype=np.float64)
        scale = max(float(np.abs(a).max(initial=0.0)), float(np.abs(b).max(initial=0.0)))
        same = a.shape == b.shape and np.allclose(a, b, rtol=RTOL, atol=RTOL * scale)
        return None if same else (where.rstrip("."), want, got)
    if isinstance(want, float | int) and isinstance(got, float | int):
        same = math.isclose(want, got, rel_tol=RTOL) and type(want) is type(got)
        return None if same else (where.rstrip("."), want, got)
    return None if want == got else (where.rstrip("."), want, got)


def mismatch(want: dict[str, Any], got: dict[str, Any]) -> str | None:
    """None where ``got`` (an env's record) means what ``want`` (a model's) does; else one
    clause naming the first difference and the fix: ``command: the model's actions are
    'torque', the env's 'dipole'; pass command=torque``."""
    found = _first_difference(want, got, "")
    if found is None:
        return None
    key, a, b = found
    if key in COMMAND_KEYS:
        fix = f"pass {key}={a} (--env-kwargs {key}={a})"
    else:
        fix = f"use the scene and env_kwargs it was trained with ({_scene_keys(key)})"
    return f"{key}: the model's actions mean {_describe(a)}, this env's {_describe(b)}; {fix}"


def _scene_keys(key: str) -> str:
    """The scene keys that set what differs at ``key`` of a record (``actuators[0]
    (magnetorquers).dipole [A m^2]``: its section's :attr:`~rigid_env.core.actuator.Actuator.
    scene_keys`), or the actuators' list where the kinds or their counts differ."""
    kind = re.match(r"actuators\[\d+\] \((\w+)\)\.(?!kind$|count$)", key)
    try:
        keys = named(kind.group(1)).scene_keys if kind else ()
    except KeyError:  # a kind an outside module registered and this process does not know
        keys = ()
    if not keys:
        return "its scene's actuators: their kinds, counts and limits"
    return f"its scene's actuators.{kind.group(1)}: " + ", ".join(keys)


def stamp_file(model_path: Path, record: dict[str, Any]) -> None:
    """Write ``record`` into a saved model zip's ``data`` JSON (as ``save`` does for a stamped
    model), every other entry copied byte for byte (the weights untouched); the zip is replaced
    whole, never left half written."""
    tmp = model_path.with_name(f".{model_path.name}.stamp.tmp")
    try:
        with zipfile.ZipFile(model_path) as src, zipfile.ZipFile(tmp, "w") as dst:
            for info in src.infolist():
                raw = src.read(info)
                if info.filename == "data":
                    data = json.loads(raw)
                    data[ATTRIBUTE] = record
                    raw = json.dumps(data, indent=4).encode()
                dst.writestr(info, raw)
        tmp.replace(model_path)
    finally:
        tmp.unlink(missing_ok=True)
