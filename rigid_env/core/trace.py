"""Compile a column kernel into straight-line Python: for one body, and for a batch.

The column kernels (:mod:`rigid_env.core.columns`) run a single body on Python floats, but
through lists, loops over components, helper calls and ``None`` tests for absent terms: most
of a one-body step is that bookkeeping, not arithmetic. :func:`compile_one_body` runs the
kernel once on *traced* numbers instead: each records the operation that made it, so the run
writes out the step as a flat list of assignments ``t17 = t5 * t9``, with every structural
decision (which terms exist, which helper runs, the loop over components) already taken.
That list, compiled, is the step for that one world, several times faster and bit for bit the
same: the same IEEE operations on the same operands in the same order (``+`` and ``*`` are
commutative in IEEE arithmetic, so writing ``c * t`` for ``t * c`` changes nothing).

A decision that depends on a *value* (a half angle within the series' range, a positive
norm) becomes a guard: the compiled step checks that the value falls the way it did during
the trace and otherwise raises :class:`Deopt`, after which the caller runs the kernel itself
for that step. The trace carries the real values of the first step for that purpose.

:func:`compile_batch` traces the same kernel for a batch, whose columns are (N,) arrays: each
operation on a column becomes one NumPy ufunc call writing into a preallocated buffer, and a
buffer is reused as soon as the value it holds is dead. A step then needs a few dozen
buffers that stay in the cache instead of a fresh (N,) array for each of its hundreds of
operations, and no Python bookkeeping between them; the same ufuncs on the same operands in
the same order, so the same numbers bit for bit as the kernel on arrays.
"""

from __future__ import annotations

import math
import operator
import re
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from rigid_env.core import columns


class Deopt(Exception):
    """A guard of a compiled step failed: run the kernel itself for this step."""


def _recorded(symbol: str, fn: Callable, reflected: bool = False) -> Callable:
    """The method of :class:`Sym` for a binary operator: the operation recorded as a line of
    the compiled step, its value computed on the traced run's values."""

    def method(self: Sym, other: Any) -> Any:
        if not isinstance(other, (Sym, float, int)):
            return NotImplemented
        a, b = (other, self) if reflected else (self, other)
        return self.trace.emit(f"{_src(a)} {symbol} {_src(b)}", fn(_val(a), _val(b)))

    return method


class Sym:
    """A traced float: the name of the local that holds it in the compiled step, and its value
    in the traced run."""

    __slots__ = ("name", "trace", "value")

    def __init__(self, trace: Trace, name: str, value: Any) -> None:
        self.trace = trace
        self.name = name
        self.value = value

    # The arithmetic and comparisons of a float, each recorded as one line.
    __add__ = _recorded("+", operator.add)
    __radd__ = _recorded("+", operator.add, reflected=True)
    __sub__ = _recorded("-", operator.sub)
    __rsub__ = _recorded("-", operator.sub, reflected=True)
    __mul__ = _recorded("*", operator.mul)
    __rmul__ = _recorded("*", operator.mul, reflected=True)
    __truediv__ = _recorded("/", operator.truediv)
    __rtruediv__ = _recorded("/", operator.truediv, reflected=True)
    __lt__ = _recorded("<", operator.lt)
    __le__ = _recorded("<=", operator.le)
    __gt__ = _recorded(">", operator.gt)
    __ge__ = _recorded(">=", operator.ge)
    __eq__ = _recorded("==", operator.eq)  # type: ignore[assignment]
    __ne__ = _recorded("!=", operator.ne)  # type: ignore[assignment]

    def __neg__(self):
        return self.trace.emit(f"-{self.name}", -self.value)

    def __abs__(self):
        return self.trace.emit(f"abs({self.name})", abs(self.value))

    def __bool__(self) -> bool:
        """A branch on a traced value: take the traced run's way and guard it."""
        taken = bool(self.value)
        self.trace.guard(self.name if taken else f"not {self.name}")
        return taken

    __hash__ = None  # type: ignore[assignment]


def _src(a: Any) -> str:
    """Source text of an operand: a local's name, or a constant that reads back exactly."""
    if isinstance(a, Sym):
        return a.name
    f = float(a)
    if math.isfinite(f):
        return repr(f)
    return "_NAN" if f != f else ("_INF" if f > 0 else "-_INF")


def _val(a: Any) -> Any:
    return a.value if isinstance(a, Sym) else a


