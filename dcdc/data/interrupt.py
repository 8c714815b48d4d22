"""Ctrl-C and SIGTERM that stop a run cleanly, at a safe point.

Raising from a signal handler at an arbitrary bytecode is not safe: inside a compiled
numba kernel (a parallel SPH substep) it can surface as a ``SystemError`` traceback, and
inside a weakref callback or ``__del__`` Python prints "Exception ignored" and drops it. So
while :func:`handling` is active (``dcdc demo``, ``dcdc generate`` and its workers), the
first SIGINT or SIGTERM only records itself (and says so on stderr); the run calls
:func:`check` at safe points — after every solver frame, while the worker pool waits —
which raises :class:`~dcdc.errors.Interrupted`. A second signal while one is pending raises
at once (the user insists), and so does the first inside :func:`at_once`: set-up code
(building a large scene: lattices of millions of points, no frame loop to reach a safe
point for minutes), where it lands between numpy calls. The CLI turns :class:`~dcdc.errors.Interrupted` into "aborted" /
"terminated" and exit status 128 + signal.
"""
from __future__ import annotations

import os
import signal
import threading
from contextlib import contextmanager

from ..errors import Interrupted

_state = {"pending": None, "active": False, "at_once": False}
SIGNALS = (signal.SIGINT, signal.SIGTERM)


class _Stop(BaseException):
    """Raised by the handler inside :func:`at_once`: a BaseException, so that no ``except
    Exception`` of the code it lands in (numba's compiler, trimesh) takes it for an error of
    its own; :func:`at_once` turns it into :class:`Interrupted`."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def _handler(signum, frame):
    if _state["at_once"]:
        _state["pending"] = signum  # kept if the raise is swallowed (it landed in a __del__)
        raise _Stop(signum)
    if _state["pending"] is None:
        _state["pending"] = signum
        if signum == signal.SIGINT:  # os.write: safe even if it lands inside another write
            os.write(2, b"\nstopping after this step (Ctrl-C again to stop at once)\n")
        return
    _state["pending"] = None
    raise Interrupted(signum)


def check() -> None:
    """Raise :class:`Interrupted` if a signal has arrived (call at safe points)."""
    signum = _state["pending"]
    if signum is not None:
        _state["pending"] = None
        raise Interrupted(signum)


@contextmanager
def at_once():
    """A block without safe points (set-up): a signal stops it at once, not after it."""
    check()  # one that arrived before the block
    before = _state["at_once"]
    _state["at_once"] = True
    try:
        yield
    except _Stop as e:
        _state["pending"] = None
        raise Interrupted(e.signum) from None
    finally:
        _state["at_once"] = before
    check()  # one whose raise was swallowed inside the block


@contextmanager
def handling(signals=SIGNALS):
    """Install the handlers for the duration of a command (main thread only; elsewhere,
    e.g. under a test runner's thread, the block runs with the handlers it has). Leaving
    the block checks once more, so a signal is never lost."""
    if threading.current_thread() is not threading.main_thread() or _state["active"]:
        yield
        return
    old = {s: signal.signal(s, _handler) for s in signals}
    _state.update(active=True, pending=None)
    try:
        yield
        check()
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        _state.update(active=False, pending=None)
