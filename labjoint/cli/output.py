"""Console output for the CLI: JSON on stdout, tables, a progress bar on stderr."""

from __future__ import annotations

import json
import logging
import math
import sys
from typing import Any, Iterable, Sequence


def _clean(obj: Any) -> Any:
    """Make numpy scalars/arrays and non-finite floats JSON-safe (NaN -> null)."""
    try:
        import numpy as np
    except ImportError:  # pragma: no cover
        np = None
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if np is not None and isinstance(obj, np.ndarray):
        return _clean(obj.tolist())
    if np is not None and isinstance(obj, np.generic):
        return _clean(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


_NAMED = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}


def terminal_safe(text: Any) -> str:
    r"""``text`` with everything a terminal would act on escaped: control characters
    (ESC sequences, bell, backspace, newlines: one line stays one line), other
    unprintable code points, and raw bytes a file name or file carried in
    (``surrogateescape``) as ``\xNN``. Printable text, accents included, is kept.

    >>> print(terminal_safe("bad '\x1b[2J\x07' in r\u00e9sum\u00e9.csv\nline 2 \udcff"))
    bad '\x1b[2J\x07' in résumé.csv\nline 2 \xff
    """
    out = []
    for ch in str(text):
        o = ord(ch)
        if 0xDC80 <= o <= 0xDCFF:              # a byte that was not UTF-8
            out.append(f"\\x{o - 0xDC00:02x}")
        elif ch.isprintable():
            out.append(ch)
        elif ch in _NAMED:
            out.append(_NAMED[ch])
        elif o < 0x100:
            out.append(f"\\x{o:02x}")
        else:
            out.append(f"\\u{o:04x}" if o < 0x10000 else f"\\U{o:08x}")
    return "".join(out)


class TerminalLog(logging.Handler):
    """Log records (warnings and up) on the current ``sys.stderr``, one line each, made
    :func:`terminal_safe` (a file name a warning quotes may carry raw bytes)."""

    def emit(self, record: logging.LogRecord) -> None:
        try:
            sys.stderr.write(terminal_safe(self.format(record)) + "\n")
        except Exception:                      # pragma: no cover - logging never raises
            self.handleError(record)


def install_terminal_log() -> None:
    """Route the root logger's output through :class:`TerminalLog` (once per process;
    where the application configured logging itself, nothing changes)."""
    root = logging.getLogger()
    if not root.handlers:
        handler = TerminalLog(logging.WARNING)
        handler.setFormatter(logging.Formatter("%(message)s"))
        root.addHandler(handler)


def emit_json(obj: Any) -> None:
    """Print exactly one JSON object on stdout."""
    sys.stdout.write(json.dumps(_clean(obj)) + "\n")
    sys.stdout.flush()


def fmt(value: Any, digits: int = 4) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        if not math.isfinite(value):
            return "-"
        return f"{value:.{digits}g}"
    return str(value)


def table(headers: Sequence[str], rows: Iterable[Sequence[Any]], digits: int = 4) -> str:
    """A plain aligned text table."""
    cells = [[terminal_safe(fmt(c, digits)) for c in r] for r in rows]
    widths = [max([len(h)] + [len(r[i]) for r in cells]) for i, h in enumerate(headers)]
    line = "  ".join(h.rjust(w) for h, w in zip(headers, widths))
    out = [line, "  ".join("-" * w for w in widths)]
    out += ["  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in cells]
    return "\n".join(out)


class Progress:
    """A text progress bar on stderr (silent when disabled or not a terminal-like use)."""

    def __init__(self, total: int, label: str = "", enabled: bool = True, width: int = 30) -> None:
        self.total = max(int(total), 1)
        self.label = label
        self.enabled = enabled
        self.width = width
        self.done = 0

    def advance(self, n: int = 1, note: str = "") -> None:
        self.done = min(self.done + n, self.total)
        if not self.enabled:
            return
        frac = self.done / self.total
        bar = "#" * int(frac * self.width)
        sys.stderr.write(f"\r{self.label} [{bar:<{self.width}}] {self.done}/{self.total} {note[:40]:<40}")
        if self.done >= self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()
