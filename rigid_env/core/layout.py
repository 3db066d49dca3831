"""Every array the compiled kernels share, declared once by name.

* :class:`Body`: a body's model, one column of the world's model columns (``len(Body._fields)``,
  N): what the per-body functions read as ``m.mass``, ``m.inv_inertia_x``.
* :class:`Params`: the world's parameters, the head of one float64 array (:func:`pack` in
  :mod:`rigid_env.core.effects` fills it by name), followed by the actuators' maps from
  :data:`MAPS` on (then each command component's :class:`Thruster` hardware numbers); the
  per-body functions read them as ``c.gravity``, ``c.drag_k``. The effects' fields come from
  their declarations (:data:`EFFECTS`); an effect the scene does not list has a 0 flag, skipped
  by one branch. Every offset follows from the order of the declaration.
* the state columns (13, N) ``(x, v, q, w)`` (:func:`load`, :func:`store`), and from
  :data:`THRUST` on the thrusters' levels where they lag.
* the step's outcome: a body's status (:data:`HEALTHY`, :data:`FROZEN`, :data:`FAILED`) and the
  code a world step returns (:func:`step_code`, decoded by :func:`decode`).

Numba compiles a named tuple of floats as it compiles a plain tuple: numbers in registers, where
an array would cost two atomic reference counts per call. :func:`unpack` and :func:`body_model`
read one from an array in the declaration's order, one load per field
(:mod:`rigid_env.core.reading`); as plain Python (``NUMBA_DISABLE_JIT=1``) they build the same
named tuple.

Frames: forces on the centre of mass are world frame, torques and angular velocities body frame
(principal axes), so the inertia is the constant diagonal ``I``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import types
from numba.cpython.unsafe.tuple import tuple_setitem
from numba.extending import overload, register_jitable
from numpy.typing import NDArray

from rigid_env.core.effect import load_effects
from rigid_env.core.jit import kernel
from rigid_env.core.reading import _read

FloatArray = NDArray[np.float64]


class Body(NamedTuple):
    """A body's model numbers, in its principal axes."""

    mass: float  # [kg]
    inertia_x: float  # principal moments [kg m^2]
    inertia_y: float
    inertia_z: float
    inv_mass: float  # 1 / mass [1/kg]
    inv_inertia_x: float  # 1 / principal moments [1/(kg m^2)]
    inv_inertia_y: float
    inv_inertia_z: float
    isotropic: float  # 1: three equal moments (no gyroscopic term), else 0
    inv_sqrt_mass: float  # 1 / sqrt(mass), for the guard's reach [1/kg^(1/2)]
    inv_sqrt_inertia: float  # 1 / sqrt(least principal moment), the same [1/(kg^(1/2) m)]


