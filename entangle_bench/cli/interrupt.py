"""Signals as exceptions: SIGTERM stops the CLI the way Ctrl-C does, so workers are stopped and files stay whole.

Python turns SIGINT into KeyboardInterrupt; `terminate_as_exception` turns SIGTERM into `Interrupted` (a
BaseException, so no `except Exception` in a trial swallows it) while the CLI runs, and restores the previous
handler afterwards. Every executor stops its workers when either passes through it (`entangle_bench.executors`).
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from typing import Any


class Interrupted(BaseException):
    """The process received a termination signal (`signum`)."""

    def __init__(self, signum: int):
        self.signum = signum
        super().__init__(f"received {signal.Signals(signum).name}")


def _raise(signum: int, frame: Any) -> None:
    raise Interrupted(signum)


@contextlib.contextmanager
def terminate_as_exception() -> Iterator[None]:
    """While active (main thread only), SIGTERM raises Interrupted(SIGTERM)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _raise)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
