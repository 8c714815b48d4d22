"""Output paths: checked before any work starts, written under a temporary name, renamed.

Every command that writes (``generate``, ``demo``, ``scene copy``/``random -o``/``show
--image``, ``dataset merge``/``export-lagrangebench``, every ``--json`` report) first calls
:func:`check_file` or :func:`check_dir`, so a read-only directory, a parent that is a file
or a missing parent is a one-line :class:`~dcdc.errors.DcdcError` before any simulation,
and an existing output is refused unless the user passed ``--overwrite``. Files are then written with
:func:`atomic_file` (temporary name in the same directory, fsync, ``os.replace``: atomic on
POSIX), and a set of files that belong together with :func:`atomic_dir` (a temporary
directory renamed into place), so a folder never mixes the outputs of two runs. HDF5 files
are built in memory and written by :func:`atomic_h5` (HDF5 does not survive a failed write:
on a full disk it fails inside its own clean-up and can crash the process).

A failed write (a full disk, a quota, a file system gone read-only) inside any of these
becomes one :class:`~dcdc.errors.DcdcError` line naming the output, and the temporary file
or directory is deleted. :func:`run_lock` keeps two processes out of one run directory.
"""
from __future__ import annotations

import errno
import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

from .errors import DcdcError

TMP_MARK = ".tmp-"  # temporary names: .NAME.tmp-PID (readers skip names starting with ".")
LOCK_NAME = ".lock"  # in a run directory: flock-ed by the process using it, holds its pid
# errors of the device rather than of the path: the output could not be written at all
WRITE_FAILURES = {errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS}


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
    if p.is_symlink() and not p.exists():
        raise DcdcError(f"cannot write into {p}: it is a symbolic link to {os.readlink(p)}, "
                        f"which leads nowhere (a loop or a missing target)")
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


def write_failure(e: OSError, *paths) -> bool:
    """True when ``e`` is a failure to write one of ``paths`` or to write at all (a full
    disk, a quota, a file too large, a read-only device)."""
    if e.errno in WRITE_FAILURES:
        return True
    names = {os.fspath(p) for p in paths}
    return e.filename is not None and os.fspath(e.filename) in names


def public_name(path) -> Path:
    """``path`` with temporary names (``.NAME.tmp-PID``) replaced by the names they stand
    for: the output the user asked for, not the file this process was writing."""
    parts = []
    for part in Path(path).parts:
        if part.startswith(".") and TMP_MARK in part:
            part = part[1:part.rindex(TMP_MARK)]
            if part.endswith(".old"):
                part = part[:-4]
        parts.append(part)
    return Path(*parts) if parts else Path(path)


def write_error(path, e: OSError) -> DcdcError:
    """The one-line error for an output ``path`` that could not be written."""
    path = public_name(path)
    if e.errno in (errno.ENOSPC, errno.EDQUOT):
        why = "no space left on the device" if e.errno == errno.ENOSPC else "disk quota exceeded"
        try:
            free = shutil.disk_usage(Path(path).parent).free
            why += f" ({free / 2**20:.1f} MiB free)"
        except OSError:
            pass
    else:
        why = e.strerror or str(e)
    return DcdcError(f"cannot write {path}: {why}")


@contextmanager
def writing(path, *tmps):
    """Turn a failed write of ``path`` (or of its temporary ``tmps``) inside the block into
    :func:`write_error`; other errors pass through."""
    try:
        yield
    except OSError as e:
        if not write_failure(e, path, *tmps):
            raise
        raise write_error(path, e) from None


@contextmanager
def atomic_file(path):
    """Yield a temporary path next to ``path``; on success fsync it and rename it over
    ``path``, on any error (or Ctrl-C) delete it. A failed write is one DcdcError line."""
    path = Path(path)
    tmp = tmp_name(path)
    try:
        with writing(path, tmp):
            yield tmp
            _sync(tmp)
            os.replace(tmp, path)
    finally:
        if tmp.exists() or tmp.is_symlink():
            tmp.unlink()


def _sync(path) -> None:
    """Flush ``path`` to the device (where a full disk shows at the latest)."""
    with open(path, "rb+") as fh:
        os.fsync(fh.fileno())


def write_text(path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically."""
    with atomic_file(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    return Path(path)


def write_bytes(path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically, after checking that the device has room."""
    path = Path(path)
    with writing(path):
        free = shutil.disk_usage(path.parent if str(path.parent) else ".").free
    if len(data) > free:
        raise DcdcError(f"cannot write {public_name(path)}: it needs {len(data) / 2**20:.1f} "
                        f"MiB, the device has {free / 2**20:.1f} MiB free")
    with atomic_file(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(data)
    return path


@contextmanager
def atomic_h5(path):
    """Yield a new HDF5 file (an ``h5py.File``) held in memory; on success its image is
    written to ``path`` with :func:`write_bytes`. HDF5 itself never writes to the disk, so a
    full disk is one error line and leaves nothing behind (an HDF5 file written in place
    fails inside HDF5's clean-up, which can crash the process)."""
    import h5py
    f = h5py.File(f"{Path(path).name}-in-memory", "w", driver="core", backing_store=False)
    try:
        yield f
        f.flush()
        image = f.id.get_file_image()
    finally:
        f.close()
    write_bytes(path, image)


@contextmanager
def atomic_dir(path, overwrite: bool = False):
    """Yield a temporary directory next to ``path``; on success it replaces ``path`` (the
    old directory, with ``overwrite``, is moved aside first and deleted after), on any
    error it is deleted and ``path`` is untouched."""
    path = Path(path)
    tmp = tmp_name(path)
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        with writing(path, tmp):
            tmp.mkdir(parents=True)
            yield tmp
            _replace_dir(tmp, path, overwrite)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def _replace_dir(tmp: Path, path: Path, overwrite: bool) -> None:
    old = None
    if path.exists():
        if not overwrite and not (path.is_dir() and not any(path.iterdir())):
            raise DcdcError(f"{path} appeared while this run was working (use --overwrite)")
        old = path.with_name(f".{path.name}.old{TMP_MARK}{os.getpid()}")
        os.replace(path, old)
    os.replace(tmp, path)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


@contextmanager
def run_lock(run, what: str):
    """Hold an exclusive lock on directory ``run`` (created if missing) while the block runs:
    a second process asking for it gets "RUN is in use by another WHAT (pid N)" at once.
    The lock is ``flock`` on ``RUN/.lock`` (which holds the owner's pid), so the kernel
    releases it when its process ends, however it ends. A directory this call created is
    removed again if the block fails and leaves nothing in it but the lock file and empty
    folders."""
    import fcntl
    run = Path(run)
    if run.exists() and not run.is_dir():
        raise DcdcError(f"{run} is a file, not a directory")
    created = not run.exists()
    try:
        run.mkdir(parents=True, exist_ok=True)
        fd = os.open(run / LOCK_NAME, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as e:
        raise DcdcError(f"cannot use {run}: {e.strerror}") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            pid = os.pread(fd, 32, 0).decode(errors="replace").strip() or "unknown"
            raise DcdcError(f"{run} is in use by another {what} (pid {pid})") from None
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        except OSError:  # a full disk: the lock holds without the pid
            pass
        try:
            yield run
        except BaseException:
            if created and _only_lock(run):
                shutil.rmtree(run, ignore_errors=True)
            raise
    finally:
        os.close(fd)  # closing the descriptor releases the lock


def _only_lock(run: Path) -> bool:
    for _, dirs, files in os.walk(run):
        if any(f != LOCK_NAME for f in files):
            return False
    return True