_HEAD = (
    ("h", "integrator step dt / substeps [s]"),
    ("substeps", "integrator steps per world step"),
)
_TAIL = (
    ("linear_damping", "flag"),
    ("linear_alpha", "v <- alpha v each world step"),
    ("angular_damping", "flag"),
    ("angular_alpha", "w <- alpha w each world step"),
    ("max_speed", "flag"),
    ("max_speed_value", "the limit on |w| [rad/s]"),
    ("actuator_force", "flag: some actuator pushes the centre of mass (not only couples)"),
    ("any_force", "flag: some effect or actuator acts (else a splitting skips its kicks)"),
    ("velocity_dependent", "flag: some force depends on v or w (kicks need more stages)"),
    ("stable_speed", "|w| [rad/s] beyond which the integrator leaves its stable range (0: none)"),
    ("actions", "number A of command components"),
    ("rtol", "error-controlled integrators (dop853): relative tolerance of a substep's error"),
    ("atol", "and its absolute tolerance"),
    ("max_substeps", "the most substeps one integrator step may take"),
    ("adaptive", "flag: error control on (else one fixed step of h)"),
    ("dt", "world step [s]"),
    ("hardware", "flag: some thruster has a hardware model (lag, min impulse, on/off, noise)"),
    ("lagged", "flag: the thrust levels are state, rows from THRUST on (some thruster lags)"),
    ("noisy", "flag: the command carries A thrust factors after its A components"),
    ("body_maps", "flag: each body has its own actuator maps, model rows from MODEL_WIDTH on"),
    (
        "dipoles",
        "flag: some command components are magnetic dipoles (dipole_row); the "
        "command carries each body's field B (3, world) [T] after its components (field_of)",
    ),
    ("residual_dipole_x", "the body's own dipole where a dipole is commanded, body frame [A m^2]"),
    ("residual_dipole_y", "its y component"),
    ("residual_dipole_z", "its z component"),
    ("wheels", "flag: the bodies carry reaction wheels (rigid_env.core.wheels)"),
    ("wheel_count", "number K of them (1 to MAX_WHEELS)"),
    ("wheel_rows", "offset of the wheels' rows (a Wheel record each) in the parameter array"),
    (
        "wheels_coupled",
        "flag: two wheel axes share a nonzero component, so that one wheel's impulse moves "
        "another's speed (the speed limit then sweeps again: rigid_env.core.wheels.wheel_laws)",
    ),
    ("orbit", "flag: each body moves on its orbit, state rows from orbit_row (core.orbit_state)"),
    ("orbit_row", "row of a body's first orbit state row (its clock) in the state columns"),
    ("orbit_mu", "the Earth's gravitational parameter of the orbits [m^3/s^2]"),
    ("field_degree", "the IGRF's degree evaluated where the body is (0: none; 1: the dipole)"),
    ("field_rows", "offset of the IGRF's coefficients g, h, g_rate, h_rate in the parameters"),
    ("orbit_epoch", "the Julian date of the orbits' epoch, UTC [days] (the Sun's place)"),
    (
        "sunlight",
        "flag: a listed effect reads the sunlight where the body is (Effect.reads; "
        "Surroundings.to_sun, .light, set per substep from the orbit state)",
    ),
    (
        "air",
        "flag: a listed effect reads the air where the body is (Effect.reads; "
        "Surroundings.air_velocity, .air_density, set per substep from the orbit state)",
    ),
)


EFFECTS = load_effects()
"""The registered effects (:mod:`rigid_env.core.effect`), in the order their terms are summed."""
_FIELDS = (
    *(name for name, _ in _HEAD),
    *(name for e in EFFECTS for name in (e.name, *e.fields)),
    *(name for name, _ in _TAIL),
)
Params = NamedTuple("Params", [(name, float) for name in _FIELDS])  # type: ignore[misc]
Params.__doc__ = (
    "The world's parameters: the step, then each registered effect's flag (1 where the scene "
    "lists it, else 0) and fields (:class:`rigid_env.core.effect.Effect`), then the step's own "
    "settings. Vectors are world frame unless named.\n\n"
    + "\n".join(f"* ``{name}``: {doc}" for name, doc in (*_HEAD, *_TAIL))
)


