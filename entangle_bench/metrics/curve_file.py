"""Reading filament curves (m) from .npz archives for the CLI and the plotting scripts.

Accepted layouts: a (K, M, 3) array under the key `curves`, or else one (M_k, 3) array per key,
taken in the order the keys are stored in the archive (the order given to `numpy.savez`).
Optional keys `contact_points` (n, 3) and `contact_kinds` (n,) (strings such as 'filament-object')
are not curves; `load_contacts` reads them.
"""

from __future__ import annotations

import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from entangle_bench.errors import FileFormatError, ParameterError
from entangle_bench.metrics.acn import clean_curves

_SIDE_KEYS = ("contact_points", "contact_kinds")


@dataclass(frozen=True)
class CurveFile:
    """Curves read from one archive: `names[k]` says where curve k came from."""

    path: Path
    names: list[str]
    curves: list[np.ndarray]  # (M_k, 3) float64 each, m


#: First bytes of a zip archive (what an .npz is) and of a bare .npy array.
_ZIP_MAGIC, _NPY_MAGIC = (b"PK\x03\x04", b"PK\x05\x06"), b"\x93NUMPY"


def open_npz(path: Path) -> np.lib.npyio.NpzFile:
    """Open an .npz archive; FileFormatError if it is no archive (text, a bare .npy array) or unreadable."""
    try:
        with open(path, "rb") as handle:
            head = handle.read(6)
    except OSError as exc:
        raise FileFormatError(f"{path}: cannot read ({exc.strerror})") from None
    if head.startswith(_NPY_MAGIC):
        raise FileFormatError(f"{path}: a single .npy array, not an .npz archive")
    if not head.startswith(_ZIP_MAGIC):
        raise FileFormatError(f"{path}: not an npz archive (an .npz is a zip file of .npy arrays, e.g. written "
                              "by numpy.savez); this file starts with " + repr(head))
    try:
        archive = np.load(path, allow_pickle=False)
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        raise FileFormatError(f"{path}: not a readable .npz archive ({exc})") from None
    if not isinstance(archive, np.lib.npyio.NpzFile):
        raise FileFormatError(f"{path}: a single .npy array, not an .npz archive")
    return archive


def load_curves(path: str | Path, *, drop_degenerate: bool = False) -> CurveFile:
    """Read and validate curves from an .npz archive; FileFormatError names the file and key."""
    path = Path(path)
    if not path.is_file():
        raise FileFormatError(f"{path}: no such file")
    archive = open_npz(path)
    with archive:
        keys = [k for k in archive.files if k not in _SIDE_KEYS]
        if "curves" in keys:
            stack = _read(archive, path, "curves")
            if stack.ndim != 3 or stack.shape[2] != 3:
                raise FileFormatError(
                    f"{path}: key 'curves': expected shape (K, M, 3), got {stack.shape}"
                )
            names = [f"curves[{k}]" for k in range(len(stack))]
            arrays = list(stack)
        elif keys:
            names, arrays = [], []
            for key in keys:
                arr = _read(archive, path, key)
                if arr.ndim != 2 or arr.shape[1] != 3:
                    raise FileFormatError(
                        f"{path}: key {key!r}: expected shape (M, 3), got {arr.shape}"
                    )
                names.append(key)
                arrays.append(arr)
        else:
            raise FileFormatError(
                f"{path}: no curve arrays (expected key 'curves' or (M, 3) arrays)"
            )
    if not arrays:
        raise FileFormatError(f"{path}: key 'curves' holds no curves")
    curves = []
    for name, arr in zip(names, arrays):
        try:
            (curve,) = clean_curves([arr], drop_degenerate=drop_degenerate)
        except ParameterError as exc:
            problem = str(exc).removeprefix("curve 0: ")
            raise FileFormatError(f"{path}: key {name!r}: {problem}") from None
        curves.append(curve)
    return CurveFile(path=path, names=names, curves=curves)


def _read(archive: np.lib.npyio.NpzFile, path: Path, key: str) -> np.ndarray:
    """One numeric array from the archive, as float64."""
    try:
        arr = archive[key]
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        raise FileFormatError(f"{path}: key {key!r}: unreadable ({exc})") from None
    if not np.issubdtype(arr.dtype, np.number) or np.iscomplexobj(arr):
        raise FileFormatError(f"{path}: key {key!r}: expected real numbers, got dtype {arr.dtype}")
    return arr.astype(np.float64)


def load_contacts(path: str | Path) -> tuple[np.ndarray, np.ndarray] | None:
    """Contact points (n, 3) in m and kinds (n,) str from an archive, or None if it has none."""
    path = Path(path)
    archive = open_npz(path)
    with archive:
        if "contact_points" not in archive.files:
            return None
        points = _read(archive, path, "contact_points")
        if points.ndim != 2 or points.shape[1] != 3 or not np.isfinite(points).all():
            raise FileFormatError(
                f"{path}: key 'contact_points': expected finite (n, 3) values, got {points.shape}"
            )
        if "contact_kinds" in archive.files:
            kinds = archive["contact_kinds"]
            if kinds.dtype.kind not in "US" or kinds.shape != (len(points),):
                raise FileFormatError(
                    f"{path}: key 'contact_kinds': expected ({len(points)},) strings, "
                    f"got {kinds.dtype} {kinds.shape}"
                )
            kinds = kinds.astype(str)
        else:
            kinds = np.full(len(points), "other")
    return points, kinds
