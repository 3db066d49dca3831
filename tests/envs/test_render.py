"""rgb_array and human rendering of the tasks (headless, under SDL's dummy video driver)."""

from __future__ import annotations

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")  # before pygame is imported anywhere

import ast
import sys
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import rigid_env
import rigid_env.render
from rigid_env.core.rotation import quat_from_axis_angle
from rigid_env.envs.detumble import DetumbleTask
from rigid_env.render import TaskRenderer, actuator_layout, body_box_size

pytest.importorskip("pygame", reason="rendering needs pygame: pip install -e '.[render]'")

ENV_IDS = rigid_env.envs.ENV_IDS
H = W = 480
# A frame "changes" when at least this fraction of its pixels differ: a visible change, not the
# odd anti-aliased pixel.
CHANGED_FRACTION = 0.005


def make(env_id: str = "RigidEnv/Detumble-v0", seed: int = 0, **kwargs):
    env = gym.make(env_id, render_mode="rgb_array", **kwargs)
    env.reset(seed=seed)
    return env


def changed_fraction(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.mean(np.any(a != b, axis=-1)))


def set_pose(task, q, w=(0.0, 0.0, 0.0), action=None) -> None:
    s = task.world.state
    s.q[0] = q
    s.w[0] = w
    task.last_action[0] = 0.0 if action is None else action


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_rgb_array_frame_is_an_image(env_id):
    env = make(env_id)
    env.step(env.action_space.sample())
    frame = env.render()
    env.close()
    assert frame.shape == (H, W, 3)
    assert frame.dtype == np.uint8
    # Not blank: many colours (body shading, flames, text), not one fill.
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 100
    assert frame.std() > 10.0


def test_frame_changes_when_the_body_rotates():
    env = make()
    task = env.unwrapped.task
    set_pose(task, [1.0, 0.0, 0.0, 0.0])
    a = env.render()
    set_pose(task, quat_from_axis_angle(np.array([0.3, 0.5, 0.8]), 0.6))
    b = env.render()
    env.close()
    assert changed_fraction(a, b) > CHANGED_FRACTION


def test_same_state_gives_the_same_frame():
    frames = []
    for _ in range(2):  # two separate envs and renderers
        env = make(seed=7)
        env.step(np.linspace(-1.0, 1.0, 6).astype(np.float32))
        frames += [env.render(), env.render()]
        env.close()
    assert all(np.array_equal(frames[0], f) for f in frames[1:])


def test_thruster_firing_changes_the_frame():
    env = make()
    task = env.unwrapped.task
    q = quat_from_axis_angle(np.array([0.2, -0.4, 0.9]), 0.4)
    set_pose(task, q, action=np.zeros(6))
    idle = env.render()
    set_pose(task, q, action=np.ones(6))
    firing = env.render()
    set_pose(task, q, action=-np.ones(6))
    reverse = env.render()
    env.close()
    assert changed_fraction(idle, firing) > CHANGED_FRACTION
    # A negative command fires the other way: another picture.
    assert changed_fraction(firing, reverse) > CHANGED_FRACTION


def test_angular_velocity_arrow_changes_the_frame():
    env = make()
    task = env.unwrapped.task
    set_pose(task, [1.0, 0.0, 0.0, 0.0], w=(0.0, 0.0, 0.0))
    rest = env.render()
    set_pose(task, [1.0, 0.0, 0.0, 0.0], w=(0.0, 0.0, 3.0))
    spinning = env.render()
    env.close()
    assert changed_fraction(rest, spinning) > CHANGED_FRACTION


