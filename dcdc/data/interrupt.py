"""Ctrl-C and SIGTERM that stop a run cleanly.

A signal that lands inside a compiled numba kernel (a parallel SPH substep) can surface as
a ``SystemError`` traceback instead of a ``KeyboardInterrupt``. So while :func:`handling`
is active (``dcdc demo``, ``dcdc generate`` and their workers), SIGINT and SIGTERM are
*deferred* inside :func:`deferred` blocks (the solver's ``advance``): the handler only
records the signal, and the block's end raises :class:`~dcdc.errors.Interrupted` at a safe
point between frames. Outside such blocks the signal raises at once. A second signal while
one is pending raises at once too (the user insists). The CLI turns
:class:`~dcdc.errors.Interrupted` into "aborted" / "terminated" and exit status 128 + signal.
"""
from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

from ..errors import Interrupted

_state = {"depth": 0, "pending": None, "active": False}
SIGNALS = (signal.SIGINT, signal.SIGTERM)


def _raise(signum):
    _state["pending"] = None
    raise Interrupted(signum)


def _handler(signum, frame):
    if _state["depth"] > 0 and _state["pending"] is None:
        _state["pending"] = signum  # raised by deferred() when the block ends
        return
    _raise(signum)


def check() -> None:
    """Raise :class:`Interrupted` if a signal arrived during a deferred block."""
    if _state["pending"] is not None:
        _raise(_state["pending"])


@contextmanager
def handling(signals=SIGNALS):
    """Install the handlers for the duration of a command (main thread only; elsewhere,
    e.g. under a test runner's thread, the block runs with the handlers it has)."""
    if threading.current_thread() is not threading.main_thread() or _state["active"]:
        yield
        return
    old = {s: signal.signal(s, _handler) for s in signals}
    _state.update(active=True, pending=None, depth=0)
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        _state.update(active=False, pending=None, depth=0)


@contextmanager
def deferred():
    """A block (a compiled solver step) that a signal must not cut in half."""
    _state["depth"] += 1
    try:
        yield
    finally:
        _state["depth"] -= 1
    if _state["depth"] == 0:
        check()
