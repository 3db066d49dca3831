"""Configuration files: YAML read safely into a frozen pydantic model, every error in one line.

    cfg = load_model(TrainConfig, "configs/agents/ppo_detumble.yaml")

Reading is PyYAML's safe loader with two changes, so that a file means what its author wrote:
a key given twice in one mapping is an error, in block and flow style alike (PyYAML silently
keeps the last one; the check compares the keys themselves, so ``{mass: 1, mass: 2}`` on one
line and ``1`` beside ``1.0`` count), and ``1e-4``, ``1e5`` and
``1.0e5`` are floats (YAML 1.1 reads a number without a dot or an exponent sign as a string;
YAML 1.2 and JSON read it as a number). Validation is pydantic v2's; the first problem becomes
one line, ``file: field.path: problem; fix``, the fix taken from the field's docstring unless
a validator gives one. Validators name a field below the one they check, and the fix, by
raising :class:`FieldError`; a plain ``ValueError("problem; fix")`` works too.

The training config (:mod:`agents.config`), the scene file (:mod:`rigid_env.scene`) and the
sweep file (:mod:`agents.sweep`) are read this way.
"""

from __future__ import annotations

import difflib
import math
import os
import re
import stat
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, TypeVar, get_args, get_origin

import yaml
from pydantic import BaseModel, BeforeValidator, Field, ValidationError

Model = TypeVar("Model", bound=BaseModel)


def describe(value: Any) -> str:
    """How a value read from a file reads in a message (``the string '1e5'``, ``a list of
    2``, ``nothing (null)``)."""
    if value is None:
        return "nothing (null)"
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, str):
        return f"the string {value!r}"
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list | tuple):
        return f"a list of {len(value)}"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def yaml_float(x: float) -> str:
    """``x`` written so that any YAML reader takes a float: a dot in the mantissa and a signed
    exponent (``1.0e+5``, ``2.5e-3``)."""
    mantissa, exponent = f"{x:e}".split("e")
    mantissa = mantissa.rstrip("0")
    if mantissa.endswith("."):
        mantissa += "0"
    return f"{mantissa}e{int(exponent):+d}"


def number(unit: str = "") -> BeforeValidator:
    """A validator that lets only an int or a float through, so that pydantic's lax mode never
    takes ``"1e6"``, ``"0.02"`` or ``true`` for a number; the message names ``unit``. (An
    integral float such as ``1e5`` still counts as an integer.)"""
    unit_s = f" [{unit}]" if unit else ""

    def check(value: Any) -> Any:
        if isinstance(value, int | float) and not isinstance(value, bool):
            return value
        got = f"expected a number{unit_s}, got {describe(value)}"
        if not isinstance(value, str):
            raise ValueError(f"{got}; write a number{unit_s}")
        try:
            parsed = float(value.replace("_", ""))
        except ValueError:
            raise ValueError(f"{got}; write a number{unit_s} without quotes") from None
        if not math.isfinite(parsed):
            raise ValueError(f"must be finite, got {describe(value)}; give a finite number{unit_s}")
        # One message for every quoted number. With an exponent the number is suggested in a
        # form any YAML reader takes for a float (PyYAML's own loader, YAML 1.1, reads 1e5 and
        # 3.986e14 as text).
        integral = re.fullmatch(r"[-+]?[0-9][0-9_]*", value.strip())
        written = (
            str(int(parsed))
            if integral
            else yaml_float(parsed)
            if "e" in value.lower()
            else repr(parsed)
        )
        raise ValueError(f"{got}; write the number without quotes: {written}")

    return BeforeValidator(check)


def vector(n: int, unit: str = "", example: str = "") -> BeforeValidator:
    """A validator that lets only a list (or tuple) of ``n`` items through, with a message that
    says how many numbers belong there (pydantic would report the first missing index)."""
    unit_s = f" [{unit}]" if unit else ""
    example = example or f"[{', '.join(['0.0'] * n)}]"

    def check(value: Any) -> Any:
        if isinstance(value, list | tuple) and len(value) == n:
            return value
        raise ValueError(
            f"expected a list of {n} numbers{unit_s}, got {describe(value)}; "
            f"write {n} numbers like {example}"
        )

    return BeforeValidator(check)


