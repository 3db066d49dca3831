"""The registered effects (:data:`rigid_env.core.layout.EFFECTS`) composed for the compiled
step: the sum of their forces and torques, their bounds for the guard, and the flags the
vectorised passes leave out. No effect is named here.

Each composition is a chain built once, at import, from the registry: one small function per
effect, ``if flag: out = effect(out); return rest(out)``, inlined by Numba at its IR level
(``inline="always"``), so the compiled code is the same sequence of guarded blocks one would
write by hand, in the registry's order; the flag is read by its index in the named parameters
``c`` (a constant). Where a pass sees a flag as the constant 0 (:func:`common`) the block
vanishes. As plain Python (``NUMBA_DISABLE_JIT=1``) the chain runs as it is.
"""

from __future__ import annotations

from collections.abc import Callable

from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic, overload

from rigid_env.core.actuator import actuators, per_body_flags, rare_flags
from rigid_env.core.effect import Effect
from rigid_env.core.layout import EFFECTS, Params

inline = njit(inline="always", error_model="numpy")
"""A link of a chain: inlined into the compiled function that calls it."""

RARE = (*(e.name for e in EFFECTS if e.rare), *rare_flags(), "orbit")
"""The flags that the common vectorised passes leave out (:func:`rigid_env.core.stepping.advance`):
the rare effects' and the rare actuators' (:attr:`rigid_env.core.actuator.Actuator.rare`: the
thrusters' hardware, whose switch times split a substep per body, and the magnetorquers, the
actuation's dipole and field, :func:`rigid_env.core.dynamics.wrench`), and the orbit
(:mod:`rigid_env.core.orbit_state`: where each body is, read per substep). A world with one
steps in the orbit's passes or body by body (:data:`PER_BODY`). The common
vectorised passes see them as the constant 0 of :func:`common`, so their code is not in those
loops at all (a flag read from the array would keep it there: the compiler computes both sides
of a branch inside a vectorised loop)."""
PER_BODY = (
    *(e.name for e in EFFECTS if e.reads),
    *sorted({flag for e in EFFECTS for flag in e.reads}),
    *per_body_flags(),
)
"""The :data:`RARE` flags that the per-body passes alone carry: the effects that read the
body's surroundings (each a loop over its facets, :attr:`rigid_env.core.effect.Effect.reads`),
the surroundings' own flags, and the actuators whose switch times split a substep per body
(:attr:`rigid_env.core.actuator.Actuator.per_body`). A world on an orbit with none of them
takes the orbit's vectorised passes (:func:`rigid_env.core.stepping.orbit_passes`), which see
them as the constant 0 and read the other rare flags from the parameters."""
WHEELS = "wheels"
"""The flag of the reaction wheels: the vectorised passes are compiled twice, seeing it as the
constant 0 (:func:`common`: a world without wheels, whose loops carry no wheel code) and as the
constant 1 (:func:`wheeled`: the wheels' momenta ride through the integrator's flow)."""
WHEELS_COUPLED = "wheels_coupled"
"""The flag of wheels whose impulses move each other's speeds: the wheeled passes are compiled
seeing it as the constant 1 (:func:`wheeled`) and 0 (:func:`wheeled_apart`: the speed limit's
sweeps after the first are left out, :func:`rigid_env.core.wheels.wheel_laws`)."""


def _chain(links: list[tuple[int, Callable]], step: Callable) -> Callable:
    """``f(c, *args, out)`` applying ``step(link, c, *args, out)`` for each ``(flag index,
    link)`` whose flag is set, in order; with no links, ``out`` unchanged."""
    done = inline(lambda c, a, out: out)
    for k, link in reversed(links):
        done = step(k, link, done)
    return done


def _terms_link(k: int, effect: Effect, rest: Callable) -> Callable:
    apply = effect.apply
    if effect.reads:  # it takes the surroundings ``a[5]`` after ``c``

        @inline
        def reading(c, a, out):
            if c[k] != 0.0:
                out = apply(a[0], a[1], a[2], a[3], a[4], c, a[5], out[0], out[1])
            return rest(c, a, out)

        return reading

    @inline
    def link(c, a, out):
        if c[k] != 0.0:
            out = apply(a[0], a[1], a[2], a[3], a[4], c, out[0], out[1])
        return rest(c, a, out)

    return link


