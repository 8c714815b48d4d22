"""Output paths: checked before any work starts, written under a temporary name, renamed.

Every command that writes (``generate``, ``demo``, ``scene copy``/``random -o``/``show
--image``, ``dataset merge``/``export-lagrangebench``) first calls :func:`check_file` or
:func:`check_dir`, so a read-only directory, a parent that is a file or a missing parent
is a one-line :class:`~dcdc.errors.DcdcError` before any simulation, and an existing output
is refused unless the user passed ``--overwrite``. Files are then written with
:func:`atomic_file` (temporary name in the same directory, fsync, ``os.replace``: atomic on
POSIX), and a set of files that belong together with :func:`atomic_dir` (a temporary
directory renamed into place), so a folder never mixes the outputs of two runs.
"""
from __future__ import annotations

import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

from .errors import DcdcError

TMP_MARK = ".tmp-"  # temporary names: .NAME.tmp-PID (readers skip names starting with ".")


def _writable_dir(d: Path, target: Path) -> None:
    """``d`` must be an existing directory this process can create files in (probed with a
    real file: permission bits alone do not show a read-only file system)."""
    if not d.exists():
        raise DcdcError(f"cannot write {target}: directory {d} does not exist")
    if not d.is_dir():
        raise DcdcError(f"cannot write {target}: {d} is a file, not a directory")
    try:
        fd, probe = tempfile.mkstemp(prefix=".dcdc-probe-", dir=d)
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise DcdcError(f"cannot write {target}: {d} is not writable ({e.strerror})") from None


def check_file(path, overwrite: bool = False) -> Path:
    """Check that ``path`` can be written as a new file (or replaced, with ``overwrite``)."""
    p = Path(path)
    if p.is_dir():
        raise DcdcError(f"cannot write {p}: it is a directory")
    if p.exists() and not overwrite:
        raise DcdcError(f"{p} exists (use --overwrite to replace it)")
    _writable_dir(p.parent if str(p.parent) else Path("."), p)
    return p


def check_dir(path, overwrite: bool | None = None) -> Path:
    """Check that directory ``path`` exists and is writable or can be created (missing
    parents are created later). ``overwrite=False`` also refuses an existing non-empty
    directory; ``None`` accepts one (a resumable dataset directory)."""
    p = Path(path)
    if p.exists():
        if not p.is_dir():
            raise DcdcError(f"cannot write into {p}: it is a file, not a directory")
        if overwrite is False and any(p.iterdir()):
            raise DcdcError(f"{p} exists and is not empty (use --overwrite to replace it)")
        _writable_dir(p, p)
        return p
    a = p.parent
    while not a.exists() and a != a.parent:
        if a.is_symlink():
            break
        a = a.parent
    if not a.is_dir():
        raise DcdcError(f"cannot create {p}: {a} is a file, not a directory")
    _writable_dir(a, p)
    return p


def tmp_name(path) -> Path:
    p = Path(path)
    return p.with_name(f".{p.name}{TMP_MARK}{os.getpid()}")


@contextmanager
def atomic_file(path):
    """Yield a temporary path next to ``path``; on success fsync it and rename it over
    ``path``, on any error (or Ctrl-C) delete it."""
    path = Path(path)
    tmp = tmp_name(path)
    try:
        yield tmp
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def write_text(path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically."""
    with atomic_file(path) as tmp:
        Path(tmp).write_text(text)
    return Path(path)


@contextmanager
def atomic_dir(path, overwrite: bool = False):
    """Yield a temporary directory next to ``path``; on success it replaces ``path`` (the
    old directory, with ``overwrite``, is moved aside first and deleted after), on any
    error it is deleted and ``path`` is untouched."""
    path = Path(path)
    tmp = tmp_name(path)
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    try:
        yield tmp
        old = None
        if path.exists():
            if not overwrite and not (path.is_dir() and not any(path.iterdir())):
                raise DcdcError(f"{path} appeared while this run was working (use --overwrite)")
            old = path.with_name(f".{path.name}.old{TMP_MARK}{os.getpid()}")
            os.replace(path, old)
        os.replace(tmp, path)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
