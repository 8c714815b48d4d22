"""Writers for rendered frame sequences, chosen by the output name: ``.mp4`` (H.264 through
``imageio-ffmpeg``, which ships the ffmpeg binary), ``.gif`` (Pillow, one
adaptive palette per frame) or any name without a suffix: a folder of ``frame_NNNNN.png``.
A :class:`FrameWriter` writes to the temporary file or folder that
:func:`dcdc.outputs.atomic_file` / ``atomic_dir`` hand out (see :func:`frame_output`),
which rename it when the block ends without error."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import DcdcError
from .output import atomic_dir, atomic_file
from .overlay import even


def output_kind(path) -> str:
    """"mp4", "gif", "png" (one picture) or "folder" by the name of ``path``."""
    suffix = Path(path).suffix.lower()
    if suffix in (".mp4", ".gif", ".png"):
        return suffix[1:]
    if suffix == "":
        return "folder"
    raise DcdcError(f"{path}: unknown output type {suffix!r} (use .mp4, .gif, .png or a "
                    f"folder name for PNG frames)")


def frame_output(path, overwrite: bool = False):
    """The atomic context for a frame sequence at ``path``: a folder or a file."""
    return atomic_dir(path, overwrite=overwrite) if output_kind(path) == "folder" \
        else atomic_file(path)


class FrameWriter:
    """``with FrameWriter(tmp, kind, fps) as w: w.append(img)``: on a clean exit the GIF is
    saved / the MP4 closed; on an error the encoder is stopped (the caller's atomic
    context deletes the temporary output)."""

    def __init__(self, tmp, kind: str, fps: float):
        if kind == "png":
            raise DcdcError("a .png holds one picture (use --strip, a single frame, or a "
                            "folder name for a sequence)")
        self.tmp, self.kind, self.fps, self.count = Path(tmp), kind, float(fps), 0
        self._gif, self._mp4 = [], None

    def __enter__(self):
        return self

    def append(self, img: np.ndarray) -> None:
        from PIL import Image
        if self.kind == "folder":
            Image.fromarray(img).save(self.tmp / f"frame_{self.count:05d}.png", format="PNG")
        elif self.kind == "gif":
            self._gif.append(Image.fromarray(img).quantize(colors=255, method=Image.Quantize.MEDIANCUT))
        else:
            img = np.ascontiguousarray(even(img))
            if self._mp4 is None:
                self._size = (img.shape[1], img.shape[0])
                self._mp4 = _Encoder(self.tmp, self._size, self.fps)
            if (img.shape[1], img.shape[0]) != self._size:
                raise DcdcError(f"frame size changed from {self._size} to {img.shape[1::-1]}")
            self._mp4.put(img.tobytes())
        self.count += 1

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None:
            if self._mp4 is not None:
                self._mp4.close(abort=True)
            return False
        if self.count == 0:
            raise DcdcError("no frames to write")
        if self.kind == "gif":
            self._gif[0].save(self.tmp, format="GIF", save_all=True, append_images=self._gif[1:],
                              loop=0, duration=max(20, int(round(1000 / self.fps))), disposal=1)
            self._gif = []
        elif self.kind == "mp4":
            self._mp4.close()
        return False


class _Encoder:
    """H.264 through ``imageio_ffmpeg.write_frames``, fed from a thread: the pipe to ffmpeg
    blocks while it encodes, and the next frame is drawn meanwhile (numba releases the
    GIL). At most two frames wait."""

    def __init__(self, path, size, fps):
        import queue
        import threading

        import imageio_ffmpeg
        self._gen = imageio_ffmpeg.write_frames(
            str(path), size, fps=fps, codec="libx264", quality=6, macro_block_size=1,
            pix_fmt_out="yuv420p", ffmpeg_log_level="fatal",  # failures: _failed()
            # the temporary name has no .mp4 suffix; "veryfast" halves the encoder's CPU
            # time against x264's default preset at a similar file size
            output_params=["-f", "mp4", "-preset", "veryfast"])
        self._gen.send(None)
        self._path = Path(path)
        self._queue, self._error = queue.Queue(maxsize=2), None
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self):
        while (data := self._queue.get()) is not None:
            if self._error is None:
                try:
                    self._gen.send(data)
                except Exception as e:  # reported by put() / close() in the caller's thread
                    self._error = e

    def put(self, data: bytes) -> None:
        if self._error is not None:
            raise self._failed(self._error)
        self._queue.put(data)

    def _failed(self, e: Exception) -> DcdcError:
        """The error for a failed encoder: ffmpeg, told to be quiet, does not say why, and
        a full disk is the usual reason (a failure to write its output file)."""
        import errno
        import shutil

        from ..outputs import public_name, write_error
        try:
            full = shutil.disk_usage(self._path.parent).free < 2**20
        except OSError:
            full = False
        if full:
            return write_error(self._path, OSError(errno.ENOSPC, "No space left on device"))
        first = (str(e).strip().splitlines() or [type(e).__name__])[0]
        return DcdcError(f"the video encoder (ffmpeg) failed writing "
                         f"{public_name(self._path)}: {first}")

    def close(self, abort: bool = False) -> None:
        self._queue.put(None)
        self._thread.join()
        try:
            self._gen.close()
        except Exception as e:
            if not abort:
                raise self._failed(e) from None
        if self._error is not None and not abort:
            raise self._failed(self._error)
