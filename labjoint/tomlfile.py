"""The one TOML file reader: a mapping, or an error naming the file (and line) that is wrong."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any

from labjoint.errors import InputError


def read_toml(path: str | Path, error: type[InputError] = InputError,
              what: str = "file") -> dict[str, Any]:
    """The table of the TOML file ``path``; a missing, unreadable, non-UTF-8 or invalid
    file raises ``error`` (an :class:`InputError` kind) naming the file and, for a syntax
    error, the line.

    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "rig.toml"
    >>> _ = p.write_text('[rig]\\nbackend = "sim"\\n')
    >>> read_toml(p)
    {'rig': {'backend': 'sim'}}
    >>> _ = p.write_text('[rig]\\nbackend = \\n')
    >>> try:
    ...     read_toml(p)
    ... except InputError as exc:
    ...     print(exc.line)
    2
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except FileNotFoundError:
        raise error(f"cannot read {what}: not found", file=str(p)) from None
    except OSError as exc:
        raise error(f"cannot read {what}: {exc.strerror or exc}", file=str(p)) from None
    try:
        return tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError:
        raise error("not UTF-8 text", file=str(p)) from None
    except tomllib.TOMLDecodeError as exc:
        line = re.search(r"at line (\d+)", str(exc))
        raise error(f"not valid TOML: {exc}", file=str(p),
                    line=int(line.group(1)) if line else None) from None