MAPS = len(Params._fields)
"""Offset of the actuators' maps in the parameter array: A rows of ``(force (3,), torque (3,))``,
body frame, at ``|u| = 1``."""
MODEL_WIDTH = len(Body._fields)
"""Rows of a body's model numbers in the model columns; where the bodies have their own
actuator maps (``Params.body_maps``: a misaligned thruster), rows ``MODEL_WIDTH + 6 a`` ..
``+ 5`` hold component ``a``'s ``(force, torque)`` at ``|u| = 1`` (body frame), as the rows of
:data:`MAPS` do for all bodies."""
WRENCH_WIDTH = 17
"""Rows of the world step's scratch columns ``wrenches`` (WRENCH_WIDTH, N): each body's
actuator force (0:3) and torque (3:6), body frame, held over the world step, its
:data:`REACH`, where a dipole is commanded (``Params.dipoles``) its dipole (7:10, body
frame) and the field (10:13, world frame): the four parts of an actuation ``act``
(:func:`rigid_env.core.dynamics.wrench`); and where the bodies carry reaction wheels each
wheel's motor torque (from :data:`MOTORS`)."""
MOTORS = 13
"""First row of ``wrenches`` holding each reaction wheel's motor torque ``u_k max_torque_k``
[N m] of the body's command, :data:`MAX_WHEELS` rows (:mod:`rigid_env.core.wheels`), written
before the vectorised passes (which then read no command)."""
REACH = 6
"""Row of ``wrenches`` holding each body's force reach for the guard
(:func:`rigid_env.core.stepping.force_reach`), computed once per world step."""
STATE_WIDTH = 13
"""Rows of the state columns: ``x`` (0:3), ``v`` (3:6), ``q`` (6:10), ``w`` (10:13)."""
THRUST = STATE_WIDTH
"""Row of the first actuator state where the scene's thrusters lag (``Params.lagged``): rows
``THRUST + a`` hold command component ``a``'s thrust level ``f_a / max_force_a`` [-] (signed),
part of the body's state as ``x, v, q, w``."""


class Thruster(NamedTuple):
    """A command component's hardware numbers (:mod:`rigid_env.core.thrusters`), one row per
    component after the actuators' maps (:func:`thruster`); an ideal one has zeros but its
    ``max_force``."""

    max_force: float  # force at |u| = 1 [N]
    inv_lag: float  # 1 / TAU of df/dt = (u f_max - f) / TAU [1/s]; 0: no lag
    min_impulse: float  # [N s]: a firing of smaller commanded impulse gives none; 0: none
    on_off: float  # flag: pulse-width firing, |u| = the fraction of the step fired
    noise: float  # SIGMA of the multiplicative thrust factor (drawn outside the core)


THRUSTER_WIDTH = len(Thruster._fields)
MAX_WHEELS = 4
"""The most reaction wheels a body carries (a pyramid of four is the usual most): their momenta
ride through the integrators as one 4-tuple, zeros past the last (:mod:`rigid_env.core.wheels`)."""


class Wheel(NamedTuple):
    """A reaction wheel's numbers (:mod:`rigid_env.core.wheels`), one row each from
    ``Params.wheel_rows`` on in the parameter array (:func:`wheel`)."""

    axis_x: float  # spin axis, a unit vector, body frame
    axis_y: float
    axis_z: float
    inertia: float  # axial inertia J [kg m^2]
    max_torque: float  # motor torque at |u| = 1 [N m]
    max_speed: float  # speed limit relative to the body [rad/s]
    viscous: float  # viscous friction [N m s/rad]
    coulomb: float  # Coulomb friction [N m]
    action: float  # its command component (an index)
    pre_fix: float  # 1: the law before issue 44 (kept for WheelPointing-v0's history), else 0


WHEEL_WIDTH = len(Wheel._fields)
"""Numbers of a reaction wheel's row in the parameter array (a :class:`Wheel`)."""
_PARAMS0 = Params(*([0.0] * MAPS))
_BODY0 = Body(*([0.0] * MODEL_WIDTH))
_THRUSTER0 = Thruster(*([0.0] * THRUSTER_WIDTH))
_WHEEL0 = Wheel(*([0.0] * WHEEL_WIDTH))

# ---- a body's status and the code of a world step -------------------------------------------
HEALTHY, FROZEN, FAILED = 0, 1, 2
"""A body's status: stepped; left alone after an earlier failure; its state turned non-finite in
this step (left at its last finite state)."""
BAD_COMMAND = -1
"""The code of a world step that stepped nothing: the command has a NaN or inf."""


