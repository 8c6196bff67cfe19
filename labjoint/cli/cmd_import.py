"""`labjoint import CSV... [--out DIR]`: CSV files (design.md format) into run files."""

from __future__ import annotations

import argparse
from pathlib import Path

from labjoint.cli.output import Progress, emit_json


def add_import_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("files", nargs="+", metavar="CSV", help="CSV file(s) in the import format")
    p.add_argument("--out", default=None, help="data directory (default: the config's data_dir)")
    p.add_argument("--name", default=None, help="run name (one file only; default: file stem)")


def run(args: argparse.Namespace) -> int:
    from labjoint.config import load_config
    from labjoint.errors import InputError
    from labjoint.storage.catalog import Catalog
    from labjoint.storage.csv_import import import_csv

    if args.name and len(args.files) > 1:
        raise InputError("--name needs exactly one CSV file", field="--name")
    out = Path(args.out or load_config(args.config).rig.data_dir)
    out.mkdir(parents=True, exist_ok=True)
    catalog = Catalog(out / "catalog.sqlite")
    bar = Progress(len(args.files), "import", enabled=not (args.json or args.quiet))
    written = []
    for f in args.files:
        written.append(str(import_csv(f, out, name=args.name, catalog=catalog)))
        bar.advance(note=Path(f).name)
    if args.json:
        emit_json({"runs": written})
    else:
        for w in written:
            print(w)
    return 0