Number = number()
Finite = Annotated[float, Number, Field(allow_inf_nan=False)]
"""A finite float (no ``.nan``, ``.inf``)."""
PositiveFloat = Annotated[float, Number, Field(gt=0, allow_inf_nan=False)]
"""A finite float > 0."""
NonNegativeFloat = Annotated[float, Number, Field(ge=0, allow_inf_nan=False)]
"""A finite float >= 0."""
Fraction = Annotated[float, Number, Field(gt=0, le=1, allow_inf_nan=False)]
"""A finite float in (0, 1]."""
PositiveInt = Annotated[int, Number, Field(ge=1)]
"""An integer >= 1."""
NonNegativeInt = Annotated[int, Number, Field(ge=0)]
"""An integer >= 0."""


class ConfigFileError(ValueError):
    """A configuration that cannot be used: ``"<file>: <field>: <problem>; <fix>"``, one line
    (or, given only its first argument, that whole message)."""

    def __init__(self, source: str, path: str = "", problem: str = "", fix: str = "") -> None:
        self.source, self.path = source, path
        self.problem, self.fix = _one_line(problem), _one_line(fix)
        if not problem:
            super().__init__(_one_line(source))
            return
        where = f"{source}: {path}: " if path else f"{source}: "
        super().__init__(f"{where}{self.problem}; {self.fix}")


class FieldError(ValueError):
    """Raised by a validator: ``path`` (dotted, below the model it validates), problem, fix;
    ``more``: how many further problems the same check found (counted in "(and N more)");
    ``unknown``: the problem is a key that is not allowed there (named before other problems).
    """

    def __init__(
        self, path: str, problem: str, fix: str, more: int = 0, unknown: bool = False
    ) -> None:
        self.path, self.problem, self.fix = path, problem, fix
        self.more, self.unknown = more, unknown
        super().__init__(f"{path}: {problem}; {fix}")


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