# Plain Python where Python calls them (no dispatch to compiled code), compiled where compiled
# code does (Numba's register_jitable): one definition of the code for both.
@register_jitable
def step_code(failures, beyond):
    """The code of a world step: ``2 failures + beyond``, ``beyond`` 1 if a body ended the step
    past the integrator's stable ``h |w|``, else 0."""
    return 2 * failures + beyond


@register_jitable
def failures_of(code):
    """Bodies that failed, from a world step's code (>= 0)."""
    return code >> 1


@register_jitable
def beyond_of(code):
    """1 if a body ended past the stable ``h |w|``, from a world step's code (>= 0)."""
    return code & 1


def decode(code: int) -> tuple[bool, int, bool]:
    """``(bad_command, failures, beyond)`` of a world step's code."""
    if code == BAD_COMMAND:
        return True, 0, False
    return False, int(failures_of(code)), bool(beyond_of(code))


# ---- reading the arrays by the declaration ---------------------------------------------------
def unpack(p: FloatArray) -> Params:
    """The named parameters at the head of the world's parameter array ``p``."""
    return Params(*p[:MAPS].tolist())


def body_model(model: FloatArray, i: int) -> Body:
    """Body ``i``'s model numbers from the model columns (MODEL_WIDTH, N)."""
    return Body(*model[:, i].tolist())


@overload(unpack, inline="always")
def _unpack(p):
    return lambda p: _read(p, 0, _PARAMS0)


@overload(body_model, inline="always")
def _body_model(model, i):
    return lambda model, i: _read(model, i, _BODY0)


def thruster(p: FloatArray, actions: int, a: int) -> Thruster:
    """Command component ``a``'s hardware numbers, after the ``actions`` rows of maps."""
    k = MAPS + 6 * actions + THRUSTER_WIDTH * a
    return Thruster(*p[k : k + THRUSTER_WIDTH].tolist())


@overload(thruster, inline="always")
def _thruster(p, actions, a):
    return lambda p, actions, a: _read(p, MAPS + 6 * actions + THRUSTER_WIDTH * a, _THRUSTER0)


def wheel(p: FloatArray, c: Params, k: int) -> Wheel:
    """Reaction wheel ``k``'s numbers, from row ``k`` after ``c.wheel_rows``."""
    j = int(c.wheel_rows) + WHEEL_WIDTH * k
    return Wheel(*p[j : j + WHEEL_WIDTH].tolist())


@overload(wheel, inline="always")
def _wheel(p, c, k):
    return lambda p, c, k: _read(p, int(c.wheel_rows) + WHEEL_WIDTH * k, _WHEEL0)


def with_item(t: tuple, k: int, value: float) -> tuple:
    """The tuple ``t`` with item ``k`` replaced by ``value`` (a loop over a tuple's slots
    builds one this way; compiled, the unrolled loop keeps the items in registers)."""
    return (*t[:k], value, *t[k + 1 :])


@overload(with_item, inline="always")
def _with_item(t, k, value):
    return lambda t, k, value: tuple_setitem(t, k, value)


def wheel_shape(t: tuple) -> tuple:
    """K zeros for a K-tuple ``t`` (a world's wheels' rows, their records, a body's momenta):
    the momenta of K wheels at rest. Compiled, K is a constant of ``t``'s type, so that each
    loop over the wheels (``for k in range(len(t))``) is one of K constant trips, which the
    compiler unrolls for the K in use: no slot past the last wheel, no count read at run
    time."""
    return (0.0,) * len(t)


@overload(wheel_shape, inline="always")
def _wheel_shape(t):
    zeros = (0.0,) * len(t)
    return lambda t: zeros


def no_wheel_records(t: tuple) -> tuple:
    """K :class:`Wheel` records of zeros for a K-tuple ``t`` (:func:`wheel_shape`): the
    records of a body without wheels, constants the compiler folds."""
    return (_WHEEL0,) * len(t)


@overload(no_wheel_records, inline="always")
def _no_wheel_records(t):
    records = (_WHEEL0,) * len(t)
    return lambda t: records