def test_huge_spin_renders_without_warnings():
    env = make()
    set_pose(env.unwrapped.task, [1.0, 0.0, 0.0, 0.0], w=(1.0e200, 1.0e200, 0.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        frame = env.render()
    env.close()
    assert frame.shape == (H, W, 3)


def test_vector_env_renders_sub_env_0():
    envs = gym.make_vec(
        "RigidEnv/Reorient-v1",
        num_envs=3,
        vectorization_mode="vector_entry_point",
        render_mode="rgb_array",
    )
    envs.reset(seed=1)
    envs.step(envs.action_space.sample())
    frame = envs.render()
    envs.close()
    assert frame.shape == (H, W, 3) and frame.dtype == np.uint8


@pytest.mark.parametrize("bad", ["human", "rgb", "RGB_ARRAY"])
def test_vector_env_refuses_render_modes_it_does_not_have(bad):
    """Only ``metadata["render_modes"]`` (``rgb_array``), at construction, in one line."""
    with pytest.raises(ValueError, match="render_mode") as exc:
        gym.make_vec(
            "RigidEnv/Detumble-v0",
            num_envs=2,
            vectorization_mode="vector_entry_point",
            render_mode=bad,
        )
    assert "\n" not in str(exc.value) and "rgb_array" in str(exc.value)


@pytest.mark.filterwarnings("ignore:.*render_mode")  # gym.make warns before we refuse
@pytest.mark.parametrize("bad", ["rgb", "ansi"])
def test_single_env_refuses_render_modes_it_does_not_have(bad):
    with pytest.raises(ValueError, match="render_mode") as exc:
        gym.make("RigidEnv/Detumble-v0", render_mode=bad)
    assert "\n" not in str(exc.value)


def test_renderer_size_and_bad_arguments():
    task = DetumbleTask(2)
    renderer = TaskRenderer(task.view(), "rgb_array", fps=20, width=321, height=200)
    assert renderer.render(task.frame(1)).shape == (200, 321, 3)
    with pytest.raises(ValueError, match="mode"):
        TaskRenderer(task.view(), "ascii", fps=20)
    with pytest.raises(IndexError, match="out of range"):
        task.frame(2)


def test_each_task_declares_what_it_shows():
    """The renderer draws a view the task declares; it reads no task attributes."""
    views = {env_id: gym.make(env_id).unwrapped.task.view() for env_id in ENV_IDS}
    built_in = ("Detumble-v0", "SpinStabilize-v1", "Reorient-v1", "TumblingFall-v1")
    detumble, spin, reorient, fall = (views[f"RigidEnv/{e}"] for e in built_in)
    assert (detumble.title, detumble.target_spin, detumble.ground) == ("Detumble", None, False)
    assert spin.target_spin == 2.0 and spin.readouts == ("spin_axis_angle",)
    assert reorient.target_orientation and reorient.readouts == ("target_angle",)
    assert fall.ground and fall.gauge_top == 70.0  # the highest drop
    assert all(views[f"RigidEnv/{e}"].thruster_points.shape == (6, 3) for e in built_in)
    coils = views["RigidEnv/BdotDetumble-v2"]  # magnetorquers: at the centre, along their axes
    assert coils.title == "BdotDetumble" and not coils.thruster_points.any()
    assert np.array_equal(coils.thruster_directions, np.eye(3))


def test_render_imports_no_environment():
    """Arrows point one way: envs import render; render imports core and scene only."""
    tree = ast.parse(Path(rigid_env.render.__file__).read_text(encoding="utf-8"))
    imported = {
        node.module if isinstance(node, ast.ImportFrom) else alias.name
        for node in ast.walk(tree)
        if isinstance(node, ast.Import | ast.ImportFrom)
        for alias in node.names
    }
    ours = {m for m in imported if m and m.startswith("rigid_env")}
    core = {"rigid_env.core.actuator", "rigid_env.core.effects", "rigid_env.core.rotation"}
    assert ours <= {*core, "rigid_env.scene"}, ours
    assert not any(m and m.startswith("gymnasium") for m in imported)


def test_box_of_a_non_box_shape_has_its_moments():
    """A sphere of radius r (I = 2/5 m r^2) is drawn as the cube with the same moments, whose
    side a satisfies m a^2 / 6 = 2/5 m r^2: a = sqrt(12/5) r."""
    scene = {
        "dt": 0.05,
        "body": {"mass": 2.0, "shape": {"sphere": 0.1}},
        "actuators": {"point_forces": {"points": [[0.1, 0.0, 0.0]], "max_force": 0.1}},
    }
    task = DetumbleTask(1, scene=scene)
    np.testing.assert_allclose(body_box_size(task.scene), np.full(3, np.sqrt(12.0 / 5.0) * 0.1))
    # One point force: three components along x, y, z.
    points, dirs = actuator_layout(task.world.force_effects)
    np.testing.assert_allclose(points, np.tile([0.1, 0.0, 0.0], (3, 1)))
    np.testing.assert_allclose(dirs, np.eye(3))
    frame = TaskRenderer(task.view(), "rgb_array", fps=20).render(task.frame(0))
    assert frame.shape == (H, W, 3)


def test_body_without_shape_is_drawn_as_its_equivalent_box():
    """A body given by its mass and inertia alone is drawn as the solid box with that mass and
    those moments: the box's closed-form moments give the scene's back (to a few roundings)."""
    from rigid_env.core.inertia import box

    mass, inertia = 2.0, [0.02, 0.03, 0.04]
    scene = {
        "dt": 0.05,
        "body": {"mass": mass, "inertia": inertia},
        "actuators": {"point_forces": {"points": [[0.1, 0.0, 0.0]], "max_force": 0.1}},
    }
    task = DetumbleTask(1, scene=scene)
    size = body_box_size(task.scene)
    # a^2 = 6 (I_y + I_z - I_x) / m, a = sqrt(a^2), then I_x = m (b^2 + c^2) / 12: each squared
    # side carries <= 6 roundings (u = 2^-53 each) of the size of the moments' sum S, and a
    # moment adds two sides, so |error| <= 15 u S: relative 15 u S / I_min = 7.5e-15 here.
    rtol = 15 * 2.0**-53 * sum(inertia) / min(inertia)
    np.testing.assert_allclose(box(mass, size).principal_moments, inertia, rtol=rtol)
    frame = TaskRenderer(task.view(), "rgb_array", fps=20).render(task.frame(0))
    assert frame.shape == (H, W, 3) and len(np.unique(frame.reshape(-1, 3), axis=0)) > 100


def test_box_shape_keeps_its_size():
    task = DetumbleTask(1)
    np.testing.assert_allclose(body_box_size(task.scene), [0.4, 0.3, 0.2])


def test_record_video_writes_a_file(tmp_path):
    try:
        import moviepy  # noqa: F401
    except ImportError:
        pytest.skip("gymnasium's RecordVideo needs moviepy: pip install moviepy")
    folder = tmp_path / "videos"
    env = gym.wrappers.RecordVideo(
        gym.make("RigidEnv/Detumble-v0", render_mode="rgb_array"),
        video_folder=str(folder),
        episode_trigger=lambda episode: True,
        disable_logger=True,
    )
    env.reset(seed=0)
    for _ in range(25):
        env.step(env.action_space.sample())
    env.close()
    videos = list(folder.glob("*.mp4"))
    assert videos and videos[0].stat().st_size > 0


def test_human_mode_opens_and_closes():
    env = gym.make("RigidEnv/SpinStabilize-v0", render_mode="human")
    env.reset(seed=0)  # renders the first frame into the window
    renderer = env.unwrapped._renderer
    assert renderer is not None and renderer._window is not None
    assert env.step(env.action_space.sample()) is not None
    assert env.render() is None
    env.close()
    assert env.unwrapped._renderer is None
    assert renderer._window is None
    renderer.close()  # closing twice is harmless


def test_missing_pygame_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "pygame", None)  # `import pygame` now raises ImportError
    with pytest.raises(ImportError, match=r'pip install "rigid_env\[render\]"'):
        TaskRenderer(DetumbleTask(1).view(), "rgb_array", fps=20)
