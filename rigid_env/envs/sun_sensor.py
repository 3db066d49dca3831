"""A coarse sun sensor: a cosine detector (a solar cell or photodiode) on each chosen face of the
body, the sensor of a satellite's safe mode ("find the Sun").

A detector on a face of outward normal ``n`` (body frame) in sunlight reads its current over
the current it gives facing the Sun in full light, the cosine law (Wertz, *Spacecraft Attitude
Determination and Control*, Reidel 1978, Sec. 6.1.1; Markley and Crassidis, *Fundamentals of
Spacecraft Attitude Determination and Control*, Springer 2014, Sec. 4.3)::

    I = max(0, L (n . s) + sigma nu)    where n . s > 0 and L > 0,    else I = 0

with ``s`` the unit vector from the body to the Sun (body frame), ``L`` the fraction of the
Sun's disk the Earth leaves uncovered (conical shadow with its penumbra,
:func:`rigid_env.core.sun.light_conical`), ``nu`` a standard normal per detector and sample: no
signal in eclipse or from a face turned away, and a current never below 0. The irradiance's
change with the Earth's distance from the Sun (+-3.4 % over a year) is left out, and so is the
Earth's albedo (up to ~0.3 of the Sun's signal on a face towards a sunlit Earth). The framework
clips each reading into [-1, 1] (noise may push a face in full light past 1).

The Sun: :func:`rigid_env.core.sun.sun_position` (0.01 deg) at the Julian date
:data:`EPOCH` + the body's time along its orbit; the body where its orbit puts it at that time
(:attr:`rigid_env.core.world.World.orbit`), or, where the orbit is world state
(:attr:`rigid_env.core.world.World.motion`), the body's position and clock from the scene's
``orbit:`` epoch. A task suits the sensor where its world has an orbit (BdotDetumble,
WheelPointing).
"""

from __future__ import annotations

import datetime as dt
import math
from typing import TYPE_CHECKING, Annotated, Literal

import numpy as np
from numba import njit
from numpy.typing import NDArray
from pydantic import AfterValidator, BaseModel, ConfigDict, Field

from rigid_env.core.orbit_state import epoch_datetime
from rigid_env.core.rotation import quat_rotate_inv
from rigid_env.core.sun import light_conical, sun_position
from rigid_env.core.timescale import SECONDS_PER_DAY, julian_date
from rigid_env.envs.quantities import quantity
from rigid_env.envs.sensor import Noise, Sensor

if TYPE_CHECKING:
    from rigid_env.envs.batch import TaskBatch

FloatArray = NDArray[np.float64]

EPOCH = dt.datetime(2025, 9, 22, 0, 0)
"""The UTC instant an orbit's time 0 is: a September equinox midnight, when the Greenwich meridian
is 1.1 deg from ECI x (GMST), as the field's tilted dipole takes it at t = 0."""
EPOCH_JD = julian_date(EPOCH)
""":data:`EPOCH` as a Julian date [days]."""

FACES = {
    "+x": (1.0, 0.0, 0.0),
    "-x": (-1.0, 0.0, 0.0),
    "+y": (0.0, 1.0, 0.0),
    "-y": (0.0, -1.0, 0.0),
    "+z": (0.0, 0.0, 1.0),
    "-z": (0.0, 0.0, -1.0),
}
"""Each face's outward normal, body frame."""

Face = Literal["+x", "-x", "+y", "-y", "+z", "-z"]
Reading = quantity("full-sun reading", ge=0, le=1)
"""A detector's reading over its full-sun reading, in [0, 1]."""


def _distinct(faces: tuple[str, ...]) -> tuple[str, ...]:
    if len(set(faces)) != len(faces):
        raise ValueError(f"lists a face twice, got {list(faces)!r}; give each face once")
    return faces


class SunSensorSettings(BaseModel):
    """Coarse sun sensors (:mod:`rigid_env.envs.sun_sensor`): a cosine detector on each chosen
    face, one observation column each."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    faces: Annotated[tuple[Face, ...], Field(min_length=1), AfterValidator(_distinct)] = tuple(
        FACES
    )
    """The faces that carry a detector, each once, among +x, -x, +y, -y, +z, -z (default
    all six)."""
    sigma: Reading = 0.0
    """Standard deviation of a lit detector's noise over its full-sun reading, in [0, 1]."""