@kernel
def command_level(command, r, a):
    """Component ``a`` of row ``r`` of the command (N | 1, A), clipped to ``[-1, 1]`` (full
    throttle either way). The one rule of every entry point (``World.step``, ``World.advance``,
    the envs): a command beyond full throttle gives full throttle; a NaN or inf is refused
    before the step (:data:`BAD_COMMAND`)."""
    return min(max(command[r, a], -1.0), 1.0)


@kernel
def map_row(p, c, model, a, i):
    """Command component ``a``'s body-frame ``(force, torque)`` at ``|u| = 1`` for body ``i``:
    the body's own (model rows from :data:`MODEL_WIDTH`) or the world's (from :data:`MAPS`)."""
    if c.body_maps != 0.0:
        k = MODEL_WIDTH + 6 * a
        return (model[k, i], model[k + 1, i], model[k + 2, i]), (
            model[k + 3, i],
            model[k + 4, i],
            model[k + 5, i],
        )
    k = MAPS + 6 * a
    return (p[k], p[k + 1], p[k + 2]), (p[k + 3], p[k + 4], p[k + 5])


@kernel
def dipole_row(p, c, a):
    """Command component ``a``'s magnetic dipole at ``|u| = 1``, body frame [A m^2] (zero for
    a thruster): rows after the maps and the thrusters' hardware rows, where a dipole is commanded
    (``c.dipoles``)."""
    actions = int(c.actions)
    k = MAPS + 6 * actions + (THRUSTER_WIDTH * actions if c.hardware != 0.0 else 0) + 3 * a
    return (p[k], p[k + 1], p[k + 2])


@kernel
def field_of(command, r, c):
    """The field ``B`` [T], world frame, that row ``r`` of the command carries after its ``A``
    components (and their thrust factors where noisy), where a dipole is commanded."""
    k = int(c.actions) * (2 if c.noisy != 0.0 else 1)
    return (command[r, k], command[r, k + 1], command[r, k + 2])


@kernel
def load(state, i):
    """Body ``i``'s ``(x, v, q, w)`` from the state columns (13, N), as tuples."""
    return (
        (state[0, i], state[1, i], state[2, i]),
        (state[3, i], state[4, i], state[5, i]),
        (state[6, i], state[7, i], state[8, i], state[9, i]),
        (state[10, i], state[11, i], state[12, i]),
    )


@kernel
def load_wrench(wrenches, i, c):
    """Body ``i``'s actuation ``(force, torque, dipole, field)`` from its column of
    ``wrenches`` (:data:`WRENCH_WIDTH`, N); the dipole and field zero unless a dipole
    is commanded."""
    f = (wrenches[0, i], wrenches[1, i], wrenches[2, i])
    t = (wrenches[3, i], wrenches[4, i], wrenches[5, i])
    if c.dipoles == 0.0:
        return f, t, ZERO3, ZERO3
    d = (wrenches[7, i], wrenches[8, i], wrenches[9, i])
    return f, t, d, (wrenches[10, i], wrenches[11, i], wrenches[12, i])


@kernel
def store_wrench(wrenches, i, act, c):
    """Write body ``i``'s actuation ``act`` into its column of ``wrenches``."""
    wrenches[0, i], wrenches[1, i], wrenches[2, i] = act[0]
    wrenches[3, i], wrenches[4, i], wrenches[5, i] = act[1]
    if c.dipoles != 0.0:
        wrenches[7, i], wrenches[8, i], wrenches[9, i] = act[2]
        wrenches[10, i], wrenches[11, i], wrenches[12, i] = act[3]


ZERO3 = (0.0, 0.0, 0.0)
"""The zero 3-vector, a constant the compiler folds."""
ZERO4 = (0.0, 0.0, 0.0, 0.0)
"""No wheels' momenta (a body without reaction wheels): a constant the compiler folds."""


