"""Where the harness finds its data: suites, rod cases, meshes and committed CoACD caches, plus the user cache.

Every data path is resolved here with `importlib.resources`, from the package folder `entangle_bench/_data/`.
In the repository, `_data/tasks` and `_data/assets` are symlinks to the top-level `tasks/` and `assets/`
folders, which stay the source of truth; a wheel holds copies of them (setuptools follows the links), so an
installed package works outside the repository.

New CoACD decompositions go into the repository's `assets/coacd_cache/` when the package runs from a
writable source checkout (so they can be committed), and otherwise into the user cache folder
`$XDG_CACHE_HOME/entangle-bench/coacd` (default `~/.cache/entangle-bench/coacd`): an installed package never
writes into its own installation. Committed caches are read first, read-only.
"""

from __future__ import annotations

import os
from importlib.resources import files
from pathlib import Path

from entangle_bench.errors import FileFormatError


def _package_data(*parts: str) -> Path:
    path = files("entangle_bench").joinpath("_data", *parts)
    if not isinstance(path, Path):  # a zipped install: the harness needs real files
        raise FileFormatError(f"package data {'/'.join(parts)} is not on disk ({path}); install the wheel unzipped")
    return path


def data_dir(*parts: str) -> Path:
    """Folder or file of the package data (`tasks`, `assets`, ...) on disk, links resolved."""
    return _package_data(*parts).resolve()


def tasks_dir() -> Path:
    """Folder of the shipped suite files (`*.toml`)."""
    return data_dir("tasks")


def rod_cases_dir() -> Path:
    """Folder of the shipped rod cases (`*.json`)."""
    return data_dir("tasks", "rod_cases")


def assets_dir() -> Path:
    """Folder of the shipped assets (meshes and their decomposition caches)."""
    return data_dir("assets")


def shipped_cache_dir() -> Path:
    """Folder of the committed CoACD decompositions (read-only, looked up first)."""
    return data_dir("assets", "coacd_cache")


def source_tree() -> bool:
    """True when the package runs from a repository checkout (its data folders link into the repository)."""
    return _package_data("assets").is_symlink()


def user_cache_dir() -> Path:
    """The user's cache folder of the harness: $XDG_CACHE_HOME/entangle-bench or ~/.cache/entangle-bench."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "entangle-bench"


def coacd_cache_dirs() -> tuple[Path, ...]:
    """Folders searched for a CoACD decomposition, in order: committed caches, then the user cache."""
    return shipped_cache_dir(), user_cache_dir() / "coacd"


def coacd_write_dir() -> Path:
    """Folder for new CoACD decompositions: the repository's cache in a writable checkout, else the user cache."""
    shipped = shipped_cache_dir()
    if source_tree() and os.access(shipped, os.W_OK):
        return shipped
    return user_cache_dir() / "coacd"
