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
