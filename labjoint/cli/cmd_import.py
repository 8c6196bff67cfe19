"""`labjoint import FILE|DIR... [--out DIR] [--map MAP.toml] [--table TABLE.csv] --json`:
what labs export (CSV, MATLAB .mat v5/v7.3, UFF 58, TDMS, HDF5) into run files, one per
test, through one channel map (:mod:`labjoint.storage.channel_map`) and an optional
per-file metadata table; CSV files in the import format (design.md) need no map.
A map is never ignored: a file it cannot serve is refused. A failed or interrupted
import (SIGINT, SIGTERM) leaves no partial file and no catalog row."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from labjoint.cli.output import Progress, emit_json


def add_import_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="files or directories: CSV in the import format, or any supported "
                        "file (CSV, .mat, .uff/.unv, .tdms, .h5) with --map")
    p.add_argument("--out", default=None, help="data directory (default: the config's data_dir)")
    p.add_argument("--name", default=None, help="run name (one file, no map; default: file stem)")
    p.add_argument("--map", default=None, metavar="MAP.toml",
                   help="channel map: which column/dataset/variable is which channel, its "
                        "quantity, units and role (configs/maps/bert.toml is an example); "
                        "'boucwen' for the Bouc-Wen benchmark's layout")
    p.add_argument("--table", default=None, metavar="TABLE.csv",
                   help="per-file/per-test metadata table (columns: file or test, then "
                        "frequency_hz, level, torque_nm, ...); replaces the map's [metadata.table]")


def run(args: argparse.Namespace) -> int:
    from labjoint.cli.signals import terminate_as_interrupt
    from labjoint.config import load_config
    from labjoint.errors import InputError
    from labjoint.storage.catalog import catalog_for
    from labjoint.storage.channel_map import is_legacy, load_channel_map, load_table, read_toml
    from labjoint.storage.foreign import FOREIGN_SUFFIXES, PRESETS, load_map

    raw: dict[str, Any] | None = None
    if args.map:
        raw = PRESETS[args.map] if args.map in PRESETS else read_toml(args.map)
    legacy = raw is not None and is_legacy(raw)
    if args.table and (raw is None or legacy):
        raise InputError("--table needs a channel map with quantity and units (--map)",
                         field="--table")
    if args.name and (len(args.files) > 1 or (raw is not None and not legacy)):
        raise InputError("--name needs exactly one file and no map naming tests (runs are "
                         "named after their tests)", field="--name")
    cmap = None
    if raw is not None and not legacy:
        cmap = load_channel_map(args.map)
        if args.table:
            cmap.table = load_table(args.table)
    old_map = load_map(args.map) if legacy else None
    for f in args.files:
        suffix = Path(f).suffix.lower()
        if raw is None and (Path(f).is_dir() or suffix not in (".csv", ".txt")):
            raise InputError("this file needs --map MAP.toml (which channel is what, its "
                             "quantity and units)", file=f, field="--map")
        if legacy and suffix not in FOREIGN_SUFFIXES:
            raise InputError(f"the map {args.map} is in the older column form (displacement_m, "
                             "force_N) for TDMS/HDF5 only; for this file write a map with "
                             "quantity and units per channel", file=f, field="--map")
    prepared = None
    if cmap is not None:                      # read and check everything before writing
        from labjoint.storage.importers import prepare_files

        prepared = prepare_files(args.files, cmap)
    cfg = load_config(args.config)
    out = Path(args.out or cfg.rig.data_dir)
    out.mkdir(parents=True, exist_ok=True)
    catalog = catalog_for(cfg, out)
    written: list[str] = []
    skipped: list[dict[str, str]] = []
    if prepared is not None:
        from labjoint.storage.importers import write_prepared

        with terminate_as_interrupt():
            res = write_prepared(*prepared, out, catalog)
        written, skipped = [str(p) for p in res.runs], res.skipped
    else:
        bar = Progress(len(args.files), "import", enabled=not (args.json or args.quiet))
        for f in args.files:
            with terminate_as_interrupt():
                written.append(str(_one(f, old_map, out, args.name, catalog)))
            bar.advance(note=Path(f).name)
    if args.json:
        emit_json({"runs": written, "skipped": skipped})
    else:
        for w in written:
            print(w)
        for s in skipped:
            print(f"skipped {s['test']} ({s['file']}): {s['reason']}")
    return 0


def _one(f: str, cmap: Any, out: Path, name: str | None, catalog: Any) -> Path:
    from labjoint.storage.csv_import import import_csv, import_parsed
    from labjoint.storage.foreign import read_foreign

    if cmap is not None:
        return import_parsed(read_foreign(f, cmap), out, name=name, catalog=catalog)
    return import_csv(f, out, name=name, catalog=catalog)
