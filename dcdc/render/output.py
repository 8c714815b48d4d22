"""Output paths of the render, export and view commands: checked before any work starts,
written under a temporary name in the same directory and renamed when complete (so a file
or folder that exists is finished), an existing output replaced only when asked."""
from __future__ import annotations

import os
import shutil
from contextlib import contextmanager
from pathlib import Path

from ..errors import DcdcError

TMP_MARK = ".tmp-"


def check_output(path, overwrite: bool, directory: bool = False,
                 replaceable: tuple[str, ...] = ()) -> Path:
    """Refuse an existing output unless ``overwrite``; a directory output may only be
    replaced when it holds nothing but files ending in ``replaceable`` (our own kind of
    output), so ``--overwrite`` never deletes a folder of other things."""
    path = Path(path)
    if path.exists() or path.is_symlink():
        if not overwrite:
            raise DcdcError(f"{path} exists (use --overwrite)")
        if directory != path.is_dir():
            kind = "a directory" if path.is_dir() else "a file"
            raise DcdcError(f"{path} is {kind}; refusing to replace it with "
                            f"{'a directory' if directory else 'a file'}")
        if directory:
            other = [p.name for p in path.iterdir()
                     if not (p.is_file() and p.name.endswith(replaceable))]
            if other:
                raise DcdcError(f"{path} holds other things ({', '.join(sorted(other)[:3])}); "
                                f"refusing to replace it")
    parent = path.parent
    if parent.exists() and not parent.is_dir():
        raise DcdcError(f"{parent} is not a directory")
    return path


def temp_name(path: Path) -> Path:
    """A hidden sibling of ``path`` that keeps its suffix (encoders choose by it)."""
    return path.with_name(f".{path.stem}{TMP_MARK}{os.getpid()}{path.suffix}")


@contextmanager
def atomic_file(path):
    """Yield a temporary path; rename it to ``path`` when the block ends without error."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_name(path)
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


@contextmanager
def atomic_dir(path):
    """Yield a temporary directory; it replaces ``path`` when the block ends without error."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}{TMP_MARK}{os.getpid()}")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    try:
        yield tmp
        move_into_place(tmp, path)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def move_into_place(tmp: Path, path: Path) -> None:
    """Rename the finished ``tmp`` (file or directory) to ``path``; an old directory there
    is renamed aside first and deleted after (a directory cannot be renamed over)."""
    if tmp.is_dir() and path.exists():
        old = path.with_name(f".{path.name}{TMP_MARK}old-{os.getpid()}")
        os.replace(path, old)
        os.replace(tmp, path)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(tmp, path)
