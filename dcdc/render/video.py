"""Writers for rendered frame sequences, chosen by the output name: ``.mp4`` (H.264 through
imageio's ffmpeg plugin; ``imageio-ffmpeg`` ships the binary), ``.gif`` (Pillow, one
adaptive palette per frame) or any name without a suffix: a folder of ``frame_NNNNN.png``.
Each writer works on a temporary name and renames on :meth:`close`; :meth:`abort` removes
it."""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np

from ..errors import DcdcError
from .output import TMP_MARK, move_into_place, temp_name
from .overlay import even

VIDEO_SUFFIXES = (".mp4", ".gif")


def output_kind(path) -> str:
    """"mp4", "gif", "png" (one picture) or "folder" by the name of ``path``."""
    suffix = Path(path).suffix.lower()
    if suffix in (".mp4", ".gif", ".png"):
        return suffix[1:]
    if suffix == "":
        return "folder"
    raise DcdcError(f"{path}: unknown output type {suffix!r} (use .mp4, .gif, .png or a "
                    f"folder name for PNG frames)")


class FrameWriter:
    def __init__(self, path, fps: float):
        self.path, self.fps, self.count = Path(path), float(fps), 0
        self.path.parent.mkdir(parents=True, exist_ok=True)
        kind = output_kind(path)
        if kind == "png":
            raise DcdcError(f"{path}: a .png holds one picture (use --strip, a single frame, "
                            f"or a folder name for a sequence)")
        self.kind = kind
        self._frames = []
        if kind == "folder":
            self.tmp = self.path.with_name(f".{self.path.name}{TMP_MARK}{os.getpid()}")
            shutil.rmtree(self.tmp, ignore_errors=True)
            self.tmp.mkdir()
        else:
            self.tmp = temp_name(self.path)
        self._mp4 = None

    def append(self, img: np.ndarray) -> None:
        from PIL import Image
        if self.kind == "folder":
            Image.fromarray(img).save(self.tmp / f"frame_{self.count:05d}.png", optimize=False)
        elif self.kind == "gif":
            self._frames.append(Image.fromarray(img).quantize(colors=255, method=Image.Quantize.MEDIANCUT))
        else:
            if self._mp4 is None:
                import imageio.v2 as iio
                self._mp4 = iio.get_writer(self.tmp, format="FFMPEG", fps=self.fps,
                                           codec="libx264", quality=6, macro_block_size=1,
                                           pixelformat="yuv420p", ffmpeg_log_level="error")
            self._mp4.append_data(even(img))
        self.count += 1

    def close(self) -> Path:
        if self.count == 0:
            self.abort()
            raise DcdcError("no frames to write")
        if self.kind == "gif":
            first, rest = self._frames[0], self._frames[1:]
            first.save(self.tmp, format="GIF", save_all=True, append_images=rest, loop=0,
                       duration=max(20, int(round(1000 / self.fps))), disposal=1)
            self._frames = []
        elif self.kind == "mp4":
            self._mp4.close()
        move_into_place(self.tmp, self.path)
        return self.path

    def abort(self) -> None:
        if self._mp4 is not None:
            try:
                self._mp4.close()
            except Exception:
                pass
        if self.tmp.is_dir():
            shutil.rmtree(self.tmp, ignore_errors=True)
        elif self.tmp.exists():
            self.tmp.unlink()