def _bound_link(k: int, bound: Callable, rest: Callable) -> Callable:
    @inline
    def link(c, a, out):
        if c[k] != 0.0:
            out = out + bound(*a, c)
        return rest(c, a, out)

    return link


def _effect_bound_link(attribute: str) -> Callable:
    """:func:`_bound_link` of an effect's ``attribute`` bound, ``a = (m, s)``: ``bound(m, c,
    s)`` for one that reads its surroundings ``s``, else ``bound(m, c)``."""

    def step(k: int, effect: Effect, rest: Callable) -> Callable:
        bound = getattr(effect, attribute)
        if effect.reads:

            @inline
            def reading(c, a, out):
                if c[k] != 0.0:
                    out = out + bound(a[0], c, a[1])
                return rest(c, a, out)

            return reading

        @inline
        def link(c, a, out):
            if c[k] != 0.0:
                out = out + bound(a[0], c)
            return rest(c, a, out)

        return link

    return step


def _declaring(attribute: str) -> list[tuple[int, Effect]]:
    """``(flag index, declaration)`` of the effects that declare ``attribute``."""
    return [(Params._fields.index(e.name), e) for e in EFFECTS if getattr(e, attribute) is not None]


def _links(attribute: str) -> list[tuple[int, Callable]]:
    """``(flag index, kernel)`` of the effects that declare ``attribute``."""
    return [(k, getattr(e, attribute)) for k, e in _declaring(attribute)]


_terms = _chain(_declaring("apply"), _terms_link)
_actuator_torques = _chain(
    [
        (Params._fields.index(a.flags[0]), a.torque_bound)
        for a in actuators()
        if a.torque_bound is not None
    ],
    _bound_link,
)
_forces = _chain(_declaring("force_bound"), _effect_bound_link("force_bound"))
_torques = _chain(_declaring("torque_bound"), _effect_bound_link("torque_bound"))
_potentials = _chain(_links("potential_bound"), _bound_link)
_POTENTIAL_FLAGS = tuple(k for k, _ in _links("potential_bound"))


@inline
def effect_terms(x, v, q, w, m, c, s, f, tau):
    """``(f, tau)`` with every listed effect's force (world) [N] and torque (body) [N m] added,
    in the registry's order; ``s``: the body's surroundings
    (:class:`rigid_env.core.layout.Surroundings`), for the effects that read them."""
    return _terms(c, (x, v, q, w, m, s), (f, tau))


@inline
def add_force_bounds(force, m, c, s):
    """``force`` [N] plus the most force the listed effects supply (in the surroundings ``s``,
    for the effects that read them)."""
    return _forces(c, (m, s), force)


@inline
def add_torque_bounds(torque, m, c, s):
    """``torque`` [N m] plus the most torque the listed effects supply (in the surroundings
    ``s``, for the effects that read them)."""
    return _torques(c, (m, s), torque)


@inline
def add_actuator_torque_bounds(torque, act, c):
    """``torque`` [N m] plus what each listed actuator's wrench ``act`` adds to ``|tau|`` beyond
    its map rows' torque (its declared ``torque_bound``: the coils' ``|m_b| |B|``)."""
    return _actuator_torques(c, (act,), torque)


@inline
def add_potential_roots(root, x, m, c):
    """``root`` [J^(1/2)] plus ``sqrt(dV)`` of each listed conservative effect from ``x``."""
    return _potentials(c, (x, m), root)


def any_potential(c: Params) -> bool:
    """Whether a conservative effect (one with a ``potential_bound``) is listed."""
    return any(c[k] != 0.0 for k in _POTENTIAL_FLAGS)


def rare(c: Params) -> bool:
    """Whether one of the :data:`RARE` flags of ``c`` is set."""
    return any(getattr(c, name) != 0.0 for name in RARE)


def common(c: Params) -> Params:
    """``c`` with the :data:`RARE` flags and the :data:`WHEELS` flag 0; compiled, 0 as
    constants that remove the effects' and the wheels' branches from the code."""
    return c._replace(**dict.fromkeys((*RARE, WHEELS), 0.0))


def wheeled(c: Params) -> Params:
    """``c`` with the :data:`RARE` flags 0 and the :data:`WHEELS` and :data:`WHEELS_COUPLED`
    flags 1, as constants (for a world whose bodies carry wheels and nothing rare)."""
    return c._replace(**dict.fromkeys(RARE, 0.0), **{WHEELS: 1.0, WHEELS_COUPLED: 1.0})


