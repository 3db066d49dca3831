"""The benchmarks' one report module: the machine, the output folder, Markdown, CSV, figures.

A benchmark measures and says what its tables and panels show; this module writes them:

* :func:`prepare_out` checks ``--out`` (a folder; earlier results only with ``--force``);
* :func:`machine`, :func:`versions`, :func:`cores`, :func:`load` describe the run's machine;
* :class:`Section` (a heading, paragraphs, captioned tables) and :func:`markdown` the text;
* :func:`write_csv` one row per dataclass instance;
* :class:`Panel` and :func:`write_figure` a figure of panels, each lines (log axes, markers,
  guides) or bars. matplotlib is imported only when a figure is written.
"""

from __future__ import annotations

import csv
import math
import os
import platform
from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from rigid_env.resources import folder_problem

# --------------------------------------------------------------------------------------------
# The machine and the output folder
# --------------------------------------------------------------------------------------------


def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo`` on Linux, else ``platform.processor()``)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown CPU"


def cores() -> str:
    """``"2 logical cores"`` (and how many this process may use, if fewer)."""
    total = os.cpu_count() or 0
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = total
    return f"{total} logical cores" + (f" ({usable} usable)" if usable != total else "")


def machine() -> str:
    """One line: CPU model, cores, OS and architecture."""
    return f"{cpu_model()}, {cores()}, {platform.system()} {platform.machine()}"


def versions(*dists: str) -> str:
    """``Python 3.11.7, numpy 2.4.6, ...``: Python's and each distribution's version, read
    without importing it (torch is slow to import)."""
    from importlib.metadata import PackageNotFoundError, version

    parts = [f"Python {platform.python_version()}"]
    for dist in ("numpy", *dists):
        try:
            parts.append(f"{dist} {version(dist)}")
        except PackageNotFoundError:
            parts.append(f"{dist} not installed")
    return ", ".join(parts)


def load() -> str:
    """The load averages over 1, 5 and 15 minutes (``n/a`` where the OS has none)."""
    try:
        return " / ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "n/a"


def prepare_out(out: Path, names: Sequence[str], force: bool) -> Path:
    """``out`` made ready for the files ``names``: a folder, created if missing.

    Raises:
        ValueError: ``out`` is a file, or holds earlier results and ``force`` is not set (one
            line naming the files and the fix).
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out: {out} is a file; give a folder for {', '.join(names)}")
    there = [name for name in names if (out / name).exists()]
    if there and not force:
        raise ValueError(
            f"--out: {out} holds earlier results ({', '.join(there)}); pass --force to "
            "overwrite them, or choose another --out"
        )
    problem = folder_problem(out / "results")
    if problem is not None:
        raise ValueError(f"--out: cannot create {out}: {problem}; choose another folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise ValueError(
            f"--out: cannot create {out} ({reason} at {exc.filename}); give a folder whose "
            "parents exist or can be created"
        ) from None
    return out


# --------------------------------------------------------------------------------------------
# Markdown
# --------------------------------------------------------------------------------------------


def si(x: float, digits: int = 3) -> str:
    """``1234567 -> '1.23 M'`` (``-`` if not finite)."""
    if not math.isfinite(x):
        return "-"
    for scale, suffix in ((1e9, " G"), (1e6, " M"), (1e3, " k")):
        if abs(x) >= scale:
            return f"{x / scale:.{digits}g}{suffix}"
    return f"{x:.{digits}g}"


def times(r: float) -> str:
    """A ratio: ``'2.82x'``, ``'548x'`` (``-`` if not finite)."""
    return "-" if not math.isfinite(r) else (f"{r:.3g}x" if r < 100 else f"{r:.0f}x")


@dataclass
class Table:
    """A Markdown table: a header, rows of cells, one ``l``/``r`` per column (default: the
    first left, the others right), and an optional caption paragraph above it."""

    header: Sequence[str]
    rows: Sequence[Sequence[str]]
    align: str = ""
    caption: str = ""

    def lines(self) -> list[str]:
        """The caption (if any), the header, the rule and the rows."""
        align = self.align or "l" + "r" * (len(self.header) - 1)
        out = [self.caption, ""] if self.caption else []
        out += [
            "| " + " | ".join(self.header) + " |",
            "|" + "|".join("---" if a == "l" else "---:" for a in align) + "|",
        ]
        return out + ["| " + " | ".join(row) + " |" for row in self.rows]


@dataclass
class Section:
    """A ``##`` section: its heading, paragraphs, tables (in order) and closing paragraphs."""

    title: str
    notes: list[str] = field(default_factory=list)
    tables: list[Table] = field(default_factory=list)
    after: list[str] = field(default_factory=list)

    def lines(self) -> list[str]:
        """The section as Markdown lines."""
        out = [f"## {self.title}", ""]
        out += [line for note in self.notes for line in (note, "")]
        for t in self.tables:
            out += [*t.lines(), ""]
        return out + [line for note in self.after for line in (note, "")]


