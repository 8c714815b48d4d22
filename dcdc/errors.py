"""User-facing errors.

Every mistake a user can make (a malformed scene, a negative density, a corrupt file, a
checkpoint of another model) raises :class:`DcdcError` with a one-line message naming the
problem. The CLI prints that line and exits non-zero; it never shows a traceback for them.
"""


class DcdcError(Exception):
    """A user-facing error: the message is one line that names the offending input."""


class SimulationDiverged(DcdcError):
    """A simulation state turned non-finite or exploded (speeds beyond a bound)."""


def require(condition: bool, message: str) -> None:
    """Raise :class:`DcdcError` with ``message`` unless ``condition`` holds."""
    if not condition:
        raise DcdcError(message)


class Interrupted(DcdcError):
    """The run was stopped by a signal (Ctrl-C = SIGINT, SIGTERM). The CLI prints
    "aborted" / "terminated" and exits with ``exit_code`` = 128 + the signal number."""

    def __init__(self, signum: int = 2, message: str | None = None):
        import signal
        self.signum = int(signum)
        self.exit_code = 128 + self.signum
        name = "aborted" if self.signum == signal.SIGINT else "terminated"
        super().__init__(message or f"{name} (signal {signal.Signals(self.signum).name})")