class _Loader(yaml.SafeLoader):
    """Safe loader that refuses duplicate keys and reads ``1e-4`` as a float."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        """The mapping, after checking the keys this node itself writes (block or flow style
        alike; keys that a merge ``<<: *anchor`` brings in may be overridden, as YAML says)."""
        seen: dict[Any, tuple[int, yaml.Mark]] = {}
        for index, (key_node, _) in enumerate(node.value):
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self.construct_object(key_node, deep=True)
            try:
                first_index, first = seen.setdefault(key, (index, key_node.start_mark))
            except TypeError:  # an unhashable key: PyYAML's own error follows
                continue
            if first_index != index:
                mark = key_node.start_mark
                raise yaml.constructor.ConstructorError(
                    None,
                    None,
                    f"key {key!r} given twice, at column {mark.column + 1} and before at "
                    f"line {first.line + 1}, column {first.column + 1}",
                    mark,
                )
        return super().construct_mapping(node, deep=deep)


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."),
)


MAX_FILE_BYTES = 16 * 2**20
"""The largest configuration or scene file read [bytes]: hand-written YAML is kilobytes; more is
the wrong file (a log, a model, /dev/zero)."""


def _read_text(path: Path, name: str) -> str:
    """The UTF-8 text of a regular file of at most :data:`MAX_FILE_BYTES` (a device, a pipe or
    a huge file is refused before reading: /dev/zero would fill memory, a FIFO never end)."""
    mode = path.stat().st_mode  # FileNotFoundError, PermissionError: the caller's messages
    if stat.S_ISDIR(mode):
        raise IsADirectoryError(path)
    if not stat.S_ISREG(mode):
        raise ConfigFileError(
            name, "", "is not a regular file (a device, a pipe or a socket)", "give a YAML file"
        )
    with path.open("rb") as f:
        data = f.read(MAX_FILE_BYTES + 1)
    if len(data) > MAX_FILE_BYTES:
        raise ConfigFileError(
            name, "", f"is larger than {MAX_FILE_BYTES // 2**20} MiB, too large for a YAML "
            "configuration", "give the YAML file (the wrong file?)",
        )  # fmt: skip
    return data.decode("utf-8")


def read_yaml(path: str | os.PathLike[str], name: str | None = None) -> Any:
    """The data in a YAML file (``None`` for an empty one); errors call it ``name`` (default:
    the path).

    Raises:
        ConfigFileError: the file is missing, unreadable, not YAML or has a duplicate key.
    """
    name = str(path) if name is None else name
    try:
        text = _read_text(Path(path), name)
    except FileNotFoundError:
        raise ConfigFileError(name, "", "file not found", "check the path") from None
    except IsADirectoryError:
        raise ConfigFileError(name, "", "is a directory", "give the path of a YAML file") from None
    except UnicodeDecodeError:
        raise ConfigFileError(name, "", "is not UTF-8 text", "give a YAML file") from None
    except OSError as exc:
        raise ConfigFileError(
            name, "", f"cannot be read ({exc.strerror})", "check the path and its permissions"
        ) from None
    try:
        loader = _Loader(text)  # a SafeLoader subclass: only plain YAML types are built
        try:
            return loader.get_single_data()
        finally:
            loader.dispose()
    except yaml.reader.ReaderError as exc:  # a control character (NUL, ...) in the text
        line = text.count("\n", 0, exc.position) + 1
        column = exc.position - (text.rfind("\n", 0, exc.position) + 1) + 1
        char = f"U+{exc.character:04X}" if isinstance(exc.character, int) else "a byte"
        raise ConfigFileError(
            name,
            f"line {line}",
            f"the control character {char} at column {column} is not allowed in YAML",
            "remove it (a file saved in a binary format?)",
        ) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or "invalid YAML"
        if "given twice" in problem:
            raise ConfigFileError(name, where, problem, "keep one") from None
        column = f" (column {mark.column + 1})" if mark is not None else ""
        raise ConfigFileError(
            name, where, f"YAML error: {problem}{column}", "fix the YAML syntax at that line"
        ) from None


def validate(model: type[Model], data: Any, source: str) -> Model:
    """``model`` built from ``data``; the first problem as a :class:`ConfigFileError`."""
    if not isinstance(data, dict):
        kind = "nothing" if data is None else f"a {type(data).__name__}"
        raise ConfigFileError(
            source,
            "top level",
            f"expected a mapping of keys, but the file holds {kind}",
            "write one `key: value` per line",
        )
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise error_line(exc, model, source) from None


def load_model(
    model: type[Model],
    source: str | os.PathLike[str] | dict[str, Any],
    overrides: dict[str, Any] | None = None,
    name: str | None = None,
) -> Model:
    """Read a YAML file (or take a dict), apply top-level ``overrides`` and validate it into
    ``model``; errors call the source ``name`` (default: the path, or ``<config>``)."""
    if isinstance(source, dict):
        name, data = name or "<config>", dict(source)
    else:
        name = name or str(source)
        data = read_yaml(source, name)
    if overrides and isinstance(data, dict | type(None)):
        data = {**(data or {}), **overrides}
    return validate(model, data, name)


# --------------------------------------------------------------------------------------------
# pydantic's errors as one line
# --------------------------------------------------------------------------------------------

_PROBLEMS: dict[str, Callable[[dict[str, Any]], str]] = {
    "greater_than": lambda c: f"must be greater than {_bound(c['gt'])}",
    "greater_than_equal": lambda c: f"must be greater than or equal to {_bound(c['ge'])}",
    "less_than": lambda c: f"must be less than {_bound(c['lt'])}",
    "less_than_equal": lambda c: f"must be less than or equal to {_bound(c['le'])}",
    "finite_number": lambda c: "must be finite",
    "int_from_float": lambda c: "must be an integer",
    "int_type": lambda c: "expected an integer",
    "int_parsing": lambda c: "expected an integer",
    "float_type": lambda c: "expected a number",
    "string_type": lambda c: "expected a string",
    "bool_type": lambda c: "expected true or false",
    "model_type": lambda c: "expected a mapping",
    "dict_type": lambda c: "expected a mapping",
    "model_attributes_type": lambda c: "expected a mapping",
    "list_type": lambda c: "expected a list",
    "tuple_type": lambda c: "expected a list",
    "too_short": lambda c: f"expected at least {c['min_length']} item(s)",
    "too_long": lambda c: f"expected at most {c['max_length']} item(s)",
    "string_too_short": lambda c: f"expected at least {c['min_length']} character(s)",
}
"""Problem texts for pydantic's error types (the rest keep pydantic's own message)."""


def _bound(x: float) -> str:
    """A constraint's bound as written: an integer in full (``4294967295``), a float short."""
    return str(x) if isinstance(x, int) else f"{x:g}"


