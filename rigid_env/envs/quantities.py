"""The numbers of the envs' keyword arguments: a finite quantity with its unit and range on the
field, refused by the scene's rule (:class:`rigid_env.scene_sections.Quantity`) where it is not
finite or its non-zero magnitude lies outside [1e-100, 1e100]. Shared by the task parameters
(:mod:`rigid_env.envs.params`) and the sensors' settings (:mod:`rigid_env.envs.sensors`)."""

from __future__ import annotations

from typing import Annotated, Any

import numpy as np
from pydantic import BeforeValidator, Field

from rigid_env.scene_sections import Quantity


def _plain_number(value: Any) -> Any:
    """A NumPy real scalar as the Python number it holds (the rest goes on unchanged)."""
    if isinstance(value, np.integer | np.floating) and not isinstance(value, np.bool_):
        return value.item()
    return value


NumPyReal = BeforeValidator(_plain_number)


def quantity(unit: str, **bounds: float) -> Any:
    """A finite number in ``unit`` with the range ``bounds`` (``gt``, ``ge``, ``lt``, ``le``) on
    the field and the scene's magnitude rule; text and booleans refused."""
    return Annotated[float, Field(allow_inf_nan=False, **bounds), Quantity(unit), NumPyReal]
