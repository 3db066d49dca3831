"""What a renderer shows of a task batch (:mod:`rigid_env.render`): the task's view, its
readouts, the thrust each component delivered and one env's frame (:class:`RenderViews`, a part
of :class:`rigid_env.envs.batch.TaskBatch`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from rigid_env.render import Frame, TaskView

FloatArray = NDArray[np.float64]


class RenderViews:
    """The part of :class:`~rigid_env.envs.batch.TaskBatch` this module names (its attributes
    are the batch's)."""

    def view(self) -> TaskView:
        """What the task shows: its body, its thrusters and (under gravity) the ground; a task
        adds its target and readouts."""
        title = type(self).__name__.removesuffix("Task")
        return TaskView.for_scene(
            title, self.scene, self.world.force_effects, spin_scale=self.w_scale
        )

    def readouts(self, i: int) -> tuple[float, ...]:
        """Env ``i``'s numbers for :attr:`TaskView.readouts` (none by default)."""
        return ()

    def delivered_thrust(self, i: int) -> FloatArray:
        """(A,) env ``i``'s thrust in the last step in units of each max force, as delivered:
        the lagged level at the step's end where the thrusters lag, else the command after
        faults (an on/off duty is the step's mean level), times the step's noise factors."""
        levels = self.world.thrust_levels
        if levels is not None:
            return np.clip(levels[i], -1.0, 1.0)
        out = self.command[i].copy()
        if self._noisy:
            out *= self.world.thrust_factors[i]
        return np.clip(out, -1.0, 1.0)

    def frame(self, i: int = 0) -> Frame:
        """The numbers of env ``i``'s current frame."""
        if not 0 <= i < self.n:
            raise IndexError(f"i: environment index {i} is out of range for {self.n} envs")
        s = self.world.state
        return Frame(
            q=s.q[i].copy(),
            w_body=s.w[i].copy(),
            height=float(s.x[i, 2]),
            command=self.delivered_thrust(i),
            step=int(self.steps[i]),
            angular_speed=float(self.angular_speed()[i]),
            fuel=float(self.fuel[i]),
            success=bool(self.success[i]),
            target=self.target[i, :4].copy() if self.target_dim else None,
            readouts=self.readouts(i),
        )
