"""Line numbers for error messages: where a dotted field of a scene (``fluid[2].min``,
``phases.oil.density``) stands in its TOML text, so that a message can say "(line 12)"."""
from __future__ import annotations

import re

from ..errors import DcdcError


def find_line(text: str, path: str) -> int | None:
    """Best-effort line number (1-based) of a dotted field in TOML text."""
    if not text:
        return None
    parts = path.split(".")
    lines = text.splitlines()
    # array-of-tables element: fluid[2].min
    m = re.match(r"^(\w+)\[(\d+)\]$", parts[0])
    start, end = 0, len(lines)
    if m:
        hdr = re.compile(r"^\s*\[\[\s*" + re.escape(m.group(1)) + r"\s*\]\]")
        hits = [i for i, ln in enumerate(lines) if hdr.match(ln)]
        k = int(m.group(2))
        if k >= len(hits):
            return None
        start = hits[k]
        if len(parts) == 1:
            return start + 1
        key = parts[-1]
    else:
        # longest table header that is a prefix of the path
        key = parts[-1]
        for n in range(len(parts), 0, -1):
            pat = re.compile(r"^\s*\[\s*" + r"\s*\.\s*".join(re.escape(p) for p in parts[:n])
                             + r"\s*\]\s*(#.*)?$")
            hits = [i for i, ln in enumerate(lines) if pat.match(ln)]
            if hits:
                if n == len(parts):
                    return hits[0] + 1
                start = hits[0]
                key = parts[n]
                break
        else:
            start = 0
    for i in range(start + (1 if start or m else 0), end):
        ln = lines[i]
        if i > start and re.match(r"^\s*\[", ln) and (m or start):
            break
        if re.match(r"^\s*" + re.escape(key) + r"\s*=", ln) or \
                re.search(r"[{,]\s*" + re.escape(key) + r"\s*=", ln):
            return i + 1
    return None


def field_error(text: str, source: str, path: str, msg: str) -> DcdcError:
    """The error "SOURCE: PATH MSG (line N)", the line where :func:`find_line` finds it."""
    line = find_line(text, path)
    return DcdcError(f"{source}: {path} {msg}" + (f" (line {line})" if line else ""))