class Surroundings(NamedTuple):
    """What a body meets where it is, held over a substep as the field is (set at the
    substep's middle from the orbit state, :func:`rigid_env.core.orbit_state.where`), for the
    effects that read it (:attr:`rigid_env.core.effect.Effect.reads`): the fifth part of the
    actuation ``act`` on the per-body path (:func:`surroundings_of`). ECI, SI.

    Attributes:
        params: the world's parameter array (the effects' rows, as their specs packed them).
        to_sun: (3) from the body to the Sun [m] (zeros unless ``Params.sunlight``).
        light: the fraction of the Sun's disk the Earth leaves uncovered, 0 (umbra) to 1.
        air_velocity: (3) the body's velocity through the turning atmosphere [m/s] (zeros
            unless ``Params.air``).
        air_density: the air's density there [kg/m^3].
    """

    params: FloatArray
    to_sun: tuple
    light: float
    air_velocity: tuple
    air_density: float


def no_wheel_rows() -> tuple[NDArray[np.float32]]:
    """The wheels' rows a world without wheels hands its compiled step: one empty float32 row,
    never read. Its type (float32 where the wheels' rows are float64 views of the state) tells
    the compiler that no body carries wheels (:func:`carries_wheels`), so the step's passes are
    compiled without the wheels' variants (about three quarters of an integrator's compile
    time); a K-tuple of rows keeps the step's types free of an empty tuple."""
    return (np.zeros(0, np.float32),)


def carries_wheels(momenta) -> bool:
    """Whether the compiled type ``momenta`` (the world's wheels' rows, a tuple of arrays) is
    that of a world whose bodies carry wheels: float64 rows, not :func:`no_wheel_rows`'s."""
    return momenta.dtype.dtype == types.float64


PLACE_ROWS = 6
"""Rows of a world on an orbit's scratch ``places`` (PLACE_ROWS, N), which its vectorised passes
read (:func:`rigid_env.core.stepping.orbit_passes`): each body's position on its orbit at the
middle of the substep in hand (0:3) and, on the last, at the world step's end (3:6), ECI [m]."""


def no_places() -> NDArray[np.float32]:
    """The ``places`` a world off an orbit hands its compiled step: an empty float32 array,
    never read, whose type (float32 where a world on an orbit hands float64 rows) leaves the
    orbit's vectorised passes out of the compiled step (:func:`on_orbit`)."""
    return np.zeros((0, 0), np.float32)


def on_orbit(places) -> bool:
    """Whether the compiled type ``places`` (the world's scratch of its bodies' places) is that
    of a world on an orbit: float64 rows, not :func:`no_places`'s."""
    return places.dtype == types.float64


NO_PARAMS = np.zeros(0)
"""An empty parameter array: the constant :data:`NOWHERE` carries."""
NOWHERE = Surroundings(NO_PARAMS, ZERO3, 0.0, ZERO3, 0.0)
"""The surroundings of a pass that carries none (the vectorised passes, whose effects that read
them are constants 0): no sun, no air."""


def surroundings_of(act: tuple) -> Surroundings:
    """The :class:`Surroundings` an actuation carries as its fifth part, else :data:`NOWHERE`;
    compiled, chosen by the tuple's length (a constant)."""
    return act[4] if len(act) > 4 else NOWHERE


@overload(surroundings_of, inline="always")
def _surroundings_of(act):
    if len(act) > 4:
        return lambda act: act[4]
    return lambda act: Surroundings(NO_PARAMS, ZERO3, 0.0, ZERO3, 0.0)  # NOWHERE, built here


@kernel
def store(state, i, x, v, q, w):
    """Write ``(x, v, q, w)`` into column ``i`` of the state columns (13, N)."""
    state[0, i], state[1, i], state[2, i] = x
    state[3, i], state[4, i], state[5, i] = v
    state[6, i], state[7, i], state[8, i], state[9, i] = q
    state[10, i], state[11, i], state[12, i] = w
