"""`labjoint import FILE... [--out DIR] [--map MAP.toml]`: CSV files (design.md format), and
TDMS or HDF5 files through a channel map (:mod:`labjoint.storage.foreign`), into run files.
A failed or interrupted import (SIGINT, SIGTERM) leaves no partial file and no catalog row."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from labjoint.cli.output import Progress, emit_json


def add_import_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="CSV file(s) in the import format, or TDMS/HDF5 files with --map")
    p.add_argument("--out", default=None, help="data directory (default: the config's data_dir)")
    p.add_argument("--name", default=None, help="run name (one file only; default: file stem)")
    p.add_argument("--map", default=None, metavar="MAP.toml",
                   help="channel map for TDMS and HDF5 files (a TOML file, or 'boucwen' for "
                        "the Bouc-Wen benchmark's layout)")


def run(args: argparse.Namespace) -> int:
    from labjoint.cli.signals import terminate_as_interrupt
    from labjoint.config import load_config
    from labjoint.errors import InputError
    from labjoint.storage.catalog import catalog_for
    from labjoint.storage.foreign import FOREIGN_SUFFIXES, load_map

    if args.name and len(args.files) > 1:
        raise InputError("--name needs exactly one CSV file", field="--name")
    cmap = load_map(args.map) if args.map else None
    for f in args.files:
        if Path(f).suffix.lower() in FOREIGN_SUFFIXES and cmap is None:
            raise InputError("a TDMS or HDF5 file needs --map MAP.toml (which channel is what)",
                             file=f, field="--map")
    cfg = load_config(args.config)
    out = Path(args.out or cfg.rig.data_dir)
    out.mkdir(parents=True, exist_ok=True)
    catalog = catalog_for(cfg, out)
    bar = Progress(len(args.files), "import", enabled=not (args.json or args.quiet))
    written = []
    for f in args.files:
        with terminate_as_interrupt():
            written.append(str(_one(f, cmap, out, args.name, catalog)))
        bar.advance(note=Path(f).name)
    if args.json:
        emit_json({"runs": written})
    else:
        for w in written:
            print(w)
    return 0


def _one(f: str, cmap: Any, out: Path, name: str | None, catalog: Any) -> Path:
    from labjoint.storage.csv_import import import_csv, import_parsed
    from labjoint.storage.foreign import FOREIGN_SUFFIXES, read_foreign

    if cmap is not None and Path(f).suffix.lower() in FOREIGN_SUFFIXES:
        return import_parsed(read_foreign(f, cmap), out, name=name, catalog=catalog)
    return import_csv(f, out, name=name, catalog=catalog)
