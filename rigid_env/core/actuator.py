"""An actuator, declared once: what a command component means, its per-unit rows, its wrench
kernel, its bound for the guard, whether it is rare, what it spends, how it is drawn, the env
keywords that change what its actions mean, the state rows it carries and the world input it
reads.

The declarations (:class:`Actuator`) are the registry (:func:`actuators`): the built-in ones of
:mod:`rigid_env.core.actuators` (one module each), then those of the modules named in the
environment variable ``RIGID_ENV_ACTUATORS`` (comma-separated module names, each with a sequence
``ACTUATORS``), as ``RIGID_ENV_EFFECTS`` adds effects (:mod:`rigid_env.core.effect`). From the
registry, with no actuator named anywhere else:

* :func:`rigid_env.core.effects.pack`: the actuators' maps, each declared per-component
  :class:`Table` (the thrusters' hardware rows, the coils' dipoles) and each declared block of
  per-unit rows (the wheels', :attr:`Actuator.rows_at`);
* the flags the common vectorised passes leave out (:func:`rare_flags`,
  :data:`rigid_env.core.compose.RARE`) and those only the per-body passes carry
  (:func:`per_body_flags`, :data:`rigid_env.core.compose.PER_BODY`);
* the guard's reach (:attr:`Actuator.torque_bound`, summed by
  :func:`rigid_env.core.compose.add_actuator_torque_bounds`);
* the state width (:func:`state_rows`), ``action_dim`` (:func:`action_dim`), the fuel measure
  (:func:`fuel_per_unit`), what the actions mean (:func:`meaning_keys`, :func:`meaning_rows`)
  and where the renderer draws them (:func:`drawn`).

Like the effects' registry it is closed when the core is imported (Numba composes the guard's
bounds at compile time, and the compiled step is cached under a key of the core's sources and of
the ``RIGID_ENV_ACTUATORS`` modules', :mod:`rigid_env.numba_cache`).

An actuator from outside is a linear one (its command components have map rows: body-frame force
and torque at ``|u| = 1``, :class:`rigid_env.core.effects.LinearActuator`): it needs no field of
the world's parameters. Its scene section is named by :attr:`Actuator.section` and joins the
scene's ``actuators`` mapping (:mod:`rigid_env.scene_sections`).

Adding an actuator (the checklist; the manual's page ``docs/extending/actuator.md``):

1. its spec, a :class:`~rigid_env.core.effects.LinearActuator` (validated numbers, its maps);
2. its declaration, an :class:`Actuator` with an :attr:`~Actuator.example`, in a module of
   :mod:`rigid_env.core.actuators` (or named by ``RIGID_ENV_ACTUATORS``);
3. its scene section (a pydantic model with ``actuator(scene)`` and ``width``), named by
   :attr:`Actuator.section`;
4. tests: the generic ones (``tests/core/test_actuators_generic.py``) pick it up from the
   registry by its example; add one against a closed form.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_env.core.effect import declared_in, modules_named

FloatArray = NDArray[np.float64]

ENV_VAR = "RIGID_ENV_ACTUATORS"
"""The environment variable naming modules of further actuators (comma-separated)."""


@dataclass(frozen=True)
class Command:
    """What one command component means.

    Attributes:
        quantity: what a component sets at ``|u| = 1`` (``"force"``, ``"dipole"``, ...).
        unit: its unit (``"N"``, ``"A m^2"``, ``"N m"``).
        low, high: the component's range (a command beyond it is clipped to it).
    """

    quantity: str
    unit: str
    low: float = -1.0
    high: float = 1.0


@dataclass(frozen=True)
class Table:
    """Rows of numbers per command component, packed after the maps for every component of the
    world where one actuator of this kind needs them (the thrusters' hardware, the coils'
    dipoles), each other actuator's components filled by :attr:`default`.

    Attributes:
        record: the named record of one row (its fields, in order).
        needed: ``spec -> bool``: whether this actuator needs the table in the world.
        rows: ``spec -> (K, width)``: its own components' rows.
        default: ``any linear actuator -> (K, width)``: the rows of another one's components.
        flags: ``(A, width) table -> {Params field: value}`` set from the whole table.
        check: ``(spec, dt) -> None``: raise a one-line ``ValueError`` for rows the world step
            cannot honour.
    """

    record: type
    needed: Callable[[Any], bool]
    rows: Callable[[Any], FloatArray]
    default: Callable[[Any], FloatArray]
    flags: Callable[[FloatArray], dict[str, float]] = lambda table: {}
    check: Callable[[Any, float], None] = lambda spec, dt: None


def _no_fuel(spec: Any) -> FloatArray:
    return np.zeros(spec.action_dim)


def _map_rows(spec: Any) -> dict[str, FloatArray]:
    return {"force [N]": spec.force_map, "torque [N m]": spec.torque_map}


def _points(spec: Any) -> tuple[FloatArray, FloatArray]:
    """Each component at the centre of mass along its force (or torque) direction."""
    fmap = np.asarray(spec.force_map, dtype=np.float64)
    along = fmap if np.any(fmap != 0.0) else np.asarray(spec.torque_map, dtype=np.float64)
    norm = np.linalg.norm(along, axis=1, keepdims=True)
    dirs = np.divide(along, norm, out=np.zeros_like(along), where=norm > 0.0)
    return np.zeros_like(fmap), dirs


def _everywhere(name: str) -> bool:
    return True


@dataclass(frozen=True)
class Actuator:
    """An actuator as the core and the layers above see it.

    Attributes:
        name: its scene key under ``actuators`` and its spec's ``name``.
        noun: what one of its units is called (``"thruster"``, ``"magnetorquer"``).
        spec: its spec class (a :class:`rigid_env.core.effects.LinearActuator`).
        command: what one of its command components means.
        wrench: the kernel that makes its wrench of a command (``"module:function"``, resolved
            by :func:`kernel`: the kernels import the composition that reads this registry).
        example: ``() -> spec``: a small valid one, which the generic tests step.
        section: its scene section, ``"module:Class"`` (a pydantic model with
            ``actuator(scene) -> spec`` and ``width``), or None (built by the scene itself).
        record: its per-unit rows as a named record (None: its map rows alone).
        unit_rows: ``(spec, first) -> (K, len(record._fields))`` its units' rows, in the
            record's order (``first``: the index of its first command component).
        table: its per-component :class:`Table` packed after the maps, if it has one.
        rows_at: the :class:`Params` field holding the offset of its :attr:`unit_rows`, packed
            last (the wheels'), or None.
        flags: its fields of the world's parameters (set by its spec's ``parameters()``).
        rare: those of :attr:`flags` that the common vectorised passes leave out (see
            :data:`rigid_env.core.compose.RARE`: a world with one steps in the orbit's
            passes or body by body).
        per_body: those of :attr:`rare` that split a substep per body (the thrusters'
            switch times), which the orbit's vectorised passes cannot carry either
            (:data:`rigid_env.core.compose.PER_BODY`).
        single: listed at most once in a world (its units in one list).
        torque_bound: ``(act, c) -> B_tau`` [N m], compiled: what it adds to ``|tau|`` of the
            wrench ``act`` for the guard (:func:`rigid_env.core.stepping.force_reach`), behind
            its first flag; None: its map rows' torque, which the guard takes already.
        bound: ``(spec, field) -> (B_F [N], B_tau [N m])``: the most force and torque it gives
            at any command in range (``field``: the world input it reads, or None), the
            Python statement of its guard bound, which the generic tests hold it to.
        torque_at: ``(spec, u (K,), field) -> (3,)`` the external body-frame torque [N m] at
            the command ``u`` (the generic momentum law).
        full_scale: ``spec -> (K,)`` each component's size at ``|u| = 1``, in
            :attr:`Command.unit` (a thruster's force, a coil's dipole, a motor's torque).
        fuel: ``spec -> (K,)`` what one component spends per second at ``|u| = 1``, in
            :attr:`fuel_unit` per second (thrusters: their force, an impulse rate [N]).
        fuel_unit: the unit of the spent total (``"N s"``, ``"A m^2 s"``).
        draw: ``spec -> (points (K, 3), directions (K, 3))`` body frame: where the renderer draws
            each component and along what.
        meaning: ``spec -> {key: (K, ...) rows}``: what one component does at ``u = 1`` (the
            record every loader compares, ``agents.meaning``).
        meaning_keys: the env keywords that change what its actions mean (``command``).
        scene_keys: the keys of its scene section that set what one command component does
            (its :attr:`meaning`), which a refusal of a policy trained on other ones names
            (none: the refusal names the actuators section as a whole).
        state_rows: ``(specs, A) -> rows`` of state its units (``specs``: the world's of this
            kind) carry after ``x, v, q, w`` in a world of ``A`` command components (None:
            none).
        check_world: ``[(declaration, spec), ...] -> None``: raise a one-line ``ValueError``
            where it cannot step beside the world's other actuators.
        rates: the kernel of its state rows' rates (``"module:function"``), or None.
        internal_momentum: ``world -> (N, 3)`` body-frame angular momentum its state holds
            (the wheels'), or None.
        world_input: the world data it reads (``"field"``: the magnetic field), or None.
        accepts: ``integrator name -> bool``: the integrators that step it.
        why_not: ``integrator name -> str``: why one it refuses does not step it (a few words,
            for the scene's error).
        tilted: ``(spec, tilt) -> (force (E, K, 3), torque (E, K, 3))``: its map rows with its
            directions turned by ``tilt`` (``(K, 3) -> (E, K, 3)``, the misalignments drawn by
            E envs at once, each from its own generator), its arithmetic elementwise over the
            leading axis (NumPy's broadcasting), or None: nothing of it tilts.
        fails: whether a unit of it may fail for an episode (the envs' faults).
        presets: the hardware presets that the env keyword of its :attr:`name` picks
            (``thrusters="realistic"``), ``{preset: (unit section, control step dt [s]) ->
            {key: value} of that unit's scene section to set}``, None: as the scene says; the
            first is the keyword's default. Empty: no such keyword.
    """

    name: str
    noun: str
    spec: type
    command: Command
    wrench: str
    example: Callable[[], Any]
    section: str | None = None
    record: type | None = None
    unit_rows: Callable[[Any, int], FloatArray] | None = None
    table: Table | None = None
    rows_at: str | None = None
    flags: tuple[str, ...] = ()
    rare: tuple[str, ...] = ()
    per_body: tuple[str, ...] = ()
    single: bool = False
    torque_bound: Callable | None = None
    bound: Callable[[Any, Any], tuple[float, float]] | None = None
    torque_at: Callable[[Any, FloatArray, Any], FloatArray] | None = None
    full_scale: Callable[[Any], FloatArray] = lambda spec: np.linalg.norm(spec.force_map, axis=1)
    fuel: Callable[[Any], FloatArray] = _no_fuel
    fuel_unit: str = "N s"
    draw: Callable[[Any], tuple[FloatArray, FloatArray]] = _points
    meaning: Callable[[Any], dict[str, FloatArray]] = _map_rows
    meaning_keys: tuple[str, ...] = ()
    scene_keys: tuple[str, ...] = ()
    state_rows: Callable[[list, int], int] | None = None
    check_world: Callable[[list], None] | None = None
    rates: str | None = None
    internal_momentum: Callable[[Any], FloatArray] | None = None
    world_input: str | None = None
    accepts: Callable[[str], bool] = _everywhere
    why_not: Callable[[str], str] = lambda integrator: "it does not"
    tilted: Callable[[Any, Callable], tuple[FloatArray, FloatArray]] | None = None
    fails: bool = False
    presets: Mapping[str, Callable[[Any, float], dict[str, Any]] | None] = field(
        default_factory=dict
    )


def plugin_modules() -> list[str]:
    """The module names in ``RIGID_ENV_ACTUATORS`` (none if unset)."""
    return modules_named(ENV_VAR)


@cache
def actuators() -> tuple[Actuator, ...]:
    """The registry: the built-in actuators, then each ``RIGID_ENV_ACTUATORS`` module's
    ``ACTUATORS``, in the order their components follow one another in a command.

    Raises:
        ValueError: for a module without ``ACTUATORS``, or a name declared twice.
    """
    from rigid_env.core.actuators import BUILT_IN

    return declared_in(ENV_VAR, BUILT_IN, "ACTUATORS", "Actuator")


def declaration(spec: Any) -> Actuator | None:
    """The declaration of an actuator spec (by its class), or None for an effect that is not
    an actuator."""
    for a in actuators():
        if type(spec) is a.spec:
            return a
    return None


def listed(effects: Sequence[Any]) -> list[tuple[Actuator, Any]]:
    """``(declaration, spec)`` of each actuator among ``effects``, in command order."""
    out = []
    for e in effects:
        found = declaration(e)
        if found is not None:
            out.append((found, e))
    return out


def specs(effects: Sequence[Any]) -> list[Any]:
    """The actuator specs among ``effects``, in command order."""
    return [spec for _, spec in listed(effects)]


def named(name: str) -> Actuator:
    """The declaration of the actuator whose scene key is ``name``."""
    for a in actuators():
        if a.name == name:
            return a
    raise KeyError(f"no actuator {name!r} is registered; known: {[a.name for a in actuators()]}")


def where(effects: Sequence[Any], test: Callable[[Actuator], bool]) -> list[Any]:
    """The actuator specs among ``effects`` whose declaration passes ``test`` (a part chosen
    by what it does, ``lambda a: a.world_input == "field"``, never by its class)."""
    return [spec for a, spec in listed(effects) if test(a)]


def kinds(test: Callable[[Actuator], bool]) -> list[Actuator]:
    """The registered declarations that pass ``test`` (a kind of part chosen by what it does,
    ``lambda a: a.command.quantity == "dipole"``), in command order: for a layer that names
    what it needs of a scene that may lack it (``f"actuators.{kind.name}"``)."""
    return [a for a in actuators() if test(a)]


def preset_keywords(preset: str) -> dict[str, str]:
    """The env keywords that pick the hardware preset ``preset`` of every actuator offering it
    (:attr:`Actuator.presets`), each set to it: ``{"thrusters": "realistic"}``."""
    return {a.name: preset for a in actuators() if preset in a.presets}


def sets_dipole(kind: Actuator) -> bool:
    """Whether ``kind``'s command sets a magnetic dipole (the coils)."""
    return kind.command.quantity == "dipole"


def stores_momentum(kind: Actuator) -> bool:
    """Whether ``kind``'s state rows hold angular momentum (the wheels)."""
    return kind.internal_momentum is not None


def component_column(effects: Sequence[Any], record: type, name: str) -> FloatArray:
    """(A,) column ``name`` of the per-component table whose record is ``record`` (a
    :class:`Table`'s), each component's own row, zeros where its actuator has no such table."""
    parts = []
    for a, spec in listed(effects):
        table = a.table
        if table is not None and table.record is record:
            parts.append(np.asarray(table.rows(spec))[:, record._fields.index(name)])
        else:
            parts.append(np.zeros(spec.action_dim))
    return np.concatenate(parts) if parts else np.zeros(0)


def action_dim(effects: Sequence[Any]) -> int:
    """Components of the command the actuators among ``effects`` read."""
    return sum(spec.action_dim for spec in specs(effects))


def rare_flags() -> tuple[str, ...]:
    """Every declared actuator's rare flags (:attr:`Actuator.rare`)."""
    return tuple(flag for a in actuators() for flag in a.rare)


def per_body_flags() -> tuple[str, ...]:
    """Every declared actuator's flags that split a substep (:attr:`Actuator.per_body`)."""
    return tuple(flag for a in actuators() for flag in a.per_body)


def state_rows(effects: Sequence[Any]) -> int:
    """Rows of actuator state each body carries after ``x, v, q, w``."""
    found = listed(effects)
    actions = sum(spec.action_dim for _, spec in found)
    kinds = [a for a in actuators() if a.state_rows is not None]
    return sum(
        a.state_rows(mine, actions) for a in kinds if (mine := [s for b, s in found if b is a])
    )


def fuel_per_unit(effects: Sequence[Any]) -> FloatArray:
    """(A,) what each command component spends per second at ``|u| = 1`` (its actuator's
    :attr:`~Actuator.fuel`)."""
    parts = [np.asarray(a.fuel(spec), dtype=np.float64) for a, spec in listed(effects)]
    return np.concatenate(parts) if parts else np.zeros(0)


def meaning_keys() -> tuple[str, ...]:
    """The env keywords that change what some actuator's actions mean, each once."""
    return tuple(dict.fromkeys(k for a in actuators() for k in a.meaning_keys))


def meaning_rows(spec: Any) -> dict[str, Any]:
    """What one command component of ``spec`` does at ``u = 1`` (its declaration's
    :attr:`~Actuator.meaning`), as plain lists."""
    found = declaration(spec)
    if found is None:
        raise TypeError(f"{type(spec).__name__} is not a registered actuator")
    rows = found.meaning(spec)
    return {key: np.asarray(value, dtype=np.float64).tolist() for key, value in rows.items()}


def drawn(effects: Sequence[Any]) -> tuple[FloatArray, FloatArray]:
    """Body point (A, 3) [m] and unit direction (A, 3) of each command component, where the
    renderer draws it (each actuator's :attr:`~Actuator.draw`), in command order."""
    parts = [a.draw(spec) for a, spec in listed(effects)]
    if not parts:
        return np.zeros((0, 3)), np.zeros((0, 3))
    points = [np.asarray(p, dtype=np.float64).reshape(-1, 3) for p, _ in parts]
    dirs = [np.asarray(d, dtype=np.float64).reshape(-1, 3) for _, d in parts]
    return np.concatenate(points), np.concatenate(dirs)


def kernel(path: str) -> Callable:
    """The kernel that ``"module:function"`` names."""
    module, _, name = path.partition(":")
    return getattr(importlib.import_module(module), name)
