"""`labjoint recover [--data DIR]`: close run files whose writer died (marked "incomplete"
with the samples all channels reached), delete temporary files of dead writers and
imports, and bring the catalog in line with the files: runs whose files are gone are
dropped, run files it lacks are indexed (the daemon closes dead writers' files at start)."""

from __future__ import annotations

import argparse
from pathlib import Path

from labjoint.cli.output import emit_json, terminal_safe


def add_recover_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--data", default=None, help="data directory (default: the config's data_dir)")


def run(args: argparse.Namespace) -> int:
    from labjoint.config import load_config
    from labjoint.errors import InputError
    from labjoint.storage.catalog import catalog_for
    from labjoint.storage.recover import recover_all

    cfg = load_config(args.config)
    data = Path(args.data or cfg.rig.data_dir)
    if not data.is_dir():
        raise InputError("no such data directory", file=str(data), field="--data")
    catalog = catalog_for(cfg, data)
    cleared: list[Path] = []
    unreadable: dict[str, str] = {}
    done = recover_all(data, catalog=catalog, cleared=cleared, unreadable=unreadable)
    stale = []
    for rec in catalog.query(status="running"):
        p = Path(rec.path)
        if not p.exists():
            catalog.remove(rec.name)
            stale.append(rec.name)
        elif p.parent.resolve() == data.resolve():
            catalog.add(p)             # re-read the file's own status
    synced = catalog.sync(data)
    stale += synced["removed"]
    for f, why in unreadable.items():
        synced["skipped"].setdefault(f, why)
    res = {"recovered": [str(p) for p in done], "cleared_flags": [str(p) for p in cleared],
           "removed_from_catalog": stale,
           "added_to_catalog": synced["added"], "not_indexed": synced["skipped"],
           "copies_not_indexed": synced["copies"],
           "still_running": [r.name for r in catalog.query(status="running")]}
    if args.json:
        emit_json(res)
        return 0
    for p in done:
        print(terminal_safe(f"recovered {p}: marked incomplete"))
    for p in cleared:
        print(terminal_safe(f"cleared {p}: open-for-write flags left by a dead writer "
                            "(e.g. a killed reprocess)"))
    for n in stale:
        print(terminal_safe(f"catalog: removed {n} (its file is gone)"))
    for n in synced["added"]:
        print(terminal_safe(f"catalog: added {n} (a run file it did not hold)"))
    for f, why in synced["skipped"].items():
        print(terminal_safe(f"catalog: not indexed {f}: {why}"))
    for name, files in synced["copies"].items():
        held = catalog.get(name)
        print(terminal_safe(
            f"catalog: {len(files)} cop{'y' if len(files) == 1 else 'ies'} of run {name} not "
            f"indexed (the catalog holds {held.path if held else 'it'}), e.g. {files[0]}"))
    for n in res["still_running"]:
        print(terminal_safe(f"{n}: still being written by a live process"))
    if not (done or cleared or stale or synced["added"] or synced["skipped"] or synced["copies"]
            or res["still_running"]):
        print("nothing to recover")
    return 0