def error_line(exc: ValidationError, model: type[BaseModel], source: str) -> ConfigFileError:
    """One line for all of ``exc``'s problems: the one most likely to be the real mistake, with
    its fix, and how many more there are.

    An unknown key (the usual typo) comes first, with the allowed key nearest to it; a missing
    key that is that nearest key is the same mistake, not one more. The rest follow in field
    order. Every problem counts once in "(and N more)", including those a validator found
    besides the one it raised (:attr:`FieldError.more`).
    """
    errors = exc.errors()
    unknown = [e for e in errors if _is_unknown_key(e)]
    suggestions = {(tuple(_field_path(e["loc"])[:-1]), _suggest(model, e)) for e in unknown} - {
        (None, None)
    }
    first = (unknown or errors)[0]
    paths = set()
    extra = 0
    for e in errors:
        loc = _field_path(e["loc"])
        if e["type"] == "missing" and (tuple(loc[:-1]), loc[-1]) in suggestions:
            continue  # `bdy` for `body`: one mistake, named by the unknown key
        paths.add(tuple(loc))
        cause = (e.get("ctx") or {}).get("error")
        extra += cause.more if isinstance(cause, FieldError) else 0
    count = len(paths - {tuple(_field_path(first["loc"]))}) + extra
    return _render(first, model, source, f" (and {count} more)" if count else "")


def _is_unknown_key(err: Any) -> bool:
    cause = (err.get("ctx") or {}).get("error")
    return err["type"] in ("extra_forbidden", "invalid_key") or (
        isinstance(cause, FieldError) and cause.unknown
    )


def _key_text(key: Any) -> str:
    """A key as the file would write it (``true``, ``1``, ``null``)."""
    if isinstance(key, str):
        return key
    return "null" if key is None else str(key).lower() if isinstance(key, bool) else repr(key)


def _kind_of(value: Any) -> str:
    """What YAML made of a plain scalar: ``a number``, ``a boolean``, ``nothing (null)``."""
    if value is None:
        return "nothing (null)"
    if isinstance(value, bool):
        return "a boolean"
    return "a number" if isinstance(value, int | float) else f"a {type(value).__name__}"


def _suggest(model: type[BaseModel], err: Any) -> str | None:
    """The allowed key nearest to an unknown one (``bdy`` -> ``body``), if any is near."""
    loc = _field_path(err["loc"])
    key = err["input"] if err["type"] == "invalid_key" else loc[-1]
    allowed = _fields_at(model, loc[:-1])
    near = difflib.get_close_matches(_key_text(key).lower(), allowed, n=1, cutoff=0.6)
    return near[0] if near else None


