"""`labjoint import FILE... [--out DIR] [--map MAP.toml]`: CSV files (design.md format), and
TDMS or HDF5 files through a channel map (:mod:`labjoint.storage.foreign`), into run files."""

from __future__ import annotations

import argparse
from pathlib import Path

from labjoint.cli.output import Progress, emit_json


def add_import_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="CSV file(s) in the import format, or TDMS/HDF5 files with --map")
    p.add_argument("--map", default=None, metavar="MAP.toml",
                   help="channel map for TDMS and HDF5 files (a TOML file, or 'boucwen' for "
                        "the Bouc-Wen benchmark's layout)")
    p.add_argument("--out", default=None, help="data directory (default: the config's data_dir)")
    p.add_argument("--name", default=None, help="run name (one file only; default: file stem)")


def run(args: argparse.Namespace) -> int:
    from labjoint.config import load_config
    from labjoint.errors import InputError
    from labjoint.storage.catalog import Catalog
    from labjoint.storage.csv_import import import_csv, import_parsed
    from labjoint.storage.foreign import FOREIGN_SUFFIXES, load_map, read_foreign

    if args.name and len(args.files) > 1:
        raise InputError("--name needs exactly one CSV file", field="--name")
    cmap = load_map(args.map) if args.map else None
    for f in args.files:
        foreign = Path(f).suffix.lower() in FOREIGN_SUFFIXES
        if foreign and cmap is None:
            raise InputError("a TDMS or HDF5 file needs --map MAP.toml (which channel is what)",
                             file=f, field="--map")
    out = Path(args.out or load_config(args.config).rig.data_dir)
    out.mkdir(parents=True, exist_ok=True)
    catalog = Catalog(out / "catalog.sqlite")
    bar = Progress(len(args.files), "import", enabled=not (args.json or args.quiet))
    written = []
    for f in args.files:
        if cmap is not None and Path(f).suffix.lower() in FOREIGN_SUFFIXES:
            path = import_parsed(read_foreign(f, cmap), out, name=args.name, catalog=catalog)
        else:
            path = import_csv(f, out, name=args.name, catalog=catalog)
        written.append(str(path))
        bar.advance(note=Path(f).name)
    if args.json:
        emit_json({"runs": written})
    else:
        for w in written:
            print(w)
    return 0