class Trace:
    """The assignments and guards recorded so far. An expression already computed (on the
    same operands) is not computed again: IEEE arithmetic is deterministic, so reusing it
    changes no number."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self._count = 0
        self._known: dict[str, Sym] = {}

    def emit(self, expr: str, value: Any) -> Sym:
        known = self._known.get(expr)
        if known is not None:
            return known
        name = f"t{self._count}"
        self._count += 1
        self.lines.append(f"{name} = {expr}")
        sym = Sym(self, name, value)
        self._known[expr] = sym
        return sym

    def guard(self, condition: str) -> None:
        self.lines.append(f"if not ({condition}): raise Deopt")

    def branch(self, start: int, condition: str, otherwise: str) -> None:
        """Put the lines from ``start`` on under ``if condition:`` with ``otherwise`` as the
        ``else`` branch; their values are then unknown after the ``if`` (not reused)."""
        block = self.lines[start:]
        defined = {line.split(" = ", 1)[0] for line in block}
        self._known = {e: s for e, s in self._known.items() if s.name not in defined}
        self.lines[start:] = [
            f"if {condition}:",
            *(f"    {line}" for line in block),
            "else:",
            f"    {otherwise}",
        ]

    def redefine(self, statement: str, syms: Sequence[Sym], values: Sequence[Any]) -> None:
        """A statement that changes ``syms`` in place (to ``values``): an expression computed
        before it, of them or giving them, is not reused after it."""
        self.lines.append(statement)
        names = {s.name for s in syms}
        self._known = {
            e: s
            for e, s in self._known.items()
            if s.name not in names and names.isdisjoint(_NAMES.findall(e))
        }
        for sym, value in zip(syms, values, strict=True):
            sym.value = value

    def inputs(self, prefix: str, values: Sequence[float]) -> list[Sym]:
        syms = [Sym(self, f"{prefix}{k}", v) for k, v in enumerate(values)]
        if syms:
            self.lines.append(f"{', '.join(s.name for s in syms)}, = {prefix}")
        return syms

    def live_lines(self, result: str) -> list[str]:
        """The lines that ``result`` (an expression) needs: top-level assignments nothing
        reads are dropped; guards and branches are kept."""
        live = set(_NAMES.findall(result))
        kept = []
        for line in reversed(self.lines):
            target, sep, expr = line.partition(" = ")
            if sep and not line.startswith(" ") and _NAMES.fullmatch(target):
                if target not in live:
                    continue
                live.update(_NAMES.findall(expr))
            else:
                live.update(_NAMES.findall(line))
            kept.append(line)
        return kept[::-1]


_NAMES = re.compile(r"\b[a-z]\d+\b")
_TEMPS = re.compile(r"\bt\d+\b")
_DEFINES = re.compile(r"^\s*((?:t\d+, )*t\d+) = ")


def _registers(lines: list[str]) -> list[str]:
    """Rename the temporaries ``t0, t1, ...`` to as few locals ``r0, r1, ...`` as their
    lifetimes allow: a local is reused once the value it holds has been read for the last
    time (the line that reads it last may write it). A step has hundreds of values but only
    a few dozen alive at once; few locals make a small frame, and each float freed at once
    is the next one's memory (about a fifth off a one-body step).

    ``lines`` is straight-line code, with the branches of :meth:`Trace.branch`: a value used
    in a branch (or after it) is alive until its last line, so no branch can lose it."""
    last: dict[str, int] = {}
    for k, line in enumerate(lines):
        for name in _TEMPS.findall(line):
            last[name] = k
    register: dict[str, str] = {}
    free: list[str] = []
    count = 0
    out = []
    for k, line in enumerate(lines):
        match = _DEFINES.match(line)
        defined = _TEMPS.findall(match[1]) if match else []
        for name in set(_TEMPS.findall(line)) - set(defined):
            if last[name] == k and name in register:
                free.append(register[name])
        for name in defined:
            if name in register:  # the other side of a branch
                continue
            if free:
                register[name] = free.pop()
            else:
                register[name], count = f"r{count}", count + 1
        out.append(_TEMPS.sub(lambda m: register.get(m[0], m[0]), line))
    return out


class TraceOps(columns.Ops):
    """The :class:`~rigid_env.core.columns.Ops` of a traced run: the scalar backend's
    functions, written out as operations on traced numbers."""

    scalar = True

    def sqrt(self, a: Any) -> Any:
        if not isinstance(a, Sym):
            return columns.SCALAR.sqrt(a)
        value = columns.SCALAR.sqrt(a.value)
        return a.trace.emit(f"(_sqrt({a.name}) if {a.name} >= 0.0 else _NAN)", value)

    def where(self, cond: Any, a: Any, b: Any) -> Any:
        return a if cond else b

    def half_sincos(self, a: Any, in_range: bool = False) -> tuple[Any, Any, Any]:
        if not isinstance(a, Sym):
            return columns.SCALAR.half_sincos(a)
        # The scalar backend's two branches, both written out: the series, and beyond its
        # range the backend's own function (NumPy's cos and sin).
        trace = a.trace
        start = len(trace.lines)
        sinc = columns.poly(a * a, columns.SIN_SERIES)
        s = a * sinc
        c = trace.emit(f"_sqrt({(1.0 - s * s).name})", 0.0)
        trace.branch(
            start,
            f"abs({a.name}) <= {columns.HALF_ANGLE_MAX!r}",
            f"{c.name}, {s.name}, {sinc.name} = _half_sincos({a.name})",
        )
        c.value, s.value, sinc.value = columns.SCALAR.half_sincos(a.value)
        return c, s, sinc


TRACE = TraceOps()
_GLOBALS = {
    "_sqrt": math.sqrt,
    "_half_sincos": columns.SCALAR.half_sincos,
    "_NAN": math.nan,
    "_INF": math.inf,
    "Deopt": Deopt,
}


def compile_one_body(
    step: Callable[..., Sequence[Sequence[Any]]],
    groups: Sequence[tuple[str, Sequence[float]]],
    name: str = "one_body_step",
) -> Callable[..., tuple[float, ...]]:
    """Trace ``step(ops, *groups)`` once and compile it.

    Args:
        step: called as ``step(TRACE, *lists)`` with one list of traced numbers per group;
            returns a sequence of output lists (floats or traced numbers).
        groups: ``(name, values)`` of each input list; ``values`` are the traced run's inputs
            (a list of floats of the same length is what the compiled step takes).
        name: the compiled function's name (shown in profiles and tracebacks).

    Returns:
        A function of the input lists (positional, in the order of ``groups``) returning the
        outputs as one flat tuple of floats; it raises :class:`Deopt` where the traced run's
        value-dependent branches would go the other way, and whatever Python raises for an
        operation without a float result (a division by zero).
    """
    trace = Trace()
    args = [trace.inputs(prefix, values) for prefix, values in groups]
    outputs = step(TRACE, *args)
    result = f"({', '.join(_src(c) for out in outputs for c in out)},)"
    body = "\n    ".join(_registers([*trace.live_lines(result), f"return {result}"]))
    params = ", ".join(prefix for prefix, _ in groups)
    return _define(f"def {name}({params}):\n    {body}\n", name, _GLOBALS)


def _define(source: str, name: str, globals_: dict[str, Any]) -> Callable[..., Any]:
    """The function ``name`` that ``source`` defines over ``globals_``, with its source kept
    as ``.source`` (for reading and for tests)."""
    namespace = dict(globals_)
    exec(compile(source, f"<{name}>", "exec"), namespace)
    fn = namespace[name]
    fn.source = source  # type: ignore[attr-defined]
    return fn


# --------------------------------------------------------------------------------------------
# A batch: the kernel on (N,) columns, one ufunc call per operation into reused buffers
# --------------------------------------------------------------------------------------------


class ArrayTraceOps(columns.Ops):
    """The :class:`~rigid_env.core.columns.Ops` of a traced batch: the array backend's
    functions written out, its treatment of the few half angles beyond the series' range
    included (:func:`~rigid_env.core.columns.fix_large_half_angles`, called on the buffers)."""

    scalar = False

    def sqrt(self, a: Any) -> Any:
        if not isinstance(a, Sym):
            return columns.ARRAY.sqrt(a)
        with np.errstate(invalid="ignore"):
            value = np.sqrt(a.value)
        return a.trace.emit(f"_sqrt({a.name})", value)

    def where(self, cond: Any, a: Any, b: Any) -> Any:
        raise TypeError("where: a choice per body is not traced for a batch")

    def half_sincos(self, a: Any, in_range: bool = False) -> tuple[Any, Any, Any]:
        if not isinstance(a, Sym):
            return columns.ARRAY.half_sincos(a, in_range)
        sinc = columns.poly(a * a, columns.SIN_SERIES)
        s = a * sinc
        c = self.sqrt(1.0 - s * s)
        if not in_range:
            fixed = [c.value.copy(), s.value.copy(), sinc.value.copy()]
            columns.fix_large_half_angles(a.value, *fixed)
            a.trace.redefine(
                f"_fix_large({a.name}, {c.name}, {s.name}, {sinc.name})", [c, s, sinc], fixed
            )
        return c, s, sinc


ARRAY_TRACE = ArrayTraceOps()


_UFUNCS = {"+": "_add", "-": "_sub", "*": "_mul", "/": "_div"}
_BINARY = re.compile(r"^(\S+) ([-+*/]) (\S+)$")
_UNARY = re.compile(r"^(-|abs\(|_sqrt\()([a-z]\d+)\)?$")
_UNARY_UFUNCS = {"-": "_neg", "abs(": "_abs", "_sqrt(": "_sqrt"}
_BATCH_GLOBALS = {
    "_add": np.add,
    "_sub": np.subtract,
    "_mul": np.multiply,
    "_div": np.divide,
    "_neg": np.negative,
    "_abs": np.absolute,
    "_sqrt": np.sqrt,
    "_copyto": np.copyto,
    "_fix_large": columns.fix_large_half_angles,
    "_NAN": math.nan,
    "_INF": math.inf,
    "Deopt": Deopt,
}


def _buffered(lines: list[str], arrays: set[str], outputs: list[str]) -> tuple[list[str], int]:
    """Rewrite traced assignments on columns as ufunc calls into buffers ``b0, b1, ...``.

    ``arrays`` names the inputs that are (N,) columns; a value computed from one is a column
    too, the rest (the model's floats and constants) stay Python floats. A buffer is taken
    back when the last line that reads its value has read it, so a line may write over its
    own operand (element-wise ufuncs allow it). Returns the lines and the number of buffers.

    Raises:
        TypeError: a line that is not one operation on columns (nothing else is compiled).
    """
    last: dict[str, int] = {}
    for k, line in enumerate(lines):
        for name in _NAMES.findall(line.partition(" = ")[2] or line):
            last[name] = k
    end = len(lines)
    for name in outputs:
        last[name] = end
    buffer_of: dict[str, str] = {}
    free: list[str] = []
    count = 0
    out = []
    for k, line in enumerate(lines):
        target, sep, expr = line.partition(" = ")
        if not sep or not _NAMES.fullmatch(target):  # a guard (or the inputs' unpacking)
            out.append(line)
            continue
        operands = _NAMES.findall(expr)
        if not any(name in arrays for name in operands):
            out.append(line)  # floats only
            continue
        arrays.add(target)
        for name in set(operands):
            if last[name] == k and name in buffer_of:
                free.append(buffer_of.pop(name))
        if free:
            buf = free.pop()
        else:
            buf, count = f"b{count}", count + 1
        buffer_of[target] = buf
        binary = _BINARY.match(expr)
        unary = _UNARY.match(expr)
        if binary:
            call = f"{_UFUNCS[binary[2]]}({binary[1]}, {binary[3]}, {buf})"
        elif unary and (unary[1] == "-" or expr.endswith(")")):
            call = f"{_UNARY_UFUNCS[unary[1]]}({unary[2]}, {buf})"
        else:
            raise TypeError(f"not an operation on columns: {expr}")
        out.append(f"{target} = {call}")
    return out, count


def compile_batch(
    step: Callable[..., Sequence[Sequence[Any]]],
    groups: Sequence[tuple[str, Sequence[Any], bool]],
    name: str = "batch_step",
) -> Callable[..., None]:
    """Trace ``step(ARRAY_TRACE, *lists)`` once on a batch and compile it to ufunc calls into
    reused buffers.

    Args:
        step: called as ``step(ARRAY_TRACE, *lists)`` with one list of traced values per
            group; returns a sequence of output lists.
        groups: ``(name, values, columns)`` of each input list: ``values`` the traced run's
            inputs, ``columns`` whether they are (N,) arrays (else floats, e.g. a shared
            model's mass properties).

    Returns:
        A function ``f(*lists, out, buffers)``: ``lists`` as ``groups``; ``out`` the
        destination of each output component in order, (N,) arrays it fills; ``buffers``
        a sequence of at least ``f.buffers`` float64 arrays of length N (scratch). It raises
        :class:`Deopt` where a guard fails (before anything is written to ``out``).

    Raises:
        TypeError: the step does something other than arithmetic and the functions of
            :class:`ArrayTraceOps` on its columns (it is not compiled).
    """
    trace = Trace()
    args = [trace.inputs(prefix, values) for prefix, values, _ in groups]
    outputs = [c for out in step(ARRAY_TRACE, *args) for c in out]
    srcs = [_src(c) for c in outputs]
    lines = trace.live_lines(f"({', '.join(srcs)},)")
    arrays = {f"{prefix}{k}" for prefix, values, cols in groups if cols for k in range(len(values))}
    body, count = _buffered(lines, arrays, [s for s in srcs if _NAMES.fullmatch(s)])
    unpack = [f"{', '.join(f'b{k}' for k in range(count))}, = buffers[:{count}]"] if count else []
    copies = [f"_copyto(out[{k}], {src})" for k, src in enumerate(srcs)]
    params = ", ".join(prefix for prefix, _, _ in groups)
    source = (
        f"def {name}({params}, out, buffers):\n    "
        + "\n    ".join([*unpack, *body, *copies])
        + "\n"
    )
    fn = _define(source, name, _BATCH_GLOBALS)
    fn.buffers = count  # type: ignore[attr-defined]
    return fn
