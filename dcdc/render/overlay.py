"""Labels around rendered frames: legend, time stamp, scale bar, titles, and tiling.

Everything is drawn with Pillow into bands above or below the pictures, so labels never
hide particles. The font is DejaVu Sans as shipped with matplotlib (a base dependency);
Pillow's built-in font is the fallback.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

INK = (40, 40, 40)
PAPER = (255, 255, 255)


@lru_cache(maxsize=8)
def font(size: int):
    from PIL import ImageFont
    try:
        from matplotlib import get_data_path
        return ImageFont.truetype(f"{get_data_path()}/fonts/ttf/DejaVuSans.ttf", size)
    except Exception:  # pragma: no cover - matplotlib is a base dependency
        return ImageFont.load_default()


def font_size(width: int) -> int:
    """Label size for a picture (or strip panel) ``width`` pixels wide."""
    return int(np.clip(width / 40, 11, 20))


def nice_length(metres: float) -> float:
    """The largest 1, 2 or 5 x 10^k not above ``metres``."""
    k = np.floor(np.log10(metres))
    for m in (5, 2, 1):
        if m * 10 ** k <= metres:
            return float(m * 10 ** k)
    return float(10 ** k)


def length_label(metres: float) -> str:
    if metres >= 1:
        return f"{metres:g} m"
    if metres >= 0.01:
        return f"{metres * 100:g} cm"
    return f"{metres * 1000:g} mm"


def legend_band(width: int, phases, ppm: float | None = None, dim: int = 2,
                left: str | None = None, size: int | None = None) -> np.ndarray:
    """A white band: ``left`` text (e.g. the time), one coloured disc with "name ρ kg/m³"
    per phase (wrapping onto more rows when needed), and at the right of the first row a
    scale bar for ``ppm`` pixels per metre (in 3-D the scale at the centre of the view)."""
    from PIL import Image, ImageDraw
    fs = size or font_size(width)
    f = font(fs)
    measure = ImageDraw.Draw(Image.new("RGB", (1, 1)))
    pad, r, row_h = int(fs * 0.6), fs * 0.42, int(fs * 2.2)
    bar = None
    if ppm:
        L = nice_length(min(width / 7, 12 * fs) / ppm)
        label = length_label(L) + (" at centre" if dim == 3 else "")
        px = int(round(L * ppm))
        bar = (px, label, max(px, int(measure.textlength(label, font=f))))
    # lay out the items (left text, then the phases) into rows
    items = ([("text", left, None)] if left else []) + \
        [("phase", f"{p.name} {p.density:g} kg/m³", p.color) for p in phases]
    rows, x, row = [[]], pad, 0
    for kind, text, col in items:
        w = int(measure.textlength(text, font=f) + (2 * r + fs * 0.4 if kind == "phase" else 0))
        limit = width - pad - (bar[2] + fs if bar and row == 0 else 0)
        if rows[-1] and x + w > limit:
            rows.append([])
            x, row = pad, row + 1
        rows[-1].append((x, kind, text, col))
        x += w + int(fs * 1.2)
    im = Image.new("RGB", (width, row_h * len(rows)), PAPER)
    d = ImageDraw.Draw(im)
    for k, entries in enumerate(rows):
        y = k * row_h + row_h // 2
        for x, kind, text, col in entries:
            if kind == "phase":
                rgb = tuple(int(round(255 * c)) for c in col)
                d.ellipse([x, y - r, x + 2 * r, y + r], fill=rgb, outline=INK)
                x += int(2 * r + fs * 0.4)
            d.text((x, y), text, fill=INK, font=f, anchor="lm")
    if bar:
        px, label, room = bar
        y = row_h // 2
        x1 = width - pad
        x0 = x1 - px
        d.rectangle([x0, y + fs * 0.35, x1, y + fs * 0.35 + max(2, fs // 5)], fill=INK)
        for xe in (x0, x1):
            d.line([xe, y + fs * 0.1, xe, y + fs * 0.7], fill=INK, width=max(1, fs // 10))
        tw = measure.textlength(label, font=f)
        d.text((min((x0 + x1) / 2, x1 - tw / 2), y + fs * 0.2), label, fill=INK, font=f,
               anchor="md")
    return np.asarray(im)


def fit_text(text: str, width: float, size: int, min_size: int = 9) -> tuple[str, int]:
    """``text`` at the largest size down to ``min_size`` that fits ``width`` pixels, else at
    ``min_size`` shortened in the middle with an ellipsis."""
    from PIL import Image, ImageDraw
    d = ImageDraw.Draw(Image.new("RGB", (1, 1)))
    for fs in range(size, min_size - 1, -1):
        if d.textlength(text, font=font(fs)) <= width:
            return text, fs
    fs, keep = min_size, len(text)
    while keep > 2 and d.textlength(short := text[:keep // 2] + "…" + text[-(keep - keep // 2):],
                                    font=font(fs)) > width:
        keep -= 1
    return (short if keep > 2 else "…"), fs


def title_band(width: int, text: str, size: int | None = None) -> np.ndarray:
    """A white band ``text`` centred in it (shrunk or shortened to fit)."""
    from PIL import Image, ImageDraw
    size = size or font_size(width)
    h = int(size * 1.8)
    text, fs = fit_text(text, width - size, size)
    im = Image.new("RGB", (width, h), PAPER)
    ImageDraw.Draw(im).text((width // 2, h // 2), text, fill=INK, font=font(fs), anchor="mm")
    return np.asarray(im)


def note(img: np.ndarray, text: str) -> np.ndarray:
    """``text`` in the top-left corner of the picture on a white box (e.g. the cut-away)."""
    from PIL import Image, ImageDraw
    im = Image.fromarray(img)
    d = ImageDraw.Draw(im)
    fs = max(10, font_size(img.shape[1]) - 3)
    f = font(fs)
    box = d.textbbox((fs // 2, fs // 2), text, font=f)
    d.rectangle([box[0] - 3, box[1] - 3, box[2] + 3, box[3] + 3], fill=PAPER)
    d.text((fs // 2, fs // 2), text, fill=INK, font=f)
    return np.asarray(im)


def vstack(*images: np.ndarray) -> np.ndarray:
    w = max(i.shape[1] for i in images)
    return np.concatenate([_pad_width(i, w) for i in images], 0)


def hstack(images, gap: int = 6) -> np.ndarray:
    h = max(i.shape[0] for i in images)
    parts = []
    for k, i in enumerate(images):
        if k:
            parts.append(np.full((h, gap, 3), 255, np.uint8))
        parts.append(np.pad(i, ((0, h - i.shape[0]), (0, 0), (0, 0)), constant_values=255))
    return np.concatenate(parts, 1)


def _pad_width(img: np.ndarray, w: int) -> np.ndarray:
    extra = w - img.shape[1]
    return np.pad(img, ((0, 0), (extra // 2, extra - extra // 2), (0, 0)), constant_values=255)


def even(img: np.ndarray) -> np.ndarray:
    """Pad to even height and width (H.264 needs them)."""
    h, w = img.shape[:2]
    return np.pad(img, ((0, h % 2), (0, w % 2), (0, 0)), constant_values=255)
