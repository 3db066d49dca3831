"""The manual's generated pages: references that are read from the code, so they cannot drift.

At ``builder-inited`` Sphinx calls :func:`write_generated`, which writes Markdown files under
``docs/_generated/`` (not committed) that the pages ``{include}``:

* ``scene_file.md``: every key of a scene file, from the pydantic models of
  :mod:`rigid_env.scene` and :mod:`rigid_env.scene_sections` (type, unit, range, default, doc);
* ``env_kwargs.md`` and ``params_<task>.md``: the keyword arguments every env takes
  (:class:`rigid_env.envs.params.EnvSettings`) and each task's own parameters model;
* ``train_config.md``: a training config (:class:`agents.config.TrainConfig`);
* ``env_<task>.md``: each env class's docstring (Gymnasium's Markdown sections);
* ``integrators.md``: the integrator registry (name, order, stable range, note);
* ``cli.md``: the ``--help`` of every command, from the argparse parsers themselves.

The same functions serve the tests (``tests/docs/``), so a test and the manual read one text.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import inspect
import os
import re
import textwrap
import types
import typing
from pathlib import Path
from typing import Any

import annotated_types
from pydantic import BaseModel
from pydantic.fields import FieldInfo
from pydantic_core import PydanticUndefined

ROOT = Path(__file__).resolve().parents[2]
GENERATED = ROOT / "docs" / "_generated"

#: The scene file's sections, in the order a reader meets them.
SCENE_MODEL = "rigid_env.scene:Scene"
#: Keyword arguments every task takes.
SETTINGS_MODEL = "rigid_env.envs.params:EnvSettings"
#: A training config (``configs/agents/*.yaml``).
TRAIN_MODEL = "agents.config:TrainConfig"


def _load(path: str) -> Any:
    module, _, name = path.partition(":")
    return getattr(importlib.import_module(module), name)


# ---- pydantic models -> tables -------------------------------------------------------------


def _unwrap(annotation: Any) -> tuple[Any, list[Any]]:
    """``Annotated[T, m1, m2]`` -> ``(T, [m1, m2])`` (nested Annotated flattened)."""
    meta: list[Any] = []
    while typing.get_origin(annotation) is typing.Annotated:
        args = typing.get_args(annotation)
        annotation, meta = args[0], [*meta, *args[1:]]
    return annotation, meta


def _is_model(tp: Any) -> bool:
    return isinstance(tp, type) and issubclass(tp, BaseModel)


def _args(tp: Any) -> tuple[Any, ...]:
    return typing.get_args(tp)


def _is_union(tp: Any) -> bool:
    return typing.get_origin(tp) in (typing.Union, types.UnionType)


def type_name(annotation: Any) -> str:
    """A reader's name of a field's type: ``float``, ``[float, float, float]``, ``BodySpec``,
    ``"ideal" | "realistic"``, ``... | None``."""
    tp, _ = _unwrap(annotation)
    if tp is type(None):
        return "None"
    if tp is Any:
        return "any"
    if _is_model(tp):
        return "mapping"
    if _is_union(tp):
        return " | ".join(type_name(a) for a in _args(tp))
    origin = typing.get_origin(tp)
    if origin is typing.Literal:
        return " | ".join(f'"{a}"' if isinstance(a, str) else repr(a) for a in _args(tp))
    if origin is tuple:
        args = _args(tp)
        if len(args) == 2 and args[1] is Ellipsis:
            return f"[{type_name(args[0])}, ...]"
        return "[" + ", ".join(type_name(a) for a in args) + "]"
    if origin in (dict, typing.Dict):  # noqa: UP006
        return "mapping"
    if origin is not None and hasattr(origin, "__name__"):
        return origin.__name__
    if isinstance(tp, type):
        return "path" if issubclass(tp, os.PathLike) else tp.__name__
    return str(tp).replace("typing.", "").replace("os.", "")


def _units(annotation: Any, meta: list[Any]) -> list[str]:
    """Units found on a field (its ``Quantity``) or on its items (a vector's)."""
    found = [m.unit for m in meta if type(m).__name__ == "Quantity" and hasattr(m, "unit")]
    if found:
        return found
    tp, inner = _unwrap(annotation)
    found = [m.unit for m in inner if type(m).__name__ == "Quantity"]
    if found:
        return found
    for arg in _args(tp):
        if arg is not Ellipsis and arg is not type(None):
            found += _units(arg, [])
    return list(dict.fromkeys(found))


_BOUNDS = (
    (annotated_types.Gt, "gt", "> {}"),
    (annotated_types.Ge, "ge", ">= {}"),
    (annotated_types.Lt, "lt", "< {}"),
    (annotated_types.Le, "le", "<= {}"),
    (annotated_types.MinLen, "min_length", "length >= {}"),
    (annotated_types.MaxLen, "max_length", "length <= {}"),
)


def _num(x: Any) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


def _bounds(meta: list[Any]) -> list[str]:
    out = []
    for m in meta:
        for kind, attr, text in _BOUNDS:
            if isinstance(m, kind):
                out.append(text.format(_num(getattr(m, attr))))
        if isinstance(m, FieldInfo):
            out += _bounds(list(m.metadata))
    return out


def range_text(annotation: Any, meta: list[Any]) -> str:
    """The range a field's constraints allow: ``> 0``, ``>= 0, <= 90``, ``each > 0``."""
    own = _bounds(meta)
    tp, inner = _unwrap(annotation)
    own += _bounds(inner)
    if own:
        return ", ".join(own)
    items: list[str] = []
    for arg in _args(tp):
        if arg is Ellipsis or arg is type(None):
            continue
        sub = range_text(arg, [])
        if sub and sub not in items:
            items.append(sub)
    if len(items) == 1 and typing.get_origin(_unwrap(tp)[0]) is tuple:
        return "each " + items[0].removeprefix("each ")
    return "; ".join(items)


def default_text(field: FieldInfo) -> str:
    if field.is_required():
        return "required"
    if field.default_factory is not None:
        value = field.default_factory()
    else:
        value = field.default
    if value is PydanticUndefined:
        return "required"
    if isinstance(value, BaseModel):
        return "(its defaults)"
    if isinstance(value, float):
        return _num(value)
    if value == ():
        return "[]"
    return repr(value) if isinstance(value, str) else str(value)


def _cell(text: str) -> str:
    """One Markdown table cell: one line, ``|`` escaped, Sphinx roles made plain code."""
    text = re.sub(r":[a-z]+:`~?([^`]+)`", r"`\1`", text)
    return " ".join(text.split()).replace("|", "\\|")


def _nested_models(annotation: Any) -> list[type[BaseModel]]:
    tp, _ = _unwrap(annotation)
    if _is_model(tp):
        return [tp]
    out: list[type[BaseModel]] = []
    for arg in _args(tp):
        if arg is not Ellipsis:
            out += _nested_models(arg)
    return out


def field_rows(model: type[BaseModel]) -> list[dict[str, str]]:
    """One row per field of ``model``: key, type, unit, range, default, doc."""
    rows = []
    for name, field in model.model_fields.items():
        annotation = field.annotation
        meta = list(field.metadata)
        rows.append(
            {
                "key": field.alias or name,
                "type": type_name(annotation),
                "unit": ", ".join(u for u in _units(annotation, meta) if u) or "",
                "range": range_text(annotation, meta),
                "default": default_text(field),
                "doc": field.description or "",
            }
        )
    return rows


def model_table(model: type[BaseModel]) -> str:
    """A Markdown table of ``model``'s fields."""
    head = "| key | type | unit | range | default | description |\n|---|---|---|---|---|---|\n"
    lines = [
        "| `{key}` | {type} | {unit} | {range} | {default} | {doc} |".format(
            **{k: _cell(v) for k, v in row.items()}
        )
        for row in field_rows(model)
    ]
    return head + "\n".join(lines) + "\n"


def _first_paragraph(obj: Any) -> str:
    doc = inspect.getdoc(obj) or ""
    return _cell(doc.split("\n\n")[0])


def model_reference(model: type[BaseModel], root: str, level: int = 2) -> str:
    """``model``'s table, then each nested model's (``body.shape``, ...) under its own
    heading, depth first: every key a file of this model may hold."""
    parts: list[str] = []
    seen: set[type[BaseModel]] = set()

    def walk(m: type[BaseModel], path: str) -> None:
        if m in seen:
            return
        seen.add(m)
        title = f"`{path}`" if path else root
        parts.append(f"{'#' * level} {title}\n\n{_first_paragraph(m)}\n\n{model_table(m)}")
        for name, field in m.model_fields.items():
            key = field.alias or name
            for sub in _nested_models(field.annotation):
                list_of = ", ...]" in type_name(field.annotation)
                walk(sub, f"{path}.{key}[k]" if list_of else f"{path}.{key}".lstrip("."))

    walk(model, "")
    return "\n".join(parts)


# ---- environments ----------------------------------------------------------------------------


def env_ids() -> list[str]:
    """The ids of the manual's environment pages: each task's newest id, then the variants."""
    import rigid_env.envs as envs

    ids = list(envs.ENV_IDS)
    return ids + [i for i in envs.ALL_ENV_IDS if i not in ids and not re.search(r"-v\d+$", i)]


def env_class(env_id: str) -> type:
    import gymnasium as gym

    import rigid_env  # noqa: F401

    entry = gym.spec(env_id).entry_point
    module, _, name = str(entry).partition(":")
    return getattr(importlib.import_module(module), name)


def slug(env_id: str) -> str:
    """``RigidEnv/SpinStabilize-v1`` -> ``spin_stabilize``."""
    name = env_id.split("/")[-1].rsplit("-v", 1)[0]
    return re.sub(r"(?<!^)(?=[A-Z])", "_", name).lower()


def env_docstring(cls: type) -> str:
    """The class docstring as Markdown: its ``## Section`` headings one level down (the page
    has the title), Sphinx roles as plain code."""
    doc = inspect.getdoc(cls) or ""
    doc = re.sub(r":[a-z]+:`~?([^`]+)`", r"`\1`", doc)
    return re.sub(r"^## ", "### ", doc, flags=re.M) + "\n"


# ---- command line ----------------------------------------------------------------------------


class _Captured(BaseException):
    """Raised by a patched ``parse_args`` to hand back the parser a ``main`` built."""

    def __init__(self, parser: argparse.ArgumentParser) -> None:
        super().__init__()
        self.parser = parser


@contextlib.contextmanager
def capture_parsers():
    """Within it, ``ArgumentParser.parse_args`` raises :class:`_Captured` with the parser
    (so a ``main`` that builds its parser inside is read without running anything)."""
    original = argparse.ArgumentParser.parse_args

    def parse_args(self, args=None, namespace=None):  # type: ignore[no-untyped-def]
        raise _Captured(self)

    argparse.ArgumentParser.parse_args = parse_args  # type: ignore[method-assign]
    try:
        yield
    finally:
        argparse.ArgumentParser.parse_args = original  # type: ignore[method-assign]


def parser_of(main: Any, argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The parser ``main(argv)`` builds and parses with."""
    with capture_parsers():
        try:
            main(argv or [])
        except _Captured as got:
            return got.parser
    raise RuntimeError(f"{main.__module__}.main parsed nothing")


def commands() -> dict[str, argparse.ArgumentParser]:
    """Every command of the manual: ``rigid-env`` and its subcommands (each benchmark's own
    flags included) and the ``python -m agents.*`` scripts, by the name a user types."""
    from rigid_env import cli

    top = cli.build_parser()
    out: dict[str, argparse.ArgumentParser] = {"rigid-env": top}
    sub = next(a for a in top._actions if isinstance(a, argparse._SubParsersAction))
    for name, parser in sub.choices.items():
        if name == "bench":
            for bench in cli.BENCHMARKS:
                p = cli._Parser(prog=f"rigid-env bench {bench}", description=cli.BENCHMARKS[bench])
                importlib.import_module(f"rigid_env.bench.{bench}").add_arguments(p)
                out[f"rigid-env bench {bench}"] = p
        else:
            out[f"rigid-env {name}"] = parser
    for script in ("train", "evaluate", "baselines", "sweep", "plot_training"):
        module = importlib.import_module(f"agents.{script}")
        out[f"python -m agents.{script}"] = parser_of(module.main)
    return out


def help_text(parser: argparse.ArgumentParser, width: int = 90) -> str:
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(width)
    try:
        return parser.format_help()
    finally:
        if old is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = old


def cli_reference() -> str:
    parts = []
    for name, parser in commands().items():
        parts.append(f"## `{name}`\n\n```text\n{help_text(parser).rstrip()}\n```\n")
    return "\n".join(parts)


# ---- integrators ----------------------------------------------------------------------------


def integrator_table() -> str:
    """The integrator registry (``rigid_env.core.integrators.INTEGRATORS``) as a table."""
    from rigid_env.core.integrators import INTEGRATORS
    from rigid_env.core.wheels import WHEEL_STEPS

    lines = [
        "| name | order | error control | warns beyond h\\|w\\| [rad] | reaction wheels | note |",
        "|---|---|---|---|---|---|",
    ]
    for info in INTEGRATORS.values():
        stable = "-" if info.stability is None else _num(info.stability)
        control = "yes (`rtol`, `atol`)" if info.error_control else "no"
        wheels = "yes" if info.name in WHEEL_STEPS else "refused"
        lines.append(
            f"| `{info.name}` | {info.order} | {control} | {stable} | {wheels} | "
            f"{_cell(info.note)} |"
        )
    return "\n".join(lines) + "\n"


# ---- the files -------------------------------------------------------------------------------


def generated_files() -> dict[str, str]:
    """Every generated page, by file name under ``docs/_generated``."""
    files = {
        "scene_file.md": model_reference(_load(SCENE_MODEL), "Top level", level=2),
        "env_kwargs.md": model_reference(_load(SETTINGS_MODEL), "Every env", level=2),
        "train_config.md": model_reference(_load(TRAIN_MODEL), "Top level", level=2),
        "cli.md": cli_reference(),
        "integrators.md": integrator_table(),
    }
    for env_id in env_ids():
        cls = env_class(env_id)
        files[f"env_{slug(env_id)}.md"] = env_docstring(cls)
        params = cls.task_cls.params_model
        files[f"params_{slug(env_id)}.md"] = model_table(params)
    return files


def write_generated(app: Any = None) -> None:
    """Write :func:`generated_files` (only files whose text changed, so Sphinx rebuilds only
    what changed)."""
    GENERATED.mkdir(exist_ok=True)
    for name, text in generated_files().items():
        path = GENERATED / name
        if not path.exists() or path.read_text() != text:
            path.write_text(text)


def setup(app: Any) -> dict[str, Any]:
    app.connect("builder-inited", write_generated)
    return {"parallel_read_safe": True, "version": "1"}


if __name__ == "__main__":  # python docs/_ext/rigid_docs.py: print what would be written
    for file, body in generated_files().items():
        print(f"==> {file}\n{textwrap.shorten(body, 300)}")
