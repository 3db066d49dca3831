"""Where the shipped data lives: scenes, agent configs, sweeps and pretrained policies.

The repository keeps ``configs/`` and ``agents/`` at its root; the wheel installs them inside the
package, as ``rigid_env/configs/`` and ``rigid_env/agents/`` (``pyproject.toml`` maps them), so
the same relative path names a file in either layout:

==================================  ==========================================================
relative path                       file
==================================  ==========================================================
``configs/scenes/<name>.yaml``      a scene (:func:`scene_path`)
``configs/agents/<name>.yaml``      a training configuration (:func:`agent_config_path`)
``configs/sweeps/<name>.yaml``      a sweep
``agents/pretrained/<name>.zip``    a pretrained policy (:func:`pretrained_path`), with its
                                    ``<name>_vecnormalize.pkl`` and ``<name>.json`` beside it
==================================  ==========================================================

:func:`data_path` looks inside the installed package first (``importlib.resources``), then in the
checkout that this package was imported from (an editable install or ``PYTHONPATH=.``). This
module imports nothing else from the package.
"""

from __future__ import annotations

import os
from importlib.resources import files
from pathlib import Path

PACKAGE = "rigid_env"


def data_roots() -> list[Path]:
    """Folders that may hold ``configs/`` and ``agents/``, in the order they are searched: the
    installed package, then the repository checkout it was imported from (if it is one)."""
    package = Path(str(files(PACKAGE)))
    roots = [package]
    checkout = package.parent
    if (checkout / "pyproject.toml").is_file() and (checkout / "configs").is_dir():
        roots.append(checkout)
    return roots


def find_data(relative: str | Path) -> Path | None:
    """The first existing ``root / relative`` of :func:`data_roots`, or None."""
    for root in data_roots():
        path = root / relative
        if path.exists():
            return path
    return None


def data_path(relative: str | Path) -> Path:
    """The file or folder ``relative`` (e.g. ``"configs/scenes/detumble.yaml"``) shipped with
    the package.

    Raises:
        FileNotFoundError: one line naming the path and the folders searched.
    """
    path = find_data(relative)
    if path is not None:
        return path
    where = " or ".join(str(r) for r in data_roots())
    raise FileNotFoundError(
        f"{Path(relative).as_posix()}: not found in {where}; reinstall rigid_env "
        "(the wheel ships configs/ and agents/pretrained/) or run from the repository checkout"
    )


def scene_path(name: str) -> Path:
    """Path of the shipped scene ``configs/scenes/<name>.yaml`` (``name`` without ``.yaml``)."""
    return data_path(f"configs/scenes/{name}.yaml")


def agent_config_path(name: str) -> Path:
    """Path of the shipped training configuration ``configs/agents/<name>.yaml``."""
    return data_path(f"configs/agents/{name}.yaml")


def pretrained_path(name: str) -> Path:
    """Path of the shipped policy ``agents/pretrained/<name>.zip`` (e.g. ``"ppo_detumble"``);
    its ``VecNormalize`` statistics and metadata lie beside it."""
    return data_path(f"agents/pretrained/{name}.zip")


SCENE_DIR: Path = find_data("configs/scenes") or data_roots()[0] / "configs" / "scenes"
"""The folder of the shipped scenes (``configs/scenes``)."""


def folder_problem(path: Path) -> str | None:
    """Why the folders above ``path`` cannot be created: one of them is a link whose target is
    missing (``mkdir`` then says only "File exists"), or a file; ``None`` otherwise."""
    for above in reversed(Path(path).absolute().parents):
        if above.is_symlink() and not above.exists():
            return f"{above} is a link to {os.readlink(above)}, which does not exist"
        if above.exists() and not above.is_dir():
            return f"{above} is a file, not a folder"
    return None