@njit(cache=True, nogil=True, error_model="numpy")
def _sun_and_light(r, jd, to_sun, light):
    """For K bodies at ECI positions ``r`` (K, 3) [m] at Julian dates ``jd`` (K,): the unit
    vector to the Sun (K, 3), ECI, and the fraction of its light past the Earth (K,)."""
    for k in range(r.shape[0]):
        sun = sun_position(jd[k])
        rk = (r[k, 0], r[k, 1], r[k, 2])
        d = (sun[0] - rk[0], sun[1] - rk[1], sun[2] - rk[2])
        size = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        to_sun[k, 0], to_sun[k, 1], to_sun[k, 2] = d[0] / size, d[1] / size, d[2] / size
        light[k] = light_conical(rk, sun)


def _sky(task: TaskBatch, rows: NDArray[np.int64]) -> tuple[FloatArray, FloatArray] | None:
    """The Sun's unit vector (K, 3) ECI and its light (K,) at the envs ``rows``; None without
    an orbit."""
    world = task.world
    if world.motion is not None:  # the orbit as world state: x is where the orbit puts the body
        t = world.orbit_rows[rows, 0]
        r = world.state.x[rows]
        epoch_jd = julian_date(epoch_datetime(world.motion.epoch))
    elif world.orbit is not None and world.orbit_time is not None:  # the coils' own orbit
        t = world.orbit_time[rows]
        r = world.orbit.orbit.position(t)
        epoch_jd = EPOCH_JD
    else:
        return None
    to_sun, light = np.empty((t.size, 3)), np.empty(t.size)
    if t.size:
        _sun_and_light(np.ascontiguousarray(r), epoch_jd + t / SECONDS_PER_DAY, to_sun, light)
    return to_sun, light


def sun_body(task: TaskBatch, rows: NDArray[np.int64]) -> FloatArray | None:
    """(K, 3) the unit vector from each body to the Sun, body frame; None without an orbit."""
    sky = _sky(task, rows)
    return None if sky is None else quat_rotate_inv(task.world.state.q[rows], sky[0])


def sunlight(task: TaskBatch, rows: NDArray[np.int64]) -> FloatArray | None:
    """(K, 1) the fraction of the Sun's light that reaches each body; None without an orbit."""
    sky = _sky(task, rows)
    return None if sky is None else sky[1][:, None]


def measure(settings: SunSensorSettings, dt_s, truth, state, normals):
    """Each chosen face's reading (K, faces) (module docstring), its noise drawn per face."""
    normals_body = np.array([FACES[f] for f in settings.faces])  # (F, 3)
    cosine = truth["sun"] @ normals_body.T  # (K, F)
    lit = (cosine > 0.0) & (truth["light"] > 0.0)
    reading = np.where(lit, truth["light"] * cosine, 0.0)
    if settings.sigma > 0.0:
        noise = settings.sigma * normals.standard_normal(reading.shape)
        reading = np.where(lit, np.maximum(0.0, reading + noise), 0.0)
    return reading, state


def face_count(settings: SunSensorSettings) -> int:
    """One detector per chosen face (a named function: an env holding the sensor pickles)."""
    return len(settings.faces)


def face_columns(settings: SunSensorSettings) -> tuple[str, ...]:
    """The observation column of each chosen face, ``sun_<face>``."""
    return tuple(f"sun_{f}" for f in settings.faces)


TRUTHS = {"sun": sun_body, "light": sunlight}
"""The truths the sun sensor reads, by name (the registry adds them to
:data:`rigid_env.envs.sensing.TRUTHS`)."""

SENSORS = (
    Sensor(
        key="sun_sensor",
        settings=SunSensorSettings,
        reads=("sun", "light"),
        measure=measure,
        noise=(Noise("sigma", face_count),),
        columns=face_columns,
        bound=1.0,
        example={"sigma": 0.01},
    ),
)
"""The coarse sun sensor."""
