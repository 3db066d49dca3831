"""What a task batch reports: fuel, success and speed, the world data the pass reads, the
record's columns, and the info dicts of one env and of all (faults and substeps among them)
(:class:`Infos`, a part of :class:`rigid_env.envs.batch.TaskBatch`)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_env.envs import kernels as K
from rigid_env.envs.hardware import (
    FAULT_KINDS,
    Fault,
)

FloatArray = NDArray[np.float64]


class Infos:
    """The part of :class:`~rigid_env.envs.batch.TaskBatch` this module names (its attributes
    are the batch's)."""

    @property
    def fuel(self) -> FloatArray:
        """(N,) impulse spent in the episode so far [N s] (a view of :attr:`record`)."""
        return self.record["fuel"]

    @property
    def success(self) -> NDArray[np.bool_]:
        """(N,) whether each env's task counts as solved at the current step."""
        return self.record["success"]

    def angular_speed(self) -> FloatArray:
        """(N,) ``|w|`` [rad/s] of the current state (finite for a frozen, diverged body)."""
        return self.record["speed"].copy()

    def infos(self) -> dict[str, NDArray[Any]]:
        """Per-env diagnostics (copies): angular speed, energy, fuel, success, failure; with an
        error-controlled integrator also the substeps each env's body took in the last step."""
        info = self._info(self._columns, self.world.failed, self._fault_infos(), self._substeps())
        return {key: value.copy() for key, value in info.items()}

    @property
    def world_data(self) -> K.WorldData:
        """Each env's world data by name (the field, the wheels' momentum), what ``evaluate``
        reads as ``body.field`` and ``body.h_wheels``: read from the world before every pass
        (one shared row of zeros where the world has neither). Views, made once per buffer
        (again after unpickling, where they would be copies)."""
        views = self.__dict__.get("_world_views")
        if views is None or views.field.base is not self._world_data:
            views = K.WorldData.of(self._world_data)
            self._world_views = views
        return views

    @property
    def _columns(self) -> K.EnvRecord:
        """:attr:`record`'s columns by name (views, made once per record buffer: again after
        unpickling, where they would be copies)."""
        columns = self.__dict__.get("_column_views")
        if columns is None or columns.speed.base is not self.record:
            columns = K.EnvRecord._make(map(self.record.__getitem__, K.RECORD.names))
            self._column_views = columns
        return columns

    def info_one(self, r: K.EnvRecord | None = None, failed: bool | None = None) -> dict[str, Any]:
        """:meth:`infos` of env 0 as Python scalars (a (3,) array for a vector): what a single
        env returns, from its record and whether its body failed (each read here if not
        given)."""
        r = K.EnvRecord._make(self.record.item(0)) if r is None else r
        failed = bool(self.world.failed[0]) if failed is None else failed
        faults = {}
        if self._faulty:
            faults = {key: column[0].item() for key, column in self._fault_infos().items()}
        taken = int(self._substeps()[0]) if self._reports_substeps else None
        out = self._info(r, failed, faults, taken)
        out["angular_velocity_world"] = r.w_world.copy()  # item() gives a view of the record
        return out

    def _info(self, r: K.EnvRecord, failed: Any, faults: dict[str, Any], substeps: Any) -> dict:
        """The diagnostics by name from a record (one env's values, or the columns of all),
        the failure flags, the fault infos and the substeps taken (None: not reported)."""
        out = {
            "angular_speed": r.speed,
            "energy": r.energy,
            "fuel": r.fuel,
            "success": r.success,
            "is_success": r.success,  # SB3 EvalCallback logs this key
            "numerical_error": failed,
            "angular_velocity_world": r.w_world,
            **faults,
        }
        if substeps is not None:
            out["substeps"] = substeps
        return out

    def _substeps(self) -> NDArray[np.int64] | None:
        """(N,) the substeps each body took in the last step, for an error-controlled
        integrator (None for a fixed-step one)."""
        if self.world.tolerances is None:
            return None
        return self.substeps if self._repeating else self.world.substeps_taken

    @property
    def faults(self) -> list[Fault | None]:
        """Each env's thruster fault in its episode (None: none), read from :attr:`fault_rows`."""
        return [
            None if k < 0 else Fault(k, step, FAULT_KINDS[kind], level)
            for k, step, kind, level in self.fault_rows.tolist()
        ]

    def _fault_infos(self) -> dict[str, NDArray[Any]]:
        """Where faults are drawn: each env's failed thruster (-1: none), the step its fault
        starts, its kind (index in :data:`~rigid_env.envs.hardware.FAULT_KINDS`, -1: none) and
        level, and whether it acts now."""
        if self.randomization.thruster_faults is None:
            return {}
        rows = self.fault_rows
        thruster, step = rows["thruster"], rows["step"]
        return {
            "fault_thruster": thruster,
            "fault_step": step,
            "fault_kind": rows["kind"],
            "fault_level": rows["level"],
            "fault_active": (thruster >= 0) & (self.steps > step),
        }
