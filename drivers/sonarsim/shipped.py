"""Files shipped inside the packages: worlds, scenarios, sensor presets, plans.

A command that takes a YAML file also takes the name of a shipped one (``lab``,
``fig12``, ``translate``) when no file of that name exists. The files are package data,
so they resolve the same way from a source checkout and from an installed wheel.

>>> resolve_shipped("lab", kind="worlds").name
'lab.yaml'
>>> "fig12" in shipped_names("scenarios")
True
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

__all__ = ["SHIPPED_KINDS", "resolve_shipped", "shipped_dir", "shipped_names"]

#: Each kind of shipped file and the package whose ``data/`` folder holds it.
SHIPPED_KINDS: dict[str, str] = {
    "worlds": "sonarsim",
    "scenarios": "sonarsim",
    "sensors": "sonarsim",
    "plans": "sonard",
}


def shipped_dir(kind: str) -> Path:
    """The folder of the shipped files of ``kind`` (a key of :data:`SHIPPED_KINDS`)."""
    try:
        package = SHIPPED_KINDS[kind]
    except KeyError:
        raise ValueError(f"kind must be one of {', '.join(SHIPPED_KINDS)}, got {kind!r}") from None
    # Installed packages are plain folders (never zipped: the project is not zip-safe), so
    # the traversable is a real path that YAML loaders and relative references can use.
    return Path(str(resources.files(package).joinpath("data", kind)))


def shipped_names(kind: str) -> list[str]:
    """The names (file stems) of the shipped files of ``kind``, sorted."""
    folder = shipped_dir(kind)
    return sorted(p.stem for p in folder.glob("*.yaml")) if folder.is_dir() else []


def resolve_shipped(ref: str | Path, *, kind: str) -> Path:
    """A path for ``ref``: the file itself if it exists, else the shipped file so named.

    Parameters
    ----------
    ref : str or Path
        A path, or the name of a shipped file with or without ``.yaml``.
    kind : str
        ``worlds``, ``scenarios``, ``sensors`` or ``plans``.

    Returns
    -------
    Path
        ``ref`` unchanged when it names an existing file or is not a bare name (so the
        caller's own error for a missing file applies); the shipped file otherwise.

    Raises
    ------
    FileNotFoundError
        ``ref`` is a bare name that is neither a file here nor a shipped file; the message
        lists the shipped names.
    """
    path = Path(ref)
    if path.exists() or len(path.parts) != 1:
        return path
    stem = path.name[:-5] if path.name.endswith(".yaml") else path.name
    candidate = shipped_dir(kind) / f"{stem}.yaml"
    if candidate.is_file():
        return candidate
    names = ", ".join(shipped_names(kind)) or "none"
    raise FileNotFoundError(
        2, f"no such file, and no shipped {kind[:-1]} of that name (shipped: {names})", str(ref)
    )
