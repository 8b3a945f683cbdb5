"""Atomic file writes: every file the harness writes appears whole or not at all.

`AtomicFile(path)` creates a temporary file beside `path` (same folder, so the rename cannot cross file
systems) with the normal permissions of a new file (0666 minus the process umask, e.g. 0644, unlike
`tempfile.mkstemp`'s 0600). Write it through `.tmp`, by name or by handle, then `commit()` fsyncs it and
renames it onto `path` with `os.replace`; `discard()` removes it; `close(keep)` does one of the two. As a
context manager it commits on success and discards on any exception, KeyboardInterrupt included. The
temporary name keeps the target's suffix, because numpy and matplotlib choose the format from it.
"""

from __future__ import annotations

import os
import secrets
from pathlib import Path
from typing import Any

import numpy as np


class AtomicFile:
    """A temporary file that becomes `path` on commit() and vanishes on discard()."""

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        while True:
            tmp = self.path.with_name(f".{self.path.stem}.{secrets.token_hex(4)}.tmp{self.path.suffix}")
            try:
                # O_EXCL: never reuse another writer's file; mode 0o666 lets the kernel apply the umask.
                os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
                break
            except FileExistsError:
                continue
        self.tmp = tmp

    def commit(self) -> Path:
        """Flush the temporary file to disk and rename it onto `path`; return `path`."""
        fd = os.open(self.tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(self.tmp, self.path)
        return self.path

    def discard(self) -> None:
        """Remove the temporary file."""
        self.tmp.unlink(missing_ok=True)

    def close(self, keep: bool) -> None:
        """Commit if `keep`, else discard."""
        if keep:
            self.commit()
        else:
            self.discard()

    def __enter__(self) -> AtomicFile:
        return self

    def __exit__(self, exc_type: Any, *_: Any) -> None:
        self.close(keep=exc_type is None)


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Write `text` (UTF-8) to `path` atomically; return `path`."""
    with AtomicFile(path) as out:
        out.tmp.write_text(text, encoding="utf-8")
    return out.path


def atomic_save_npz(path: str | os.PathLike, compressed: bool = True, **arrays: Any) -> Path:
    """Save arrays to an .npz at `path` atomically (compressed by default); return `path`."""
    with AtomicFile(path) as out, open(out.tmp, "wb") as handle:
        (np.savez_compressed if compressed else np.savez)(handle, **arrays)
    return out.path


def atomic_savefig(figure: Any, path: str | os.PathLike, **kwargs: Any) -> Path:
    """Save a matplotlib figure to `path` atomically (format from the suffix); return `path`."""
    path = Path(path)
    with AtomicFile(path) as out:
        figure.savefig(out.tmp, format=path.suffix.lstrip(".") or "png", **kwargs)
    return out.path
