"""Rendering of a task's body: ``rgb_array`` frames and a ``human`` pygame window.

A task declares what it shows once, as a :class:`TaskView` (the body's box, the thruster
layout, what its target is, which readouts to print), and hands over the numbers of each frame
as a :class:`Frame` (pose, spin, command, counters). :class:`TaskRenderer` draws a frame as seen
by a fixed perspective camera that follows the body's centre of mass (the camera never turns,
so the body's rotation is what moves on screen). This module reads core and scene objects
only; the environments import it, never the reverse.

* the body as a box with flat Lambert shading, faces sorted back to front (painter's
  algorithm). A ``box`` shape is drawn at its size; any other shape, and a body given by its
  mass and inertia alone (no ``shape``), as its *equivalent box*: the solid box with the same
  mass and principal moments, ``a^2 = 6 (I_y + I_z - I_x) / m`` (and cyclic; MuJoCo draws
  inertia boxes the same way);
* the world axes x, y, z (red, green, blue) from the centre of mass;
* each actuator component as a marker at its body point with a flame along ``-direction``
  whose length is proportional to its thrust as delivered (``Frame.command``: a lagged, pulsed
  or failed thruster's, a negative one firing the other way);
* the world angular velocity ``R w_body`` as a magenta arrow from the centre, its length
  proportional to ``|w|`` (capped at ``ARROW_MAX`` body radii); the part inside the body is
  drawn through it, dimmed;
* the task's guides, as its view declares them: a target orientation (Reorient) as a green
  outline of the box; a target spin about body +y (SpinStabilize) as a dashed cyan axis as long
  as the arrow at the target rate; under gravity (TumblingFall) the ground grid near touchdown
  and a height gauge;
* a text overlay: task, step, ``|w|``, fuel, success, and the view's readouts (height,
  orientation or spin-axis error).

Occlusion of the thin things (flames, arrow, axes, outlines) by the convex box is exact up to
their sampling: every piece is tested with a ray-box (slab) test from the camera in the body
frame; a piece with a hidden end is drawn before the box (which covers it), the rest after.

pygame is imported only when a renderer is made (``pip install "rigid_env[render]"``); in
``rgb_array`` mode ``SDL_VIDEODRIVER`` defaults to ``dummy``, so no display is needed.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.actuator import drawn
from rigid_env.core.effects import ForceEffect
from rigid_env.core.rotation import quat_to_matrix
from rigid_env.scene import Scene

FloatArray = NDArray[np.float64]
Color = tuple[int, int, int]

RENDER_MODES = ("rgb_array", "human")

# Camera: looks at the centre of mass from azimuth -55 deg, elevation 25 deg (world z up), from
# CAMERA_DISTANCE view radii away (a mild perspective); the centre of mass sits at VIEW_CENTER_Y
# of the frame height, below the text.
CAMERA_AZIMUTH = np.deg2rad(-55.0)
CAMERA_ELEVATION = np.deg2rad(25.0)
CAMERA_DISTANCE = 4.0
VIEW_CENTER_Y = 0.58
# Light direction in camera coordinates (right, up, towards the viewer): upper left, in front.
LIGHT_CAMERA = np.array([-0.45, 0.65, 0.62])
AMBIENT, DIFFUSE = 0.38, 0.62
# Lengths in body radii (half-diagonal of the box or the farthest actuator point): half the
# visible width (view radius); flame at |u| = 1 and its width at the nozzle; marker radius;
# arrow at the view's angular velocity scale (``TaskView.spin_scale``), longest arrow,
# head length and shaft width.
VIEW_MARGIN = 2.0
FLAME_LENGTH, FLAME_WIDTH = 0.7, 0.1
MARKER_RADIUS = 0.045
ARROW_AT_SCALE, ARROW_MAX, ARROW_HEAD, ARROW_WIDTH = 1.5, 1.9, 0.22, 0.035
# The ground grid appears below this height, in view radii [-].
GROUND_VISIBLE = 2.5
# Commands below this magnitude draw no flame [-].
FLAME_MIN_COMMAND = 1.0e-3
# Pieces per flame, per arrow shaft, per axis and per outline edge for the occlusion test.
FLAME_PIECES, ARROW_PIECES, AXIS_PIECES, EDGE_PIECES = 6, 12, 10, 4
# A point counts as hidden if the ray from the camera enters the box before this fraction of
# the way to it: points on a visible face (t = 1 exactly) stay visible despite rounding.
OCCLUSION_EPS = 1.0e-6

BACKGROUND_TOP: Color = (16, 20, 34)
BACKGROUND_BOTTOM: Color = (44, 50, 72)
# Box faces by body axis (+-x, +-y, +-z): one light steel, tinted so the axes can be told apart.
FACE_COLORS = np.array([[214, 184, 162], [172, 204, 180], [170, 186, 224]], dtype=np.float64)
EDGE_COLOR: Color = (24, 26, 34)
AXIS_COLORS: tuple[Color, Color, Color] = ((235, 80, 80), (90, 200, 100), (90, 140, 255))
ARROW_COLOR: Color = (240, 70, 230)
XRAY_GREY: Color = (120, 124, 140)
TARGET_COLOR: Color = (90, 235, 130)
SPIN_AXIS_COLOR: Color = (80, 220, 235)
GROUND_COLOR: Color = (70, 110, 80)
GAUGE_COLOR: Color = (255, 200, 80)
TEXT_COLOR: Color = (236, 238, 245)
DIM_TEXT: Color = (150, 156, 175)
SUCCESS_COLOR: Color = (110, 235, 130)
FLAME_NOZZLE: Color = (255, 245, 170)
FLAME_TIP: Color = (225, 55, 15)
THRUSTER_IDLE: Color = (70, 74, 88)
THRUSTER_RIM: Color = (230, 232, 240)
THRUSTER_FIRING: Color = (255, 170, 60)
# Masks of a 24-bit surface whose bytes are R, G, B (little-endian).
RGB_MASKS = (0x0000FF, 0x00FF00, 0xFF0000, 0)

# Box of half extents h: vertex k has signs from the bits of k; faces list vertex indices
# counter-clockwise seen from outside, one per body axis and sign.
_SIGNS = (
    np.array([[(k >> 0) & 1, (k >> 1) & 1, (k >> 2) & 1] for k in range(8)], dtype=np.float64) * 2.0
    - 1.0
)
_FACES = np.array(
    [
        [1, 3, 7, 5],
        [0, 4, 6, 2],  # +x, -x
        [2, 6, 7, 3],
        [0, 1, 5, 4],  # +y, -y
        [4, 5, 7, 6],
        [0, 2, 3, 1],
    ]
)  # +z, -z
_FACE_NORMALS = np.repeat(np.eye(3), 2, axis=0) * np.tile([1.0, -1.0], 3)[:, None]
_EDGES = np.array([[a, b] for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1])


def _import_pygame(mode: str) -> Any:
    if mode == "rgb_array":
        os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    try:
        import pygame
    except ImportError as exc:
        raise ImportError('render: pygame is missing; run pip install "rigid_env[render]"') from exc
    return pygame


READOUTS: dict[str, tuple[str, Color]] = {
    "target_angle": ("off target {:.1f} deg", TARGET_COLOR),
    "spin_axis_angle": ("spin axis off {:.1f} deg", SPIN_AXIS_COLOR),
    "sun_angle": ("panel off the Sun {:.1f} deg", TARGET_COLOR),
}
"""Readouts a view may ask for: the text (formatted with the frame's number) and its colour."""


@dataclass(frozen=True, eq=False)
class TaskView:
    """What a task shows, declared once by the task (see :meth:`for_scene`).

    Attributes:
        title: the task's name, drawn at the top left.
        box_size: (3,) full side lengths of the box drawn for the body, body x, y, z [m].
        thruster_points: (A, 3) body point of each action component [m].
        thruster_directions: (A, 3) unit force direction of each action component, body frame.
        spin_scale: angular speed drawn as an arrow of ``ARROW_AT_SCALE`` body radii [rad/s].
        target_orientation: draw :attr:`Frame.target` (a quaternion) as an outline of the box.
        target_spin: draw a dashed axis along body +y as long as the arrow at this rate
            [rad/s]; None for none.
        ground: draw the ground grid (z = 0) near touchdown, a height gauge and the height.
        gauge_top: height at the top of the gauge [m].
        readouts: text readouts after the success flag (and the height), keys of
            :data:`READOUTS`, one number each in :attr:`Frame.readouts`.
        fuel_unit: the unit of :attr:`Frame.fuel` (a coil's dipole-time: ``A m^2 s``).
        actuation: the legend's name of what the actuators' arrows show.
    """

    title: str
    box_size: FloatArray
    thruster_points: FloatArray
    thruster_directions: FloatArray
    spin_scale: float = 1.0
    target_orientation: bool = False
    target_spin: float | None = None
    ground: bool = False
    gauge_top: float = 1.0
    readouts: tuple[str, ...] = ()
    fuel_unit: str = "N s"
    actuation: str = "thrust"

    def __post_init__(self) -> None:
        unknown = [r for r in self.readouts if r not in READOUTS]
        if unknown:
            raise ValueError(f"readouts: unknown {unknown}; known: {', '.join(READOUTS)}")

    @classmethod
    def for_scene(
        cls, title: str, scene: Scene, effects: Sequence[ForceEffect], **task: Any
    ) -> TaskView:
        """The view of a body built from ``scene`` with the actuators among ``effects``: its
        box, its thrusters, and (under gravity) the ground and a gauge up to the initial
        height (at least 1 m); ``task`` sets the other attributes."""
        points, directions = actuator_layout(effects)
        ground = scene.effects_spec.gravity is not None
        top = max(float(scene.initial.position[2]), 1.0)
        return cls(
            title,
            body_box_size(scene),
            points,
            directions,
            **{"ground": ground, "gauge_top": top, **task},
        )


@dataclass(frozen=True, eq=False)
class Frame:
    """The numbers of one frame, from the task.

    Attributes:
        q: (4,) orientation, body -> world (w, x, y, z).
        w_body: (3,) angular velocity, body frame [rad/s].
        height: centre-of-mass height, world z [m] (drawn when the view has a ground).
        command: (A,) each component's thrust in the step, in units of its max force, in
            [-1, 1]: the command as the hardware delivered it (lagged, pulsed, failed).
        step: steps into the episode.
        angular_speed: ``|w|`` [rad/s] (finite even for a diverged body).
        fuel: impulse spent so far [N s].
        success: whether the task counts as solved now.
        target: (4,) target orientation (when the view draws one), else None.
        readouts: one number per :attr:`TaskView.readouts`.
    """

    q: FloatArray
    w_body: FloatArray
    height: float
    command: FloatArray
    step: int
    angular_speed: float
    fuel: float
    success: bool
    target: FloatArray | None = None
    readouts: tuple[float, ...] = ()


def body_box_size(scene: Scene) -> FloatArray:
    """(3,) full side lengths [m] of the box drawn for a scene's body, body x, y, z.

    The scene's ``box`` if it is one; otherwise (another shape, or none: a body given by its
    mass and inertia) the solid box with the scene's mass and principal moments:
    ``I_x = m (b^2 + c^2) / 12`` and cyclic give ``a^2 = 6 (I_y + I_z - I_x) / m``. A flat
    side (a plate on the triangle equality) is kept at a tenth of the longest.
    """
    shape = scene.body.shape
    if shape is not None and shape.box is not None:
        return np.asarray(shape.box, dtype=np.float64)
    moments = np.asarray(scene.inertia, dtype=np.float64)
    assert scene.body.mass is not None  # filled in when the scene is loaded
    sq = 6.0 * (moments.sum() - 2.0 * moments) / scene.body.mass
    size = np.sqrt(np.maximum(sq, 0.0))
    return np.maximum(size, 0.1 * size.max())


def actuator_layout(effects: Sequence[ForceEffect]) -> tuple[FloatArray, FloatArray]:
    """Body point (A, 3) [m] and unit direction (A, 3) of each action component.

    Read from the actuators among ``effects`` (body frame), in action order, each as its
    declaration draws it (:func:`rigid_env.core.actuator.drawn`): a ``point_forces`` point
    gives three components, along its three force directions; a magnetorquer sits at the centre
    of mass along its coil's axis (its arrow: the dipole).
    """
    return drawn(effects)


def _mix(a: Any, b: Any, s: float) -> Color:
    """Colour ``(1 - s) a + s b`` as integers."""
    c = (1.0 - s) * np.asarray(a, dtype=np.float64) + s * np.asarray(b, dtype=np.float64)
    return (int(c[0]), int(c[1]), int(c[2]))


# A piece of a thin polyline ready to draw: colour, end points a, b [px], and the quad of a
# wide piece (None for a hairline, drawn anti-aliased).
Piece = tuple[Color, list[float], list[float], list[list[float]] | None]


class _Polylines:
    """Thin things sampled in the body frame, split by the box into pieces behind and in front.

    A piece with a hidden end goes behind the box (which then covers it), unless its polyline
    is ``xray``: then it is drawn on top, dimmed and thinner (the arrow inside the body).
    All samples of a frame are projected and tested in one call.
    """

    def __init__(self) -> None:
        self.samples: list[FloatArray] = []
        self.widths: list[FloatArray] = []
        self.colors: list[Color] = []  # one per sample: of the piece that starts there
        self.starts: list[NDArray[np.bool_]] = []  # whether a piece starts at the sample
        self.xray: list[NDArray[np.bool_]] = []

    def add(
        self,
        samples_body: FloatArray,
        colors: list[Color],
        widths: float | FloatArray,
        *,
        dashed: bool = False,
        xray: bool = False,
    ) -> None:
        """Queue L polylines of M samples each, (L, M, 3) or (M, 3) body frame [m], with
        L (M - 1) piece colours and the width [px] at each sample, (M,) or scalar (a hairline
        at <= 1 px)."""
        lines = samples_body.reshape(-1, *samples_body.shape[-2:])
        n_lines, m = lines.shape[:2]
        self.samples.append(lines.reshape(-1, 3))
        self.widths.append(
            np.broadcast_to(np.asarray(widths, dtype=np.float64), (n_lines, m)).ravel()
        )
        per_line = len(colors) // n_lines
        for j in range(n_lines):
            self.colors.extend(colors[j * per_line : (j + 1) * per_line])
            self.colors.append((0, 0, 0))  # no piece starts at a line's last sample
        starts = np.ones(m, dtype=bool)
        starts[-1] = False
        if dashed:
            starts[1::2] = False
        self.starts.append(np.tile(starts, n_lines))
        self.xray.append(np.full(n_lines * m, xray))

    def split(
        self, r: TaskRenderer, rot: FloatArray, cam_body: FloatArray
    ) -> tuple[list[Piece], list[Piece]]:
        """Project and test every sample at once; sort the pieces into (behind, front)."""
        if not self.samples:
            return [], []
        samples = np.concatenate(self.samples)
        screen, _ = r._project(samples @ rot.T)
        hidden = r._hidden(samples, cam_body)
        k = np.flatnonzero(np.concatenate(self.starts))
        widths = np.concatenate(self.widths)
        xray = np.concatenate(self.xray)[k]
        cover = hidden[k] | hidden[k + 1]
        dim = cover & xray
        wa = np.where(dim, np.maximum(1.0, 0.6 * widths[k]), widths[k])
        wb = np.where(dim, np.maximum(1.0, 0.6 * widths[k + 1]), widths[k + 1])
        a, b = screen[k], screen[k + 1]
        seg = b - a
        length = np.hypot(seg[:, 0], seg[:, 1])
        perp = np.stack([-seg[:, 1], seg[:, 0]], axis=1) / np.maximum(length, 1.0e-9)[:, None]
        na, nb = perp * (0.5 * wa)[:, None], perp * (0.5 * wb)[:, None]
        quads = np.stack([a + na, b + nb, b - nb, a - na], axis=1).tolist()
        thin = (np.maximum(wa, wb) <= 1.0) | (length < 0.5)
        a_l, b_l = a.tolist(), b.tolist()
        behind: list[Piece] = []
        front: list[Piece] = []
        for j, kk in enumerate(k.tolist()):
            color = _mix(self.colors[kk], XRAY_GREY, 0.55) if dim[j] else self.colors[kk]
            piece = (color, a_l[j], b_l[j], None if thin[j] else quads[j])
            (behind if cover[j] and not xray[j] else front).append(piece)
        return behind, front


class TaskRenderer:
    """Draws a task's frames as RGB arrays or into a pygame window.

    Args:
        view: what the task shows (fixed for the renderer's life).
        mode: ``"rgb_array"`` (``render`` returns (H, W, 3) uint8) or ``"human"`` (a window,
            refreshed at most ``fps`` times a second; ``render`` returns None).
        fps: frames per second of the window [1/s].
        width, height: frame size [px].

    Raises:
        ImportError: pygame is missing (the message says how to install it).
        ValueError: unknown mode or a size below 64 px.
    """

    def __init__(
        self, view: TaskView, mode: str, fps: int, width: int = 480, height: int = 480
    ) -> None:
        if mode not in RENDER_MODES:
            raise ValueError(f"mode: must be one of {RENDER_MODES}, got {mode!r}")
        if int(width) < 64 or int(height) < 64:
            raise ValueError(f"width, height: must be >= 64 px, got {width} x {height}")
        self.pg = _import_pygame(mode)
        pg = self.pg
        self.view = view
        self.mode = mode
        self.fps = int(fps)
        self.width, self.height = int(width), int(height)
        self._window: Any = None
        self._clock: Any = None
        self._surface = pg.Surface((self.width, self.height))
        # A frame leaves through a 24-bit copy whose bytes are R, G, B: one contiguous copy.
        # (Only blitted into: pygame 2.6's anti-aliased lines on 24-bit surfaces can crash.)
        self._rgb = pg.Surface((self.width, self.height), 0, 24, RGB_MASKS)
        self._rgb.set_at((0, 0), (1, 2, 3))
        self._rgb_bytes = self._rgb.get_buffer().raw[:3] == b"\x01\x02\x03"
        pg.font.init()
        self.ui = min(self.width, self.height) / 480.0  # text and marker scale
        self._font = pg.font.Font(None, max(10, round(21 * self.ui)))
        self._font_title = pg.font.Font(None, max(12, round(27 * self.ui)))
        self._font_small = pg.font.Font(None, max(9, round(18 * self.ui)))
        self._geometry()
        self._background = self._make_background()

    # ---- static geometry -------------------------------------------------------------------
    def _geometry(self) -> None:
        view = self.view
        self.half = 0.5 * np.asarray(view.box_size, dtype=np.float64)
        self.vertices_body = _SIGNS * self.half
        self.thruster_points = np.asarray(view.thruster_points, dtype=np.float64)
        self.thruster_dirs = np.asarray(view.thruster_directions, dtype=np.float64)
        reach = [np.linalg.norm(self.half)]
        if len(self.thruster_points):
            reach.append(np.linalg.norm(self.thruster_points, axis=1).max())
        self.body_radius = float(max(reach))
        self.view_radius = VIEW_MARGIN * self.body_radius
        self.distance = CAMERA_DISTANCE * self.view_radius
        # Camera frame: d from the target to the camera; right, up, forward (into the scene).
        ce, se = np.cos(CAMERA_ELEVATION), np.sin(CAMERA_ELEVATION)
        d = np.array([ce * np.cos(CAMERA_AZIMUTH), ce * np.sin(CAMERA_AZIMUTH), se])
        forward = -d
        right = np.cross(forward, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        self.cam_offset = self.distance * d  # camera position relative to the centre of mass
        self.cam_basis = np.stack([right, up, forward])  # rows: world -> camera coordinates
        light = LIGHT_CAMERA / np.linalg.norm(LIGHT_CAMERA)
        self.light_world = light[0] * right + light[1] * up - light[2] * forward
        self.focal = 0.5 * min(self.width, self.height) * self.distance / self.view_radius
        self.px_per_m = self.focal / self.distance  # at the centre of mass
        self.center = np.array([0.5 * self.width, VIEW_CENTER_Y * self.height])
        self.arrow_per_speed = ARROW_AT_SCALE * self.body_radius / float(view.spin_scale or 1.0)
        self.axis_length = 0.75 * self.view_radius
        t = np.linspace(0.0, 1.0, AXIS_PIECES + 1)[:, None] * self.axis_length
        self.axes_world = t[None, :, :] * np.eye(3)[:, None, :]  # (3 axes, samples, xyz) [m]
        self.axes_colors = [c for c in AXIS_COLORS for _ in range(AXIS_PIECES)]
        self.flame_t = np.linspace(0.0, 1.0, FLAME_PIECES + 1)
        mid = 0.5 * (self.flame_t[:-1] + self.flame_t[1:])
        self.flame_colors = [_mix(FLAME_NOZZLE, FLAME_TIP, s) for s in mid]
        self.ground = view.ground
        self.gauge_top = float(view.gauge_top)
        ui = self.ui
        self.gauge_x = self.width - round(24 * ui)
        self.gauge_span = (round(0.24 * self.height), round(0.86 * self.height))
        self.text_origin = (round(10 * ui), round(8 * ui))

    def _make_background(self) -> Any:
        """Gradient, axis labels, legend, title and gauge frame: everything that never moves."""
        pg, ui = self.pg, self.ui
        t = np.linspace(0.0, 1.0, self.height)[None, :, None]
        col = (1.0 - t) * np.array(BACKGROUND_TOP) + t * np.array(BACKGROUND_BOTTOM)
        img = np.broadcast_to(col, (self.width, self.height, 3)).astype(np.uint8)
        bg = pg.Surface((self.width, self.height), 0, self._surface)
        bg.blit(pg.surfarray.make_surface(np.ascontiguousarray(img)), (0, 0))
        # The camera never turns, so the world axes' tips stay where they are on screen.
        tips, _ = self._project(np.eye(3) * self.axis_length * 1.08)
        for k, name in enumerate("xyz"):
            label = self._font_small.render(name, True, AXIS_COLORS[k])
            w, h = label.get_size()
            bg.blit(label, (tips[k, 0] - w / 2, tips[k, 1] - h / 2))
        legend: list[tuple[str, Color]] = [
            ("angular velocity (world)", ARROW_COLOR),
            (
                f"{self.view.actuation} (length ~ |{self.view.actuation}|)",
                _mix(FLAME_NOZZLE, FLAME_TIP, 0.5),
            ),
        ]
        if self.view.target_orientation:
            legend.append(("target orientation", TARGET_COLOR))
        if self.view.target_spin is not None:
            legend.append(("target spin (body +y)", SPIN_AXIS_COLOR))
        x0 = self.text_origin[0]
        y = self.height - round(8 * ui)
        swatch = round(16 * ui)
        for text, color in reversed(legend):
            label = self._font_small.render(text, True, DIM_TEXT)
            y -= label.get_height() + round(2 * ui)
            mid = y + label.get_height() // 2
            pg.draw.line(bg, color, (x0, mid), (x0 + swatch, mid), max(2, round(3 * ui)))
            bg.blit(label, (x0 + swatch + round(6 * ui), y))
        title = self._font_title.render(self.view.title, True, TEXT_COLOR)
        bg.blit(title, self.text_origin)
        self._title_size = title.get_size()
        if self.ground:
            x, (top, bottom) = self.gauge_x, self.gauge_span
            pg.draw.line(bg, DIM_TEXT, (x, top), (x, bottom), 2)
            for frac in np.linspace(0.0, 1.0, 5):
                yy = round(bottom - frac * (bottom - top))
                pg.draw.line(bg, DIM_TEXT, (x - 5, yy), (x + 5, yy), 1)
            for text, yy in ((f"{self.gauge_top:.0f} m", top - 4), ("0 m", bottom + 4)):
                label = self._font_small.render(text, True, DIM_TEXT)
                ytop = yy - label.get_height() if yy < bottom else yy
                bg.blit(
                    label, (min(x - label.get_width() // 2, self.width - label.get_width()), ytop)
                )
        return bg

    # ---- projection and occlusion ----------------------------------------------------------
    def _project(self, p_rel: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Screen points (M, 2) [px] and depths (M,) [m] of world points relative to the CoM."""
        cam = (p_rel - self.cam_offset) @ self.cam_basis.T
        depth = np.maximum(cam[:, 2], 1.0e-6 * self.distance)
        xy = cam[:, :2] * (self.focal / depth)[:, None]
        return np.stack([self.center[0] + xy[:, 0], self.center[1] - xy[:, 1]], axis=1), depth

    def _hidden(self, p_body: FloatArray, cam_body: FloatArray) -> NDArray[np.bool_]:
        """(M,) whether the box hides body points (M, 3) from the camera (body frame).

        Slab test on the segment ``c + t (p - c)``, ``t`` in [0, 1]: hidden when it enters the
        box (``t_in <= t_out``) before reaching the point and leaves it after the camera.
        A direction along a slab gives +-inf there (never entering, or always inside); fmin and
        fmax skip the NaN of a camera exactly on a slab plane.
        """
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / (p_body - cam_body)
            t1 = (-self.half - cam_body) * inv
            t2 = (self.half - cam_body) * inv
        t_in = np.fmax.reduce(np.fmin(t1, t2), axis=1)
        t_out = np.fmin.reduce(np.fmax(t1, t2), axis=1)
        return (t_in <= t_out) & (t_in < 1.0 - OCCLUSION_EPS) & (t_out > 0.0)

    # ---- drawing ---------------------------------------------------------------------------
    def render(self, frame: Frame) -> NDArray[np.uint8] | None:
        """Draw ``frame``.

        Returns:
            (H, W, 3) uint8 RGB frame in ``"rgb_array"`` mode; None in ``"human"`` mode.
        """
        self._draw(frame)
        if self.mode == "human":
            self._show()
            return None
        if not self._rgb_bytes:  # a platform that lays the surface out otherwise
            buf = self.pg.image.tobytes(self._surface, "RGB")
            return np.frombuffer(buf, dtype=np.uint8).reshape(self.height, self.width, 3).copy()
        self._rgb.blit(self._surface, (0, 0))
        rows = np.frombuffer(self._rgb.get_buffer().raw, dtype=np.uint8)
        rows = rows.reshape(self.height, -1)
        return np.array(rows[:, : 3 * self.width]).reshape(self.height, self.width, 3)

    def _draw(self, frame: Frame) -> None:
        view = self.view
        rot = quat_to_matrix(np.asarray(frame.q, dtype=np.float64))
        cam_body = rot.T @ self.cam_offset  # camera position in the body frame
        self._surface.blit(self._background, (0, 0))
        if self.ground:
            self._draw_ground(float(frame.height))

        lines = _Polylines()
        self._add_axes(rot, lines)
        if view.target_orientation and frame.target is not None:
            self._add_target(rot, np.asarray(frame.target, dtype=np.float64), lines)
        if view.target_spin is not None:
            n = ARROW_PIECES
            length = self.arrow_per_speed * float(view.target_spin)
            samples = np.linspace(0.0, 1.0, n + 1)[:, None] * np.array([0.0, length, 0.0])
            lines.add(samples, [SPIN_AXIS_COLOR] * n, 2.0, dashed=True, xray=True)
        commands = self._add_flames(np.asarray(frame.command, dtype=np.float64), lines)
        arrow = self._add_arrow(np.asarray(frame.w_body, dtype=np.float64), lines)
        behind, front = lines.split(self, rot, cam_body)

        self._draw_pieces(behind)
        self._draw_box(rot)
        self._draw_markers(rot, cam_body, commands)
        self._draw_pieces(front)
        if arrow is not None:
            self._draw_arrow_head(*arrow, rot=rot, cam_body=cam_body)
        self._draw_text(frame)
        if self.ground:
            self._draw_gauge(float(frame.height))

    def _draw_pieces(self, pieces: list[Piece]) -> None:
        pg, surf = self.pg, self._surface
        for color, a, b, quad in pieces:
            if quad is None:
                pg.draw.aaline(surf, color, a, b)
            else:
                pg.draw.polygon(surf, color, quad)

    def _draw_box(self, rot: FloatArray) -> None:
        """Front faces back to front (painter's algorithm), flat Lambert shading."""
        pg, surf = self.pg, self._surface
        verts_rel = self.vertices_body @ rot.T
        screen, depth = self._project(verts_rel)
        normals = _FACE_NORMALS @ rot.T
        centres = verts_rel[_FACES].mean(axis=1)
        facing = np.einsum("ij,ij->i", normals, self.cam_offset - centres) > 0.0
        shade = AMBIENT + DIFFUSE * np.clip(normals @ self.light_world, 0.0, None)
        colors = np.clip(FACE_COLORS[np.arange(6) // 2] * shade[:, None], 0, 255).astype(int)
        order = np.argsort(-depth[_FACES].mean(axis=1), kind="stable")  # far to near
        polys = screen[_FACES].tolist()
        for f in order:
            if facing[f]:  # a back face of a convex box is covered by the front ones
                pg.draw.polygon(surf, tuple(colors[f]), polys[f])
                pg.draw.aalines(surf, EDGE_COLOR, True, polys[f])

    def _add_axes(self, rot: FloatArray, lines: _Polylines) -> None:
        # World samples t e_k in the body frame: R^T (t e_k), as rows (t e_k)^T R.
        lines.add(self.axes_world @ rot, self.axes_colors, 1.0)

    def _add_target(self, rot: FloatArray, q_target: FloatArray, lines: _Polylines) -> None:
        # Target box written in the current body frame, R^T R_t v; 4 % larger so that it stays
        # visible as an outline once the body is aligned with it.
        rel = rot.T @ quat_to_matrix(q_target)
        verts = (self.vertices_body * 1.04) @ rel.T
        t = np.linspace(0.0, 1.0, EDGE_PIECES + 1)[None, :, None]
        a, b = verts[_EDGES[:, 0]][:, None, :], verts[_EDGES[:, 1]][:, None, :]
        lines.add(a + t * (b - a), [TARGET_COLOR] * (EDGE_PIECES * len(_EDGES)), 1.0)

    def _add_flames(self, action: FloatArray, lines: _Polylines) -> list[float]:
        """Queue the flames; returns each thruster's command in [-1, 1] (for the markers)."""
        commands = [float(u) for u in np.clip(np.nan_to_num(action), -1.0, 1.0)]
        t, colors = self.flame_t, self.flame_colors
        for p, d, u in zip(self.thruster_points, self.thruster_dirs, commands, strict=True):
            if abs(u) < FLAME_MIN_COMMAND:
                continue
            # The thrust u d pushes the body; the exhaust leaves along -u d.
            length = FLAME_LENGTH * self.body_radius * abs(u)
            samples = p - np.sign(u) * t[:, None] * (length * d)
            width = FLAME_WIDTH * self.body_radius * self.px_per_m * (0.6 + 0.4 * abs(u))
            lines.add(samples, colors, np.maximum(1.5, width * (1.0 - 0.85 * t)))
        return commands

    def _draw_markers(self, rot: FloatArray, cam_body: FloatArray, commands: list[float]) -> None:
        if not len(self.thruster_points):
            return
        pg, surf = self.pg, self._surface
        # Test a point just off the surface so that a nozzle on a visible face is visible.
        hidden = self._hidden(self.thruster_points * (1.0 + 1.0e-3), cam_body)
        screen, _ = self._project(self.thruster_points @ rot.T)
        radius = max(3.0, MARKER_RADIUS * self.body_radius * self.px_per_m)
        for k in np.flatnonzero(~hidden):
            u = abs(commands[k])
            fill = _mix(THRUSTER_IDLE, THRUSTER_FIRING, u)
            pg.draw.circle(surf, fill, screen[k], radius)
            pg.draw.circle(surf, THRUSTER_RIM, screen[k], radius, width=max(1, round(self.ui)))

    def _add_arrow(self, w_body: FloatArray, lines: _Polylines) -> Any:
        """Queue the shaft of the angular-velocity arrow; returns its head (base, tip), body
        frame, or None at rest."""
        with np.errstate(over="ignore", invalid="ignore"):
            speed = float(np.sqrt(np.sum(w_body * w_body)))
        if not np.isfinite(speed) or speed < 1.0e-9:
            return None
        length = min(self.arrow_per_speed * speed, ARROW_MAX * self.body_radius)
        # R w has body coordinates w: the arrow's samples along w / |w| are body-frame points.
        axis = w_body / speed
        head = min(ARROW_HEAD * self.body_radius, 0.5 * length)
        samples = np.linspace(0.0, length - head, ARROW_PIECES + 1)[:, None] * axis
        width = max(2.0, ARROW_WIDTH * self.body_radius * self.px_per_m)
        lines.add(samples, [ARROW_COLOR] * ARROW_PIECES, width, xray=True)
        return axis * (length - head), axis * length

    def _draw_arrow_head(
        self, base: FloatArray, tip: FloatArray, *, rot: FloatArray, cam_body: FloatArray
    ) -> None:
        """Screen-space triangle; dimmed like the shaft when the box hides it."""
        ends = np.stack([base, tip])
        color = ARROW_COLOR
        if self._hidden(ends, cam_body).any():
            color = _mix(ARROW_COLOR, XRAY_GREY, 0.55)
        (b, t), _ = self._project(ends @ rot.T)
        seg = t - b
        length = float(np.hypot(seg[0], seg[1]))
        half_width = ARROW_HEAD * 0.5 * self.body_radius * self.px_per_m
        if length < 0.25 * half_width:  # seen along the axis: a dot
            self.pg.draw.circle(self._surface, color, t.tolist(), half_width)
            return
        n = np.array([-seg[1], seg[0]]) / length * half_width
        self.pg.draw.polygon(self._surface, color, [t.tolist(), (b + n).tolist(), (b - n).tolist()])

    def _draw_ground(self, height: float) -> None:
        """Grid on z = 0 under the body, once the ground is within reach of the view."""
        if not np.isfinite(height) or height > GROUND_VISIBLE * self.view_radius:
            return
        span = 2.0 * self.view_radius
        ticks = np.linspace(-span, span, 9)
        n = len(ticks)
        ends = np.zeros((2, 2, n, 3))  # (direction, end, line, xyz)
        ends[0, :, :, 0] = np.array([-span, span])[:, None]
        ends[0, :, :, 1] = ticks
        ends[1, :, :, 1] = np.array([-span, span])[:, None]
        ends[1, :, :, 0] = ticks
        ends[..., 2] = -height
        screen, depth = self._project(ends.reshape(-1, 3))
        if depth.min() <= 0.05 * self.distance:  # too close to the camera plane to draw
            return
        screen = screen.reshape(2, 2, n, 2).tolist()
        for k in range(2):
            for j in range(n):
                self.pg.draw.aaline(self._surface, GROUND_COLOR, screen[k][0][j], screen[k][1][j])

    def _draw_gauge(self, height: float) -> None:
        frac = float(np.clip(height / self.gauge_top, 0.0, 1.0)) if np.isfinite(height) else 0.0
        top, bottom = self.gauge_span
        x, y, s = self.gauge_x, bottom - frac * (bottom - top), 6.0 * self.ui
        self.pg.draw.polygon(
            self._surface, GAUGE_COLOR, [(x - 3, y), (x - 3 - 2 * s, y - s), (x - 3 - 2 * s, y + s)]
        )

    def _draw_text(self, frame: Frame) -> None:
        surf, ui = self._surface, self.ui
        speed = float(frame.angular_speed)
        success = bool(frame.success)
        x0, y0 = self.text_origin
        tw, th = self._title_size
        step = self._font.render(f"step {int(frame.step)}", True, DIM_TEXT)
        surf.blit(step, (x0 + tw + round(12 * ui), y0 + th - step.get_height() - round(2 * ui)))
        rows: list[list[tuple[str, Color]]] = [
            [
                (f"|w| {speed:.3f} rad/s", TEXT_COLOR),
                (f"fuel {float(frame.fuel):.3f} {self.view.fuel_unit}", TEXT_COLOR),
            ],
            [
                (
                    "success" if success else "not (yet) successful",
                    SUCCESS_COLOR if success else DIM_TEXT,
                )
            ],
        ]
        if self.ground:
            rows[1].append((f"height {float(frame.height):.1f} m", GAUGE_COLOR))
        for name, value in zip(self.view.readouts, frame.readouts, strict=True):
            text, color = READOUTS[name]
            rows[1].append((text.format(float(value)), color))
        y = y0 + th + round(2 * ui)
        for parts in rows:
            x, row_height = x0, 0
            for text, color in parts:
                img = self._font.render(text, True, color)
                surf.blit(img, (x, y))
                x += img.get_width() + round(16 * ui)
                row_height = max(row_height, img.get_height())
            y += row_height + round(3 * ui)

    # ---- window ----------------------------------------------------------------------------
    def _show(self) -> None:
        pg = self.pg
        if self._window is None:
            pg.display.init()
            pg.display.set_caption(f"rigid_env: {self.view.title}")
            self._window = pg.display.set_mode((self.width, self.height))
            self._clock = pg.time.Clock()
        pg.event.pump()
        self._window.blit(self._surface, (0, 0))
        pg.display.flip()
        self._clock.tick(self.fps)

    def close(self) -> None:
        """Close the window (human mode); safe to call more than once."""
        if self._window is not None:
            self.pg.display.quit()
            self._window = None
            self._clock = None
