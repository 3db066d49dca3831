"""The scene sections of where the body is: ``orbit:`` (its orbit about the Earth from an epoch)
and ``field:`` (the Earth's field there), read into a
:class:`rigid_env.core.orbit_state.OrbitMotion` (the orbit as world state).

```yaml
orbit:
  altitude: 5.0e+5        # [m] above the Earth's equatorial radius (6378.137 km): a = R + altitude
                          # (or semi_major_axis: [m]; give one of the two)
  eccentricity: 0.0       # in [0, 1)
  inclination: 97.4       # [deg], 0 to 180
  raan: 0.0               # [deg] right ascension of the ascending node at the epoch
  perigee: 0.0            # [deg] argument of perigee at the epoch
  mean_anomaly: 0.0       # [deg] at the epoch
  j2: false               # J2's secular drift of the node, the perigee and the mean motion
  epoch: 2025.0           # a decimal year or a UTC date-time (2025-01-01T00:00:00Z)
field: {model: igrf, degree: 13}   # or {model: dipole} (IGRF's degree 1)
```
"""

from __future__ import annotations

import datetime as _dt
import math
from typing import Annotated, Literal

from pydantic import BeforeValidator, Field, model_validator

from rigid_env import knobs
from rigid_env.config_files import FieldError, describe
from rigid_env.core.igrf import MAX_DEGREE
from rigid_env.core.orbit import EARTH_EQUATORIAL_RADIUS, kepler_orbit
from rigid_env.core.orbit_state import OrbitMotion
from rigid_env.scene_sections import Quantity, Spec

Angle = Annotated[float, Field(ge=-360, le=360, allow_inf_nan=False), Quantity("deg")]
Metres = Annotated[float, Field(gt=0, le=1.0e9, allow_inf_nan=False), Quantity("m")]
EPOCH_YEARS = (1900.0, 2100.0)
"""The decimal years an epoch may be given as."""
_EPOCH_FIX = "write a decimal year (2025.0) or a UTC date-time (2025-01-01T00:00:00Z)"


def _epoch(value: object) -> _dt.datetime | float:
    """An epoch as a datetime or a decimal year: a number is a year (never seconds since
    1970, which pydantic would make of it), text a date-time in ISO 8601 only."""
    value = knobs.plain_tree(value)
    if isinstance(value, _dt.datetime):
        return value
    if isinstance(value, _dt.date):  # YAML's 2025-01-01: midnight UTC
        return _dt.datetime(value.year, value.month, value.day, tzinfo=_dt.timezone.utc)
    if isinstance(value, int | float) and not isinstance(value, bool):
        low, high = EPOCH_YEARS
        if not (math.isfinite(value) and low <= value <= high):
            raise ValueError(
                f"a decimal year lies in [{low:g}, {high:g}], got {value!r}; {_EPOCH_FIX}"
            )
        return float(value)
    if isinstance(value, str):
        try:
            return _dt.datetime.fromisoformat(value.strip().replace("Z", "+00:00"))
        except ValueError:
            pass
        try:
            float(value)
        except ValueError:
            pass
        else:
            raise ValueError(
                f"a year is a number, got the string {value!r}; write it without quotes"
            )
    raise ValueError(f"expected a decimal year or a date-time, got {describe(value)}; {_EPOCH_FIX}")


class FieldSpec(Spec):
    """The Earth's main field where the body is: the IGRF-14 to a degree (``dipole``: its
    degree 1, the centred tilted dipole), at the orbit's epoch and clock."""

    model: Literal["igrf", "dipole"] = "igrf"
    """``igrf`` (to ``degree``) or ``dipole`` (degree 1)."""
    degree: Annotated[int, Field(ge=1, le=MAX_DEGREE, strict=True)] | None = None
    """The highest degree summed, 1 to 13; left out: 13 for ``igrf``, 1 for ``dipole``."""

    @model_validator(mode="after")
    def _degree(self) -> FieldSpec:
        if self.model == "dipole" and self.degree not in (None, 1):
            raise FieldError(
                "degree", f"the dipole is degree 1, got {self.degree}",
                "leave degree out, or use model: igrf",
            )  # fmt: skip
        return self

    @property
    def resolved_degree(self) -> int:
        """The degree the step sums."""
        if self.degree is not None:
            return self.degree
        return 1 if self.model == "dipole" else MAX_DEGREE


class OrbitSceneSpec(Spec):
    """The body's orbit about the Earth (Kepler's ellipse, J2's secular drift as an option),
    from an epoch its clock counts from; the body's position is the orbit's."""

    altitude: Metres | None = None
    """Height above the Earth's equatorial radius (WGS 84, 6378.137 km) [m]: the semi-major
    axis is ``R + altitude`` (a low orbit: 4e5 to 8e5). Give this or ``semi_major_axis``."""
    semi_major_axis: Metres | None = None
    """Or the semi-major axis [m]."""
    eccentricity: Annotated[float, Field(ge=0, lt=1, allow_inf_nan=False), Quantity("")] = 0.0
    """Eccentricity, in [0, 1)."""
    inclination: Annotated[float, Field(ge=0, le=180, allow_inf_nan=False), Quantity("deg")]
    """Inclination to the equator [deg], 0 to 180 (polar: 90; sun-synchronous at 500 km:
    97.4)."""
    raan: Angle = 0.0
    """Right ascension of the ascending node at the epoch [deg]."""
    perigee: Angle = 0.0
    """Argument of perigee at the epoch [deg]."""
    mean_anomaly: Angle = 0.0
    """Mean anomaly at the epoch [deg]."""
    j2: knobs.Flag = False
    """J2's secular drift of the node, the perigee and the mean motion."""
    epoch: Annotated[_dt.datetime | float, BeforeValidator(_epoch)] = 2025.0
    """The UTC instant the clock counts from: a decimal year or a date-time; with a field,
    inside the IGRF-14 table (1900.0 to 2030.0)."""

    @model_validator(mode="after")
    def _size(self) -> OrbitSceneSpec:
        if (self.altitude is None) == (self.semi_major_axis is None):
            raise FieldError(
                "altitude", "give the orbit's size once",
                "write altitude: m (above 6378.137 km) or semi_major_axis: m, not both",
            )  # fmt: skip
        perigee = self.a * (1.0 - self.eccentricity)
        if perigee <= EARTH_EQUATORIAL_RADIUS:
            raise FieldError(
                "eccentricity",
                f"the perigee radius a (1 - e) = {perigee:.0f} m lies inside the Earth "
                f"({EARTH_EQUATORIAL_RADIUS:.0f} m)",
                "raise the orbit's size or lower eccentricity",
            )
        return self

    @property
    def a(self) -> float:
        """The semi-major axis [m]."""
        if self.semi_major_axis is not None:
            return self.semi_major_axis
        return EARTH_EQUATORIAL_RADIUS + float(self.altitude or 0.0)

    def motion(self, field: FieldSpec | None) -> OrbitMotion:
        """The orbit as world state, with the field (None: none)."""
        orbit = kepler_orbit(
            self.a, self.eccentricity,
            *(math.radians(x) for x in (self.inclination, self.raan, self.perigee,
                                        self.mean_anomaly)),
            j2=self.j2,
        )  # fmt: skip
        degree = 0 if field is None else field.resolved_degree
        return OrbitMotion(orbit, self.epoch, field_degree=degree)
