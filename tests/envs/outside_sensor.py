"""A sensor the package has never seen, registered from outside (``RIGID_ENV_SENSORS=
outside_sensor``, this folder on ``PYTHONPATH``): a spin-rate meter reading ``|w|`` [rad/s] with
white noise into a column of its own, ``spin_rate``. ``test_sensors_generic.py`` picks it up in
a fresh process (``test_a_sensor_registered_from_outside_gets_the_generic_tests``)."""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict

from rigid_env.envs.quantities import quantity
from rigid_env.envs.sensor import Noise, Sensor


class SpinMeterSettings(BaseModel):
    """A spin-rate meter: ``|w|`` plus white noise."""

    model_config = ConfigDict(frozen=True, extra="forbid", use_attribute_docstrings=True)

    sigma: quantity("rad/s", ge=0) = 0.0  # type: ignore[valid-type]
    """Standard deviation of the noise [rad/s], >= 0."""


def measure(settings, dt, truth, state, normals):
    """``|w| + sigma nu`` (K, 1) [rad/s]."""
    speed = np.linalg.norm(truth["w"], axis=1, keepdims=True)
    if settings.sigma > 0.0:
        speed = speed + settings.sigma * normals.standard_normal(speed.shape)
    return speed, state


SENSORS = (
    Sensor(
        key="spin_meter",
        settings=SpinMeterSettings,
        reads=("w",),
        measure=measure,
        noise=(Noise("sigma", 1),),
        columns=("spin_rate",),
        bound=5.0,
        example={"sigma": 0.01},
    ),
)
