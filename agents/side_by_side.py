"""Two policies on the same seed, rendered side by side into one small GIF.

Each policy runs one episode of a single env (``render_mode="rgb_array"``, the task's own
renderer), frames are taken every ``stride`` steps and downscaled to ``PANEL`` px, the two
panels are laid side by side under a header line (task, seed, playback speed) and above a
caption per panel (policy, final ``|w|``, success), and the frames go to a GIF through imageio.
The shorter episode holds its last frame until the longer one ends.

Two passes per policy: the first, without rendering, gives the episode's length and its outcome;
the second renders only the frames kept. Both replay the same seed, so they are the same episode
(the environments are deterministic for a given seed, bit for bit).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from .evaluate import Policy

Frame = NDArray[np.uint8]

#: Side of one panel [px] (the env renders 480 x 480; downscaled to keep the GIF small).
PANEL = 256
#: Most frames per animation [-]: a longer episode is subsampled (every ``stride``-th step).
MAX_FRAMES = 50
#: A frame lasts ``stride * dt`` (real time) up to this [ms]; beyond it playback runs faster.
MAX_FRAME_MS = 100
#: The last frame stays up this long [ms] before the GIF loops.
HOLD_MS = 1500
#: Colours of the one palette all frames share [-].
PALETTE_COLORS = 128
HEADER_PX, CAPTION_PX = 24, 40
BACKGROUND = (16, 20, 34)
TEXT = (236, 238, 245)
DIM = (150, 156, 175)
GOOD = (110, 235, 130)
BAD = (240, 120, 110)


@dataclass(frozen=True)
class Outcome:
    """How a rendered episode ended (from the env's last ``info``)."""

    steps: int
    success: bool
    final_angular_speed: float  # [rad/s]
    fuel: float  # [N s]
    time_to_success: float | None  # first step with success [s]; None if never


def play(
    env: gym.Env[Any, Any], policy: Policy, seed: int, render_every: int | None = None
) -> tuple[Outcome, list[Frame]]:
    """One episode from ``env.reset(seed=seed)``; frames at steps 0, k, 2k, ... and the last.

    Args:
        env: a single env, made with ``render_mode="rgb_array"`` if frames are wanted.
        policy: maps a batch of observations (1, obs_dim) to actions (1, A).
        seed: the reset seed.
        render_every: keep a frame every this many steps; None renders nothing.
    """
    obs, info = env.reset(seed=seed)
    dt = float(env.unwrapped.task.dt)
    frames = [env.render()] if render_every else []
    steps, first_success, done = 0, None, False
    while not done:
        obs, _, terminated, truncated, info = env.step(policy(obs[None])[0])
        steps += 1
        done = terminated or truncated
        if info["success"] and first_success is None:
            first_success = steps * dt
        if render_every and (steps % render_every == 0 or done):
            frames.append(env.render())
    outcome = Outcome(
        steps,
        bool(info["success"]),
        float(info["angular_speed"]),
        float(info["fuel"]),
        first_success,
    )
    return outcome, frames


def _font(size: int) -> Any:
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1: one small bitmap font
        return ImageFont.load_default()


def caption(label: str, outcome: Outcome) -> tuple[str, str, bool]:
    """(first line, second line, success) under a panel."""
    result = (
        f"success at {outcome.time_to_success:.2f} s"
        if outcome.success and outcome.time_to_success is not None
        else ("success" if outcome.success else "not successful")
    )
    return label, f"final |w| {outcome.final_angular_speed:.3f} rad/s, {result}", outcome.success


def compose(
    header: str,
    panels: list[tuple[list[Frame], tuple[str, str, bool]]],
) -> list[Frame]:
    """Frames of the panels side by side, each ``PANEL`` px square, under ``header``.

    Args:
        header: one line across the top.
        panels: per panel, its frames (any square size) and its caption lines.
    """
    from PIL import Image, ImageDraw

    n = max(len(frames) for frames, _ in panels)
    width, height = PANEL * len(panels), HEADER_PX + PANEL + CAPTION_PX
    big, small = _font(15), _font(13)
    base = Image.new("RGB", (width, height), BACKGROUND)
    draw = ImageDraw.Draw(base)
    draw.text((width // 2, HEADER_PX // 2), header, fill=TEXT, font=big, anchor="mm")
    for j, (_, (line1, line2, ok)) in enumerate(panels):
        x = j * PANEL + 8
        y = HEADER_PX + PANEL + 3
        draw.text((x, y), line1, fill=GOOD if ok else BAD, font=big)
        draw.text((x, y + 19), line2, fill=DIM, font=small)
    out = []
    for k in range(n):
        image = base.copy()
        for j, (frames, _) in enumerate(panels):
            frame = Image.fromarray(frames[min(k, len(frames) - 1)])
            image.paste(frame.resize((PANEL, PANEL), Image.LANCZOS), (j * PANEL, HEADER_PX))
        out.append(np.asarray(image))
    return out


def shared_palette(images: list[Frame], colors: int = PALETTE_COLORS) -> list[Frame]:
    """The frames mapped to one palette of ``colors`` colours, without dithering.

    GIF stores each frame with at most 256 colours; quantised one by one, the background
    gradient maps differently in every frame and every pixel changes. With one palette a pixel
    that does not move keeps its colour, and the GIF writer stores only the changed region.
    """
    from PIL import Image

    sample = images[:: max(1, len(images) // 8)]
    palette = Image.fromarray(np.concatenate(sample, axis=0)).quantize(
        colors, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE
    )
    return [
        np.asarray(
            Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE).convert("RGB")
        )
        for f in images
    ]


def record_side_by_side(
    env_id: str,
    policies: list[tuple[str, Policy]],
    seed: int,
    path: Path,
    env_kwargs: dict[str, Any] | None = None,
) -> dict[str, Outcome]:
    """Render every policy's episode from ``seed`` and write them side by side to ``path`` (.gif).

    Returns:
        The outcome of each policy's episode, by label.
    """
    import imageio.v3 as iio

    envs = [gym.make(env_id, render_mode="rgb_array", **(env_kwargs or {})) for _ in policies]
    dt = float(envs[0].unwrapped.task.dt)
    first = [play(env, policy, seed)[0] for env, (_, policy) in zip(envs, policies, strict=True)]
    longest = max(o.steps for o in first)
    stride = max(1, math.ceil(longest / MAX_FRAMES))
    frame_ms = min(MAX_FRAME_MS, stride * dt * 1000.0)
    speed = stride * dt * 1000.0 / frame_ms
    panels, outcomes = [], {}
    for env, (label, policy) in zip(envs, policies, strict=True):
        outcome, frames = play(env, policy, seed, render_every=stride)
        env.close()
        outcomes[label] = outcome
        panels.append((frames, caption(label, outcome)))
    task = env_id.removeprefix("RigidEnv/").removesuffix("-v0")
    pace = "real time" if abs(speed - 1.0) < 1e-9 else f"{speed:.1f}x real time"
    images = shared_palette(compose(f"{task}   seed {seed}   {pace}", panels))
    durations = [round(frame_ms)] * len(images)
    durations[-1] = HOLD_MS
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp.gif")
    try:
        iio.imwrite(tmp, np.stack(images), extension=".gif", duration=durations, loop=0)
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)
    return outcomes