def markdown(title: str, header: Sequence[str], sections: Sequence[Section]) -> str:
    """A report: ``# title``, the header paragraphs or ``-`` lines, then the sections."""
    out = [f"# {title}", "", *header, ""]
    for s in sections:
        out += s.lines()
    return "\n".join(out).rstrip("\n") + "\n"


# --------------------------------------------------------------------------------------------
# CSV
# --------------------------------------------------------------------------------------------


def write_csv(path: Path, rows: Sequence[Any], columns: Sequence[str] | None = None) -> None:
    """One line per dataclass instance of ``rows`` (columns: its fields, or ``columns``);
    floats with 6 significant digits."""
    if columns is None:
        columns = [f.name for f in fields(rows[0])] if rows else []
    with open(path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(columns)
        for r in rows:
            values = (getattr(r, c) for c in columns)
            writer.writerow([f"{v:.6g}" if isinstance(v, float) else v for v in values])


# --------------------------------------------------------------------------------------------
# Figures
# --------------------------------------------------------------------------------------------


@dataclass
class Series:
    """One line of a ``lines`` panel, or one group of bars of a ``bars`` panel.

    Attributes:
        label: legend entry ("" for none).
        x, y: the points (a line: x values; bars: ignored, the panel's categories).
        style: matplotlib format, e.g. ``"o-"``, ``"s--"``, ``"x"``.
        color: matplotlib colour (None: the colour cycle).
        width: line width [pt]; size: marker size [pt].
        hollow: open markers.
        notes: text written at the end of each bar.
    """

    label: str
    x: Sequence[float]
    y: Sequence[float]
    style: str = "o-"
    color: Any = None
    width: float = 1.3
    size: float = 4.0
    hollow: bool = False
    notes: Sequence[str] = ()


@dataclass
class Panel:
    """One subplot.

    Attributes:
        kind: ``lines`` (x against y), ``barh`` (horizontal bars, one per category) or ``bar``.
        title, xlabel, ylabel: text.
        series: the lines, or the groups of bars (side by side).
        categories: the bars' labels (bar panels).
        log: log axes (``lines``).
        ticks: x positions to label, and only those (``lines``).
        guides: horizontal lines at these y (``lines``) or a vertical line at these x (``barh``).
        ylim: y limits (``lines``).
        legend: legend location ("" for none).
    """

    kind: str
    title: str
    xlabel: str = ""
    ylabel: str = ""
    series: list[Series] = field(default_factory=list)
    categories: Sequence[str] = ()
    log: bool = True
    ticks: Sequence[float] = ()
    guides: Sequence[float] = ()
    ylim: tuple[float, float] | None = None
    legend: str = "best"


def write_figure(
    path: Path,
    panels: Sequence[Panel | None],
    title: str,
    *,
    ncols: int = 3,
    panel_size: tuple[float, float] = (5.6, 5.0),
    shared_legend: bool = False,
    dpi: int = 110,
) -> None:
    """``panels`` in a grid of ``ncols`` columns (None: an empty cell), ``title`` above; with
    ``shared_legend`` one legend below, from the first panel."""
    from matplotlib.figure import Figure  # a benchmark extra: imported only here

    nrows = math.ceil(len(panels) / ncols)
    fig = Figure(figsize=(panel_size[0] * ncols, panel_size[1] * nrows), layout="constrained")
    axes = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False).ravel())
    for ax, panel in zip(axes, [*panels, *[None] * (len(axes) - len(panels))], strict=True):
        if panel is None:
            ax.axis("off")
            continue
        {"lines": _lines, "barh": _bars, "bar": _bars}[panel.kind](ax, panel, shared_legend)
    if shared_legend and panels and panels[0] is not None:
        handles, labels = axes[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 5))
    fig.suptitle(title, fontsize=10)
    fig.savefig(path, dpi=dpi)