def _render(err: Any, model: type[BaseModel], source: str, more: str) -> ConfigFileError:
    """One pydantic error as ``file: field.path: problem; fix`` + ``more``."""
    loc = _field_path(err["loc"])
    ctx = err.get("ctx") or {}
    cause = ctx.get("error")
    if isinstance(cause, FieldError):
        return ConfigFileError(source, _dotted([*loc, cause.path]), cause.problem, cause.fix + more)
    kind, msg = err["type"], err["msg"]
    if kind in ("extra_forbidden", "invalid_key"):
        allowed = _fields_at(model, loc[:-1])
        near = _suggest(model, err)
        hint = f"did you mean {near}? " if near else ""
        keys = f"allowed keys: {', '.join(allowed)}" if allowed else "see the documentation"
        if kind == "extra_forbidden":
            return ConfigFileError(source, _dotted(loc), "unknown key", f"{hint}{keys}{more}")
        key = err["input"]
        where = _dotted(loc[:-1]) or "top level"
        return ConfigFileError(
            source,
            where,
            f"the key {_key_text(key)} is not a name (YAML read it as {_kind_of(key)})",
            f"{hint}write a name (quote it if it is meant as one); {keys}{more}",
        )
    meaning = _description(model, loc)
    if kind == "missing":
        parent = _dotted(loc[:-1])
        fix = f"add {loc[-1]}" + (f" to {parent}" if parent else " at the top level")
        fix += f" ({meaning})" if meaning else ""
        return ConfigFileError(source, _dotted(loc), "missing required key", fix + more)
    if msg.startswith(("Value error, ", "Assertion failed, ")):
        problem, _, fix = msg.split(", ", 1)[1].partition("; ")
        return ConfigFileError(source, _dotted(loc), problem, (fix or "fix the value") + more)
    render = _PROBLEMS.get(kind)
    text = render(ctx) if render is not None else f"{msg[0].lower()}{msg[1:]}"
    name = next((part for part in reversed(loc) if not part.isdigit()), "it")
    fix = f"{name} is: {meaning}" if meaning else "fix the value"
    got = err["input"]
    got_text = repr(got) if isinstance(got, int | float) and not isinstance(got, bool) else None
    return ConfigFileError(
        source, _dotted(loc), f"{text}, got {got_text or describe(got)}", fix + more
    )


def _field_path(loc: tuple[int | str, ...]) -> list[str]:
    """``loc`` without the tags pydantic adds for a union's members (``list[int]``,
    ``constrained-int``, ``function-after[...]``): field names, keys and indices only."""
    return [str(p) for p in loc if isinstance(p, int) or not re.search(r"[\[\]-]", p)]


def _dotted(loc: list[str]) -> str:
    out = ""
    for part in loc:
        if not part:
            continue
        out += f"[{part}]" if part.isdigit() else (f".{part}" if out else part)
    return out


def _field(model: Any, key: str) -> Any:
    """The field of ``model`` that the file calls ``key`` (its alias or its name)."""
    if not _is_model(model):
        return None
    for name, field in model.model_fields.items():
        if key in (field.alias, name):
            return field
    return None


def _model_at(model: type[BaseModel], loc: list[str]) -> type[BaseModel] | None:
    """The model class that the field path ``loc`` leads to (``None`` if it leaves models)."""
    current: Any = model
    for part in loc:
        if part.isdigit():  # an item of a list of models
            continue
        field = _field(current, part)
        if field is None:
            return None
        current = next((t for t in _types_in(field.annotation) if _is_model(t)), None)
    return current if _is_model(current) else None


def _types_in(annotation: Any) -> list[Any]:
    if get_origin(annotation) is None:
        return [annotation]
    return [t for arg in get_args(annotation) for t in _types_in(arg)]


def _is_model(obj: Any) -> bool:
    return isinstance(obj, type) and issubclass(obj, BaseModel)


def _fields_at(model: type[BaseModel], loc: list[str]) -> list[str]:
    found = _model_at(model, loc)
    if found is None:
        return []
    return [field.alias or name for name, field in found.model_fields.items()]


def _description(model: type[BaseModel], loc: list[str]) -> str:
    """The first sentence of the docstring of the field at ``loc``, lower-cased."""
    while loc and loc[-1].isdigit():  # an item of a list field: the list's description
        loc = loc[:-1]
    found = _model_at(model, loc[:-1]) if loc else None
    field = _field(found, loc[-1]) if found is not None else None
    text = _one_line(field.description or "") if field is not None else ""
    text = re.split(r"\.\s+(?=[A-Z])", text.replace("``", ""))[0].rstrip(".")
    return text[:1].lower() + text[1:] if text[1:2].islower() else text
