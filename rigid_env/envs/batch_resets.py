"""A task batch's resets: where an episode's world starts by name (:data:`WORLD_STARTS`), the
envs' new episodes and their randomisation (mass properties, thrust, misalignment, faults)
(:class:`Resets`, a part of :class:`rigid_env.envs.batch.TaskBatch`)."""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.actuator import listed
from rigid_env.core.layout import MAPS
from rigid_env.core.state import BodyModel
from rigid_env.core.world import World
from rigid_env.envs.hardware import (
    NO_FAULT,
    draw_fault,
    misaligned_many,
)
from rigid_env.envs.orbit_draws import place_on_orbit
from rigid_env.envs.sampling import (
    mass_property_draws,
    random_mass_properties,
    random_thrust,
)

FloatArray = NDArray[np.float64]


def _start_orbit_time(world: World, rows: NDArray[np.int64], t: FloatArray) -> None:
    world.orbit_time[rows] = t


def _start_wheel_speed(world: World, rows: NDArray[np.int64], speed: FloatArray) -> None:
    world.set_wheel_speed(speed, rows)


WORLD_STARTS: dict[str, Callable[[World, NDArray[np.int64], FloatArray], None]] = {
    "orbit_time": _start_orbit_time,
    "orbit_start": place_on_orbit,
    "wheel_speed": _start_wheel_speed,
}
"""Where an episode's world starts, by name, as a task's :meth:`TaskBatch.sample` may draw it:
``orbit_time`` the time along the orbit [s] (K,); ``orbit_start`` the orbit phase and the
Earth's rotation angle at the epoch [rad] (K, 2) where the orbit is world state
(:func:`rigid_env.envs.orbit_draws.place_on_orbit`); ``wheel_speed`` each wheel's speed
relative to the body [rad/s] (K, wheels)."""


SAMPLERS = ("sample", "sample_many")
"""A task's two ways to draw its envs' initial states (:func:`draws_together`)."""


@functools.cache
def draws_together(task: type) -> bool:
    """Whether ``task``'s :meth:`Resets.sample_many` is its :meth:`Resets.sample`'s peer: the
    class that defines ``sample_many`` defines ``sample`` too, or derives from the one that
    does. A subclass that draws otherwise in its own ``sample`` and inherits ``sample_many``
    draws env by env with its ``sample``, never with its parent's draws."""
    owner = {name: next(k for k in task.__mro__ if name in vars(k)) for name in SAMPLERS}
    return owner["sample_many"] is not Resets and issubclass(owner["sample_many"], owner["sample"])


