"""Issue 35, item 6: properties of the public inputs (Hypothesis), each a contract: one clear
line (a ValueError, the world's NumericalInstabilityError, or the command line's exit 2 with
one stderr line) or a sensible finite result; never a traceback of another type, a non-finite
state, or a changed file the call did not own.

The keys tried come from the pydantic models that validate them (the scene's sections, the env
settings, the randomisation, the fault model, a task's parameters), the values from a mix of
plausible numbers and hostile ones (text, booleans, None, NaN, inf, huge and NumPy scalars).

Budget: the ``ci`` profile (a few seconds a property); ``HYPOTHESIS_PROFILE=long`` tries many
more examples.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import rigid_env.envs  # noqa: F401  (registers the ids)
from rigid_env.cli import main as cli_main
from rigid_env.core.integrators import INTEGRATORS
from rigid_env.core.world import NumericalInstabilityError
from rigid_env.envs.detumble import DetumbleParams
from rigid_env.envs.hardware import ThrusterFaults
from rigid_env.envs.params import EnvSettings, Randomization
from rigid_env.scene import Scene, load_scene
from rigid_env.scene_sections import ThrusterSpec

_COMMON = {
    "deadline": None,
    "database": None,
    "print_blob": True,
    "suppress_health_check": [HealthCheck.too_slow, HealthCheck.filter_too_much],
}
settings.register_profile("ci", max_examples=25, **_COMMON)
settings.register_profile("long", max_examples=1000, derandomize=False, **_COMMON)
PROFILE = settings.get_profile(
    os.environ.get("HYPOTHESIS_PROFILE", "ci")
    if os.environ.get("HYPOTHESIS_PROFILE") in ("ci", "long")
    else "ci"
)
ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "configs" / "scenes" / "detumble.yaml"
D = "RigidEnv/Detumble-v0"

HOSTILE = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.booleans(),
    st.none(),
    st.text(max_size=6),
    st.sampled_from(["1e5", "3.986e14", "0.5", "nan", "1.0e-6", "-1", "true"]),
    st.lists(st.floats(allow_nan=True), max_size=3),
    st.sampled_from([np.float32(0.5), np.int64(3), np.bool_(True), np.float64(np.nan)]),
)
"""Values a hostile user writes where a number (or a list of two) belongs."""
PLAUSIBLE = st.one_of(
    st.floats(min_value=0.0, max_value=1.0),
    st.integers(min_value=1, max_value=5),
    st.lists(st.floats(min_value=0.0, max_value=1.0), min_size=2, max_size=2).map(sorted),
)
"""Values in or near the ranges the knobs take."""
VALUE = st.one_of(PLAUSIBLE, HOSTILE)


def _one_line(exc: BaseException) -> None:
    text = str(exc)
    assert text and "\n" not in text and "Traceback" not in text, repr(text)


def _fields(model: type, *leave_out: str) -> list[str]:
    return [name for name in model.model_fields if name not in leave_out]


@st.composite
def env_kwargs(draw: st.DrawFn) -> dict:
    """Keyword arguments of gym.make: some of the task's parameters, the settings every task
    takes, the randomisation and the fault model, by their models' field names."""
    kwargs: dict = {}
    for name in draw(st.lists(st.sampled_from(_fields(DetumbleParams, "version")), max_size=2)):
        kwargs[name] = draw(VALUE)
    settings_keys = _fields(EnvSettings, "scene", "randomization")
    for name in draw(st.lists(st.sampled_from(settings_keys), max_size=3)):
        kwargs[name] = draw(st.one_of(VALUE, st.sampled_from(
            [*INTEGRATORS, "realistic", "ideal", "sixd", 1e-8, 0.02, 1e-18]
        )))  # fmt: skip
    randomization: dict = {}
    for name in draw(st.lists(st.sampled_from(_fields(Randomization)), max_size=3)):
        if name == "thruster_faults":
            faults = {k: draw(VALUE) for k in draw(st.lists(st.sampled_from(
                _fields(ThrusterFaults)), max_size=3))}  # fmt: skip
            randomization[name] = draw(st.one_of(st.just(faults), HOSTILE))
        elif name == "action_repeat":
            randomization[name] = draw(st.one_of(
                st.lists(st.integers(1, 4), min_size=1, max_size=3, unique=True),
                st.lists(HOSTILE, max_size=2), HOSTILE,
            ))  # fmt: skip
        else:
            randomization[name] = draw(VALUE)
    if randomization or draw(st.booleans()):
        kwargs["randomization"] = draw(st.one_of(st.just(randomization), HOSTILE))
    return kwargs


