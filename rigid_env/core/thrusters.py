"""Thrusters as hardware, compiled: what a world step's command becomes when a scene's thrusters
have a lag, a minimum impulse bit, pulse-width (on/off) firing or thrust noise.

The hardware turns one world step ``[0, dt]`` of a body into **segments** on which every
thruster's thrust is a known function of time, split at each on/off switch time; each segment
is one step of the world's integrator with a constant wrench (:func:`segment_wrench`), so every
integrator (``splitting`` and ``exact_free`` included) integrates a pulse as it integrates any
held command, and the discontinuity of a valve closing never falls inside a step.

Per thruster ``a`` with command ``u`` (held over the world step), in units of its
``max_force`` (a *level*, signed: a negative command pushes along ``-direction``):

* **minimum impulse bit** ``J``: the commanded impulse ``|u| f_max dt`` below ``J`` gives no
  firing (``u <- 0``); exactly at ``J`` it fires.
* **on/off** (pulse width): the valve is open from the step's start for ``d dt``, ``d =
  min(|u|, 1)``, at level ``sign(u)``; the switch time ``d dt`` splits the step.
* **noise**: the level is multiplied by a factor the caller draws per world step (the command's
  components ``A .. 2A``, :attr:`Params.noisy`), so the core draws nothing.
* **lag**: the thrust follows its target ``c`` (the level above, 0 once the valve has closed)
  by ``dg/dt = (c - g) / TAU``; on a segment of length ``s`` from ``g0`` the exact solution is
  ``g(t) = c + (g0 - c) e^{-t/TAU}``, kept as state (:data:`rigid_env.core.layout.THRUST`):
  ``g1 = c + (g0 - c) e^{-s/TAU}``.

What an integrator sees of a lagged thrust: the segment's **mean** level ``gbar = c + (g0 - c)
(TAU/s)(1 - e^{-s/TAU})`` held over it, which gives the thrust's impulse over the segment
exactly, and with it ``v`` and ``w`` exactly where the force is the only change of them (no
gyroscopic coupling). It is not exact for the state: the position gains ``int_0^s (s - t)
(f(t) - fbar) dt / m``, with ``f - fbar = O(s f')`` that is ``O(s^3 |f'|)`` per segment, and a
time-varying torque meets the gyroscopic term ``w x I w`` with the same ``O(s^3)`` local
error; over ``dt / s`` segments that is a **second-order** method in ``s`` for the coupling
(and exact for the thrust level itself). An integrator of higher order on the rest of the
dynamics (rk4, yoshida4) then meets order 2 only in those terms, scaled by ``|f'| <= f_max /
TAU``: substeps shrink it as ``h^2``.
"""

from __future__ import annotations

import math

from rigid_env.core.dynamics import ZERO_WRENCH, add_component, with_field
from rigid_env.core.jit import kernel
from rigid_env.core.layout import THRUST, command_level, thruster


@kernel
def firing(p, c, command, i, a):
    """Command component ``a`` of body ``i`` in this world step: ``(level, end)``, the level
    while firing [-] (signed, the noise factor applied) and the time the firing ends [s] from
    the step's start (``dt`` unless on/off). ``c``: the named parameters of ``p``."""
    actions = int(c.actions)
    r = 0 if command.shape[0] == 1 else i
    u = command_level(command, r, a)
    th = thruster(p, actions, a)
    if abs(u) * th.max_force * c.dt < th.min_impulse:
        u = 0.0  # below the minimum impulse bit: the valve does not open
    factor = command[r, actions + a] if c.noisy != 0.0 else 1.0
    if th.on_off != 0.0:
        level = 0.0 if u == 0.0 else math.copysign(factor, u)
        return level, min(abs(u), 1.0) * c.dt
    return u * factor, c.dt


@kernel
def next_switch(p, c, command, i, t, t1):
    """The end of the segment that starts at ``t``: the first on/off switch time of body ``i``
    strictly inside ``(t, t1)``, else ``t1`` [s from the step's start]."""
    end = t1
    for a in range(int(c.actions)):
        _, off = firing(p, c, command, i, a)
        if t < off < end:
            end = off
    return end


@kernel
def segment_wrench(p, c, model, command, state, i, t, s):
    """Body-frame ``(force, torque)`` of body ``i``'s thrusters held over the segment ``[t, t +
    s]`` (no switch inside): each component's level (its mean over the segment where it lags,
    whose state in ``state`` advances to the segment's end) times its map row
    (:func:`rigid_env.core.dynamics.add_component`)."""
    act = ZERO_WRENCH
    actions = int(c.actions)
    for a in range(actions):
        level, off = firing(p, c, command, i, a)
        target = level if t < off else 0.0
        g = target
        th = thruster(p, actions, a)
        if th.inv_lag != 0.0:
            g0 = state[THRUST + a, i]
            x = s * th.inv_lag
            # (1 - e^{-x}) / x by expm1: no cancellation for a segment short against TAU.
            g = target + (g0 - target) * (-math.expm1(-x) / x)
            state[THRUST + a, i] = target + (g0 - target) * math.exp(-x)
        act = add_component(act, g, p, c, model, a, i)
    return with_field(act, command, 0 if command.shape[0] == 1 else i, c)
