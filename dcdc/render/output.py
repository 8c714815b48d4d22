"""Output paths of the render, export and view commands, on top of the project's
:mod:`dcdc.outputs` (checked before any work, temporary name, renamed when complete,
an existing output replaced only with ``--overwrite``). One addition: an existing
*directory* is replaced only when it holds nothing but our own kind of files, so
``--overwrite`` never deletes a folder of other things (``--out . --overwrite``)."""
from __future__ import annotations

from pathlib import Path

from ..outputs import atomic_dir, atomic_file, check_dir, check_file  # noqa: F401
from ..errors import DcdcError


def check_output(path, overwrite: bool, directory: bool = False,
                 replaceable: tuple[str, ...] = ()) -> Path:
    """:func:`check_file` or :func:`check_dir`; a directory that exists may be replaced
    (with ``overwrite``) only when every entry is a file ending in ``replaceable``."""
    if not directory:
        return check_file(path, overwrite)
    p = check_dir(path, overwrite=bool(overwrite))
    if p.exists():
        other = [e.name for e in p.iterdir() if not (e.is_file() and e.name.endswith(replaceable))]
        if other:
            raise DcdcError(f"{p} holds other things ({', '.join(sorted(other)[:3])}); "
                            f"refusing to replace it")
    return p