@settings(PROFILE)
@given(kwargs=env_kwargs(), seed=st.integers(0, 2**32 - 1))
def test_env_kwargs_give_one_line_or_a_finite_rollout(kwargs, seed):
    try:
        env = gym.make(D, **kwargs)
    except ValueError as exc:
        _one_line(exc)
        return
    obs, _ = env.reset(seed=seed)
    assert np.all(np.isfinite(obs))
    for _ in range(3):
        obs, reward, *_ = env.step(env.action_space.sample())
        state = env.unwrapped.task.world.state
        assert np.all(np.isfinite(obs)) and math.isfinite(reward)
        assert all(np.all(np.isfinite(a)) for a in (state.x, state.v, state.q, state.w))


ACTIONS = st.one_of(
    hnp.arrays(
        dtype=st.one_of(hnp.scalar_dtypes(), hnp.byte_string_dtypes(), hnp.unicode_string_dtypes()),
        shape=hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=7),
    ),
    st.lists(st.one_of(st.floats(), st.integers(-(2**70), 2**70), st.booleans()), max_size=7),
    HOSTILE,
)


@pytest.fixture(scope="module")
def detumble():
    env = gym.make(D)
    env.reset(seed=0)
    return env


@settings(PROFILE, max_examples=PROFILE.max_examples * 4)
@given(action=ACTIONS)
def test_actions_of_every_dtype_and_shape(detumble, action):
    """env.step(action): a ValueError of one line, or a finite step with the command clipped
    into [-1, 1]."""
    env = detumble
    try:
        obs, reward, terminated, truncated, _ = env.step(action)
    except ValueError as exc:
        _one_line(exc)
        return
    assert np.all(np.isfinite(obs)) and math.isfinite(reward)
    assert np.all(np.abs(env.unwrapped.task.command) <= 1.0)
    if terminated or truncated:
        env.reset(seed=0)


def _base_scene() -> dict:
    return yaml.safe_load(SCENE.read_text())


SCENE_KEYS = [k for k in _fields(Scene) if k not in ("body", "initial", "effects_spec",
                                                     "actuators")]  # fmt: skip


@st.composite
def scene_dicts(draw: st.DrawFn) -> dict:
    """The Detumble scene with top-level knobs and one thruster's hardware replaced, by the
    field names of the scene's models."""
    data = _base_scene()
    for key in draw(st.lists(st.sampled_from(SCENE_KEYS), max_size=3)):
        data[key] = draw(st.one_of(VALUE, st.sampled_from([*INTEGRATORS, 1e-8, 1e-15, 0.01])))
    thruster = data["actuators"]["thrusters"][0]
    for key in draw(st.lists(st.sampled_from(_fields(ThrusterSpec, "point", "direction")),
                             max_size=3)):  # fmt: skip
        thruster[key] = draw(st.one_of(VALUE, st.sampled_from(["on_off", "proportional"])))
    if draw(st.booleans()):
        data["body"]["mass"] = draw(VALUE)
    return data


@settings(PROFILE)
@given(data=scene_dicts(), command=st.floats(-3.0, 3.0))
def test_scene_dicts_give_one_line_or_a_finite_world(data, command):
    try:
        world = load_scene(data).build_world(1)
    except ValueError as exc:
        _one_line(exc)
        return
    rng = np.random.default_rng(0)
    try:
        for _ in range(3):
            world.draw_thrust_factors(rng)
            world.step(np.full((1, world.action_dim), command))
    except (ValueError, NumericalInstabilityError) as exc:
        _one_line(exc)
        return
    s = world.state
    assert all(np.all(np.isfinite(a)) for a in (s.x, s.v, s.q, s.w))


FLAG_VALUES = st.one_of(
    st.integers(-3, 40).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["", " ", "1e1", "true", "nan", "-0", "2.5", "0x10", "1,2", "rk4", "dop853",
                     "1e-300", "1e-8", "١٢", "--", "-1e308"]),
)  # fmt: skip
FLAGS = ["--steps", "--dt", "--integrator", "--substeps", "--rtol", "--atol", "--action", "--seed"]


@settings(PROFILE)
@given(flags=st.dictionaries(st.sampled_from(FLAGS), FLAG_VALUES, max_size=4))
def test_simulate_arguments_give_one_line_or_a_finite_trajectory(tmp_path_factory, flags):
    """`rigid-env simulate` with hostile flag values, in-process: exit 0 with a finite
    trajectory in --out and nothing else written, or exit 1/2 with one stderr line; --out
    is the only file the call may create."""
    folder = tmp_path_factory.mktemp("sim")
    out = folder / "t.npz"
    flags = {"--steps": "3", **flags}
    argv = ["simulate", str(SCENE), *[f"{k}={v}" for k, v in flags.items()], "--out", str(out)]
    import contextlib
    import io

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = cli_main(argv)
    written = sorted(p.name for p in folder.iterdir())
    if code == 0:
        assert written == ["t.npz"]
        with np.load(out) as data:
            assert all(np.all(np.isfinite(data[k])) for k in data.files)
        return
    assert code in (1, 2), code
    lines = err.getvalue().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rigid-env: error:"), err.getvalue()
    assert written == [], written