def _lines(ax: Any, panel: Panel, shared_legend: bool) -> None:
    from matplotlib.ticker import FixedFormatter, FixedLocator, NullLocator

    for y in panel.guides:
        ax.axhline(y, color="0.85", lw=0.8, zorder=0)
    for s in panel.series:
        ax.plot(
            s.x,
            s.y,
            s.style,
            color=s.color,
            lw=s.width,
            ms=s.size,
            mfc="none" if s.hollow else None,
            label=s.label or None,
        )
    if panel.log:
        ax.set(xscale="log", yscale="log")
    if panel.ticks:
        ax.xaxis.set_major_locator(FixedLocator(list(panel.ticks)))
        ax.xaxis.set_major_formatter(FixedFormatter([f"{t:g}" for t in panel.ticks]))
        ax.xaxis.set_minor_locator(NullLocator())
    if panel.ylim is not None:
        ax.set_ylim(*panel.ylim)
    ax.set(xlabel=panel.xlabel, ylabel=panel.ylabel)
    ax.set_title(panel.title, fontsize=10)
    ax.grid(True, which="major", alpha=0.3)
    if panel.legend and not shared_legend and any(s.label for s in panel.series):
        ax.legend(fontsize=6, ncol=2 if len(panel.series) > 6 else 1, loc=panel.legend)


def _bars(ax: Any, panel: Panel, shared_legend: bool) -> None:
    horizontal = panel.kind == "barh"
    at = np.arange(len(panel.categories))
    width = 0.8 / max(len(panel.series), 1)
    top = 0.0
    for j, s in enumerate(panel.series):
        pos = at + (j - (len(panel.series) - 1) / 2) * width
        values = np.asarray(s.y, dtype=np.float64)
        draw = ax.barh if horizontal else ax.bar
        draw(pos, values, width, color=s.color, label=s.label or None)
        for k, text in enumerate(s.notes):
            if horizontal:
                ax.text(values[k], pos[k], f" {text}", va="center", fontsize=7)
            else:
                ax.text(pos[k], values[k], text, ha="center", va="bottom", fontsize=7)
        top = max(top, float(np.nanmax(values, initial=0.0)))
    for x in panel.guides:
        ax.axvline(x, color="black", lw=0.8)
    if horizontal:
        ax.set_yticks(at, panel.categories, fontsize=7)
        ax.invert_yaxis()
        if any(s.notes for s in panel.series):
            ax.set_xlim(0, 1.45 * (top or 1.0))
    else:
        ax.set_xticks(at, panel.categories, fontsize=7)
        ax.set_ylim(0, 1.25 * (top or 1.0))
    ax.set(xlabel=panel.xlabel, ylabel=panel.ylabel)
    ax.set_title(panel.title, fontsize=10)
    ax.grid(True, axis="x" if horizontal else "y", alpha=0.3)
    if panel.legend and any(s.label for s in panel.series):
        ax.legend(fontsize=7, loc=panel.legend)
