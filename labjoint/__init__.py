"""labjoint: bolted-joint dynamics lab service.

Layers, lowest first (a layer never imports a higher one):
``errors``/``config`` -> ``hardware`` -> ``acquisition`` -> ``storage`` -> ``signal``
-> ``identify`` -> ``models`` -> ``compare`` -> ``api``/``cli``/``web``.
"""

__version__ = "0.1.0"


def _numba_cache_dir() -> None:
    """Compiled kernels are cached per state of the package's sources.

    numba's own cache checks only the file of the function it compiled, so a kernel that
    calls (or inlines) a function from another module keeps the old code after that module
    changes: a stale law with new parameters, silently. Keying the cache directory by the
    size and modification time of every source file (in the user's cache) makes any change
    recompile everything once. An explicit ``NUMBA_CACHE_DIR`` is left alone.
    """
    import hashlib
    import os
    from pathlib import Path

    if "NUMBA_CACHE_DIR" in os.environ:
        return
    root = Path(__file__).resolve().parent
    h = hashlib.sha1()
    for p in sorted(root.rglob("*.py")):
        st = p.stat()
        h.update(f"{p.relative_to(root)}:{st.st_size}:{st.st_mtime_ns};".encode())
    base = (Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "labjoint-numba"
            / hashlib.sha1(str(root).encode()).hexdigest()[:12])    # one per installation
    here = base / h.hexdigest()[:16]
    try:
        here.mkdir(parents=True, exist_ok=True)
        os.utime(here)
    except OSError:
        return                      # no writable cache: numba's default applies
    os.environ["NUMBA_CACHE_DIR"] = str(here)
    import shutil
    import time

    for old in base.iterdir():      # best effort: states unused for a day are removed
        try:
            if old != here and old.is_dir() and time.time() - old.stat().st_mtime > 86400:
                shutil.rmtree(old, ignore_errors=True)
        except OSError:
            pass


_numba_cache_dir()