def wheeled_apart(c: Params) -> Params:
    """:func:`wheeled` with the :data:`WHEELS_COUPLED` flag the constant 0 (wheels whose
    impulses move no other wheel: the speed limit's one sweep suffices)."""
    return c._replace(**dict.fromkeys(RARE, 0.0), **{WHEELS: 1.0, WHEELS_COUPLED: 0.0})


def orbiting(c: Params) -> Params:
    """``c`` with the :data:`PER_BODY` flags and the :data:`WHEELS` flag the constant 0 (a
    world on an orbit whose bodies carry no wheels), the other rare flags as they are."""
    return c._replace(**dict.fromkeys((*PER_BODY, WHEELS), 0.0))


def orbiting_wheeled(c: Params) -> Params:
    """:func:`orbiting` with the :data:`WHEELS` and :data:`WHEELS_COUPLED` flags the constant 1."""
    return c._replace(**dict.fromkeys(PER_BODY, 0.0), **{WHEELS: 1.0, WHEELS_COUPLED: 1.0})


def orbiting_wheeled_apart(c: Params) -> Params:
    """:func:`orbiting_wheeled` with the :data:`WHEELS_COUPLED` flag the constant 0."""
    return c._replace(**dict.fromkeys(PER_BODY, 0.0), **{WHEELS: 1.0, WHEELS_COUPLED: 0.0})


def per_body(c: Params) -> bool:
    """Whether one of the :data:`PER_BODY` flags of ``c`` is set."""
    return any(getattr(c, name) != 0.0 for name in PER_BODY)


def _any_set(indices: tuple[int, ...]) -> Callable:
    @intrinsic
    def any_set(typingctx, c):
        def codegen(context, builder, sig, args):
            out = cgutils.false_bit
            zero = context.get_constant(types.float64, 0.0)
            for k in indices:
                flag = builder.extract_value(args[0], k)
                out = builder.or_(out, builder.fcmp_unordered("!=", flag, zero))
            return out

        return types.boolean(c), codegen

    return any_set


_rare = _any_set(tuple(Params._fields.index(name) for name in RARE))
_potential = _any_set(_POTENTIAL_FLAGS)
_per_body = _any_set(tuple(Params._fields.index(name) for name in PER_BODY))


def _set_flags(zeros: tuple[str, ...], ones: tuple[str, ...]) -> Callable:
    """An intrinsic ``c -> c`` with the flags ``zeros`` set to the constant 0 and ``ones`` to 1."""

    @intrinsic
    def set_flags(typingctx, c):
        def codegen(context, builder, sig, args):
            out = args[0]
            for names, value in ((zeros, 0.0), (ones, 1.0)):
                constant = context.get_constant(types.float64, value)
                for name in names:
                    out = builder.insert_value(out, constant, Params._fields.index(name))
            return out

        return c(c), codegen

    return set_flags


_common = _set_flags((*RARE, WHEELS), ())
_wheeled = _set_flags(RARE, (WHEELS, WHEELS_COUPLED))
_wheeled_apart = _set_flags((*RARE, WHEELS_COUPLED), (WHEELS,))
_orbiting = _set_flags((*PER_BODY, WHEELS), ())
_orbiting_wheeled = _set_flags(PER_BODY, (WHEELS, WHEELS_COUPLED))
_orbiting_wheeled_apart = _set_flags((*PER_BODY, WHEELS_COUPLED), (WHEELS,))


def _compile_as(function: Callable, compiled: Callable) -> None:
    """Compiled code calling ``function`` (plain Python on the named parameters) runs
    ``compiled`` (its intrinsic: flags read or set as constants), inlined."""

    @overload(function, inline="always")
    def _overload(c):
        return lambda c: compiled(c)


for _function, _compiled in (
    (rare, _rare),
    (per_body, _per_body),
    (any_potential, _potential),
    (common, _common),
    (wheeled, _wheeled),
    (wheeled_apart, _wheeled_apart),
    (orbiting, _orbiting),
    (orbiting_wheeled, _orbiting_wheeled),
    (orbiting_wheeled_apart, _orbiting_wheeled_apart),
):
    _compile_as(_function, _compiled)
