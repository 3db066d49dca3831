"""Configuration files: YAML read safely into a frozen pydantic model, every error in one line.

    cfg = load_model(TrainConfig, "configs/agents/ppo_detumble.yaml")

Reading is PyYAML's safe loader with two changes, so that a file means what its author wrote:
a key given twice is an error (PyYAML silently keeps the last one), and ``1e-4``, ``1e5`` and
``1.0e5`` are floats (YAML 1.1 reads a number without a dot or an exponent sign as a string;
YAML 1.2 and JSON read it as a number). Validation is pydantic v2's; the first problem becomes
one line, ``file: field.path: problem; fix``. Validators name a field below the one they check,
and the fix, by raising :class:`FieldError`; a plain ``ValueError("problem; fix")`` works too.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Annotated, Any, TypeVar, get_args, get_origin

import yaml
from pydantic import BaseModel, BeforeValidator, Field, ValidationError

Model = TypeVar("Model", bound=BaseModel)


def _number(value: Any) -> Any:
    """Refuse text and booleans where a number belongs (pydantic's lax mode would take
    ``"1e6"`` and ``true``); an integral float such as ``1e5`` still counts as an integer."""
    if isinstance(value, str | bool):
        raise ValueError(
            f"expected a number, got {value!r}; write a number without quotes, e.g. 1.0e-4"
        )
    return value


Number = BeforeValidator(_number)
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
    """Raised by a validator: ``path`` (dotted, below the model it validates), problem, fix."""

    def __init__(self, path: str, problem: str, fix: str) -> None:
        self.path, self.problem, self.fix = path, problem, fix
        super().__init__(f"{path}: {problem}; {fix}")


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


class _Loader(yaml.SafeLoader):
    """Safe loader that refuses duplicate keys and reads ``1e-4`` as a float."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            try:
                first = seen.setdefault(key, key_node.start_mark.line)
            except TypeError:  # an unhashable key: PyYAML's own error follows
                continue
            if first != key_node.start_mark.line:
                raise yaml.constructor.ConstructorError(
                    None,
                    None,
                    f"key {key!r} given twice (first at line {first + 1})",
                    key_node.start_mark,
                )
        return super().construct_mapping(node, deep=deep)


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."),
)


def read_yaml(path: str | os.PathLike[str]) -> Any:
    """The data in a YAML file (``None`` for an empty one).

    Raises:
        ConfigFileError: the file is missing, unreadable, not YAML or has a duplicate key.
    """
    name = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigFileError(name, "", "file not found", "check the path") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigFileError(name, "", f"cannot read it ({exc})", "check the file") from None
    try:
        return yaml.load(text, Loader=_Loader)  # a SafeLoader subclass
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or "YAML syntax error"
        fix = "keep one" if "given twice" in problem else "fix the YAML syntax"
        raise ConfigFileError(name, where, problem, fix) from None


def validate(model: type[Model], data: Any, source: str) -> Model:
    """``model`` built from ``data``; the first problem as a :class:`ConfigFileError`."""
    if not isinstance(data, dict):
        kind = "nothing" if data is None else f"a {type(data).__name__}"
        raise ConfigFileError(
            source, "", f"holds {kind}, not a mapping of keys", "write one `key: value` per line"
        )
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise error_line(exc, model, source) from None


def load_model(
    model: type[Model],
    source: str | os.PathLike[str] | dict[str, Any],
    overrides: dict[str, Any] | None = None,
    name: str = "<config>",
) -> Model:
    """Read a YAML file (or take a dict, called ``name`` in errors), apply top-level
    ``overrides`` and validate it into ``model``."""
    if isinstance(source, dict):
        data: Any = dict(source)
    else:
        name, data = str(source), read_yaml(source)
    if overrides and isinstance(data, dict | type(None)):
        data = {**(data or {}), **overrides}
    return validate(model, data, name)


def error_line(exc: ValidationError, model: type[BaseModel], source: str) -> ConfigFileError:
    """The first error of ``exc`` as one line: where, what, and what to do."""
    errors = exc.errors()
    err = errors[0]
    loc = _field_path(err["loc"])
    others = {tuple(_field_path(e["loc"])) for e in errors} - {tuple(loc)}
    more = f" (and {len(others)} more)" if others else ""
    cause = (err.get("ctx") or {}).get("error")
    if isinstance(cause, FieldError):
        return ConfigFileError(source, _dotted([*loc, cause.path]), cause.problem, cause.fix + more)
    kind, msg = err["type"], err["msg"]
    got = repr(err["input"])
    got = got if len(got) <= 60 else got[:57] + "..."
    if kind == "extra_forbidden":
        keys = ", ".join(_fields_at(model, loc[:-1])) or "see the documentation"
        return ConfigFileError(source, _dotted(loc), "unknown key", f"allowed keys: {keys}{more}")
    if kind == "missing":
        return ConfigFileError(source, _dotted(loc), "required key is missing", "add it" + more)
    if msg.startswith(("Value error, ", "Assertion failed, ")):
        problem, _, fix = msg.split(", ", 1)[1].partition("; ")
        return ConfigFileError(source, _dotted(loc), problem, (fix or "fix the value") + more)
    meaning = _description(model, loc)
    fix = f"{loc[-1] if loc else 'it'} is: {meaning}" if meaning else "fix the value"
    problem = f"{msg[0].lower()}{msg[1:]}, got {got}"
    return ConfigFileError(source, _dotted(loc), problem, fix + more)


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


def _model_at(model: type[BaseModel], loc: list[str]) -> type[BaseModel] | None:
    """The model class that the field path ``loc`` leads to (``None`` if it leaves models)."""
    current: Any = model
    for part in loc:
        field = current.model_fields.get(part) if _is_model(current) else None
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
    return list(found.model_fields) if found is not None else []


def _description(model: type[BaseModel], loc: list[str]) -> str:
    """The first sentence of the docstring of the field at ``loc``, lower-cased."""
    while loc and loc[-1].isdigit():  # an item of a list field: the list's description
        loc = loc[:-1]
    found = _model_at(model, loc[:-1]) if loc else None
    field = found.model_fields.get(loc[-1]) if found is not None else None
    text = _one_line(field.description or "") if field is not None else ""
    text = re.split(r"\.\s+(?=[A-Z])", text.replace("``", ""))[0].rstrip(".")
    return text[:1].lower() + text[1:] if text[1:2].islower() else text