class Resets:
    """The part of :class:`~rigid_env.envs.batch.TaskBatch` this module names (its attributes
    are the batch's)."""

    def reset_envs(
        self, idx: Sequence[int] | NDArray[np.int64], rngs: Sequence[np.random.Generator]
    ) -> None:
        """Start new episodes for envs ``idx``, each drawing from ``rngs[k]`` (one per index),
        and observe them (:attr:`obs` rows ``idx``; sensor noise from the same generators)."""
        idx = np.asarray(idx, dtype=np.int64)
        s = self.world.state
        draws = []
        r = self.randomization
        randomized = r.physical or r.thrust > 0.0 or r.hardware or r.drawn_repeat
        # Each env draws its initial state, then its episode's randomisation, from its own
        # generator: all the envs' states, then all their randomisations (the draws of many at
        # once), unless envs share a generator: then env by env, in order.
        distinct = len({id(g) for g in rngs}) == len(rngs)
        shared = randomized and not distinct
        groups = [[k] for k in range(idx.size)] if shared else [list(range(idx.size))]
        together = None  # the initial states drawn in one compiled pass, where the task can
        if distinct and idx.size and draws_together(type(self)):
            self.streams.follow(rngs, idx)
            together = self.sample_many(idx)
        for group in groups:
            for k in group if together is None else ():
                draws.append(self.sample(rngs[k]))
                self._check_target(np.shape(draws[-1][4]), "sample")
            if randomized and group:
                self._randomize(idx[group], [rngs[k] for k in group])
        if randomized and self.randomization.physical and idx.size:
            self.world.set_model_rows(idx)  # their mass properties drawn above, set at once
        self.world.restart(idx)  # valves closed, dop853 from its own first guess
        if together is not None:
            x, v, q, w, target = together
            self._check_target(np.shape(target)[1:], "sample_many")
        elif draws:
            x, v, q, w, target = (np.array(c) for c in zip(*(d[:5] for d in draws), strict=True))
        if together is not None or draws:
            s.x[idx], s.v[idx], s.q[idx], s.w[idx] = x, v, q, w
            if self.target_dim:
                self.target[idx, : self.target_dim] = target
            if draws and len(draws[0]) > 5:
                for name in draws[0][5]:
                    WORLD_STARTS[name](self.world, idx, np.array([d[5][name] for d in draws]))
        self.steps[idx] = 0
        self.record[idx] = 0
        self.last_action[idx] = 0.0
        self.command[idx] = 0.0
        self.world.failed[idx] = False
        if idx.size == 0:
            return
        self._own_obs(keep=True)  # rows idx are written below, the others kept
        self._read_world(idx, reset=True)
        if self._draws:
            self.streams.follow(rngs, idx)
        self._pass_rows(idx, stepped=False)
        self._observe_period(idx)
        if self.sensors is not None:
            self.sensors.reset(self, idx, rngs)

    def sample_many(self, rows: NDArray[np.int64]) -> tuple[FloatArray, ...] | None:
        """The initial ``(x, v, q, w_body, target)`` of the envs ``rows``, arrays (K, ...),
        drawn together in a compiled pass, each env from its own generator (:attr:`streams`
        follows them): what :meth:`sample` gives env by env, bit for bit, and the generators
        left where it leaves them. None (this default): :meth:`sample` draws env by env. Called
        only where every env has a generator of its own."""
        return None

    def _check_target(self, shape: tuple[int, ...], method: str) -> None:
        """A one-line error where ``method`` drew a target of another size than
        :attr:`target_dim`."""
        if shape != (self.target_dim,):
            raise ValueError(
                f"{type(self).__name__}.{method}: drew a target of shape {shape}, the task "
                f"declares target_dim = {self.target_dim}; return a target of target_dim "
                "numbers (or declare its size in target_dim)"
            )

    def _randomize(self, rows: NDArray[np.int64], rngs: Sequence[np.random.Generator]) -> None:
        """The episode draws of the envs ``rows`` (``rngs``: their generators, one each): their
        mass properties and thrust scales from their uniform draws (all the envs' in one
        compiled pass), then env by env their thrusters' misalignment, fault and control
        period."""
        r = self.randomization
        physical = mass_property_draws(r)
        thrust = self.action_dim if r.thrust > 0.0 else 0
        if physical + thrust:
            self.streams.follow(rngs, rows)
            u = self.streams.randoms(rows, physical + thrust)
        if r.physical:
            if self.world.model.n == 1:  # first randomised reset: give every body its own copy
                self.world.set_model(
                    BodyModel(
                        np.repeat(self.base_model.mass, self.n),
                        np.repeat(self.base_model.inertia, self.n, axis=0),
                    )
                )
            mass, inertia = random_mass_properties(
                u[:, :physical], r, self.base_model.mass[0], self.base_model.inertia[0]
            )
            model = self.world.model  # set in the world by reset_envs, once for all its envs
            model.mass[rows] = mass
            model.inertia[rows] = inertia
        if thrust:
            if self.thrust_scale is None:  # first randomised reset: scales, and a command apart
                self.thrust_scale = np.ones((self.n, self.action_dim))
                self.command = self.last_action * self.thrust_scale
            self.thrust_scale[rows] = random_thrust(u[:, physical:], r)
        if not (r.hardware or r.drawn_repeat):
            return
        if r.thruster_misalignment > 0.0:  # each env's tilts, then its fault and its repeat
            self._misalign(rows, rngs, r.thruster_misalignment)
        for i, rng in zip(rows.tolist(), rngs, strict=True):
            if r.thruster_faults is not None:
                fault = draw_fault(rng, r.thruster_faults, self.action_dim)
                self.fault_rows[i] = NO_FAULT if fault is None else fault.row
            if r.drawn_repeat:
                choices = r.action_repeat
                self.repeats[i] = choices[int(rng.integers(len(choices)))]

    def _misalign(
        self, rows: NDArray[np.int64], rngs: Sequence[np.random.Generator], degrees: float
    ) -> None:
        """The thrusters of envs ``rows`` tilted for their episodes (their own actuator maps
        in the world), env ``rows[k]`` drawing from ``rngs[k]``, all envs together
        (:func:`rigid_env.envs.hardware.misaligned_many`: each env's draws and numbers those of
        a reset of it alone)."""
        if self.world.body_maps is None:  # first misaligned reset: every body its own maps
            maps = np.broadcast_to(
                self.world.params[MAPS : MAPS + 6 * self.action_dim].reshape(-1, 6),
                (self.n, self.action_dim, 6),
            )
            self.world.set_body_maps(maps[:, :, :3], maps[:, :, 3:])
        maps = self.world.body_maps
        k = 0
        for a, spec in listed(self.world.force_effects):
            width = spec.action_dim
            if a.tilted is not None:  # its directions turned, as it declares
                force, torque = a.tilted(spec, lambda d: misaligned_many(d, rngs, degrees))
                maps[rows, k : k + width, :3] = force
                maps[rows, k : k + width, 3:] = torque
            k += width
