"""Clipped channels of a run file (flat tops: :mod:`labjoint.signal.clipping`), for the
page's warnings: a run whose channel sat at its input range, and a friction coefficient
identified from such a run (issue 33 items 1 and 3). Scans are cached by the file's
identity and length."""

from __future__ import annotations

import threading
from collections import OrderedDict
from pathlib import Path
from typing import Any

from labjoint.api.errors import ApiError
from labjoint.errors import LabjointError
from labjoint.signal.clipping import MIN_FRACTION, flat_top_fraction
from labjoint.storage import RunFile

#: Scans kept (a few channel names each).
CACHE_SIZE = 256
_CACHE: OrderedDict[tuple[Any, ...], list[dict[str, Any]]] = OrderedDict()
_LOCK = threading.Lock()


def file_key(rf: RunFile, *what: Any) -> tuple[Any, ...]:
    """A key that changes when the run file does (path, mtime, size, samples)."""
    st = Path(rf.path).stat()
    return (str(Path(rf.path).resolve()), st.st_mtime_ns, st.st_size, rf.n_samples, *what)


#: Samples read at a time when scanning a run's channels for flat tops.
SCAN_SAMPLES = 1 << 18


def clipped_channels(rf: RunFile) -> list[dict[str, Any]]:
    """The stored channels that sat at their input range: flat tops over more than
    ``MIN_FRACTION`` of a block's samples (cached like the analysis)."""
    key = file_key(rf)
    with _LOCK:
        hit = _CACHE.get(key)
    if hit is None:
        hit = []
        for name in rf.channel_names:
            worst, level = 0.0, float("nan")
            for a in range(0, rf.n_samples, SCAN_SAMPLES):
                frac, lvl = flat_top_fraction(rf.physical(name, a, min(a + SCAN_SAMPLES,
                                                                       rf.n_samples)))
                if frac > worst:
                    worst, level = frac, lvl
            if worst > MIN_FRACTION:
                hit.append({"channel": name, "level": level, "unit": rf.channel(name).unit,
                            "fraction": worst})
        with _LOCK:
            _CACHE[key] = hit
            while len(_CACHE) > CACHE_SIZE:
                _CACHE.popitem(last=False)
    return list(hit)


def friction_flag(resolver: Any, source: str | None) -> str | None:
    """Why the friction coefficient from run ``source`` is not to be trusted (a clipped
    channel: the friction pipeline refuses such a run), or None (fine, or not a run of
    this archive)."""
    if not source:
        return None
    try:
        with resolver.open(source) as rf:
            clipped = clipped_channels(rf)
    except (ApiError, LabjointError, OSError):   # not a run of this archive (given by hand)
        return None
    if not clipped:
        return None
    what = "; ".join(f"{c['channel']} sat at {c['level']:.4g} {c['unit']}" for c in clipped)
    return (f"the friction coefficient comes from run {source}, which is clipped ({what}): "
            "the friction and loop pipelines refuse that run, so mu and every stick-slip value "
            "taken from it are not results; record the friction test again with a larger "
            "input range")
