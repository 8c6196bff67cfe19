"""A catalog shared by two data directories (two machines on one PostgreSQL catalog, or
two archives in one SQLite file): rebuilding or syncing one directory leaves the other's
runs alone; sync indexes run files the catalog lacks and drops runs whose files are gone;
`labjoint recover` reports both."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from labjoint.cli.main import main
from labjoint.storage import Catalog
from test_storage_fixtures import write_run


@pytest.fixture()
def shared(tmp_path, catalog_target):
    cat = Catalog(catalog_target)
    a, b = tmp_path / "machine_a", tmp_path / "machine_b"
    for d, names in ((a, ("a1", "a2", "a3")), (b, ("b1", "b2"))):
        for i, n in enumerate(names):
            write_run(d, n, np.full((4, 20), 0.1 * i), catalog=cat,
                      metadata={"torque_nm": 5.0 + i})
    return cat, a, b


def _names(cat):
    return sorted(r.name for r in cat.query())


def test_rebuilding_one_directory_keeps_the_other_directorys_runs(shared):
    cat, a, b = shared
    (a / "a2.h5").unlink()
    (a / "junk.h5").write_text("not a run file")
    assert cat.rebuild(a) == 2
    assert _names(cat) == ["a1", "a3", "b1", "b2"]
    assert cat.get("b1").torque_nm == 5.0


def test_sync_indexes_files_it_lacks_and_drops_runs_whose_files_are_gone(shared, tmp_path):
    cat, a, b = shared
    outside = tmp_path / "elsewhere"
    write_run(outside, "c1", np.zeros((4, 20)), metadata={"torque_nm": 9.0})  # not catalogued
    shutil.copy(outside / "c1.h5", a / "c1.h5")                # copied into the archive
    (a / "a1.h5").unlink()
    (b / "b2.h5").unlink()                                     # the other directory: left alone
    (a / "broken.h5").write_bytes(b"\x89HDF\r\n")
    got = cat.sync(a)
    assert got["added"] == ["c1"] and got["removed"] == ["a1"]
    assert list(got["skipped"]) == [str(a / "broken.h5")]
    assert _names(cat) == ["a2", "a3", "b1", "b2", "c1"]
    assert cat.get("c1").torque_nm == 9.0 and cat.get("c1").path == str((a / "c1.h5").resolve())
    again = cat.sync(a)
    assert again["added"] == [] and again["removed"] == []     # idempotent


def test_sync_does_not_index_a_second_file_under_a_name_the_catalog_holds(shared, tmp_path):
    cat, a, b = shared
    other = tmp_path / "other"
    write_run(other, "b1", np.ones((4, 20)), uid="another-uid")   # same name, other run
    shutil.copy(other / "b1.h5", a / "b1.h5")
    got = cat.sync(a)
    assert got["added"] == []
    assert "already holds a run named 'b1'" in got["skipped"][str(a / "b1.h5")]
    assert cat.get("b1").path == str((b / "b1.h5").resolve())


def test_recover_reports_what_it_changed_in_the_catalog(tmp_path, capsys):
    d = tmp_path / "data"
    cat = Catalog(d / "catalog.sqlite")
    for n in ("r1", "r2"):
        write_run(d, n, np.zeros((4, 20)), catalog=cat)
    write_run(tmp_path / "x", "r3", np.zeros((4, 20)))
    shutil.copy(tmp_path / "x" / "r3.h5", d / "r3.h5")
    (d / "r1.h5").unlink()
    assert main(["recover", "--data", str(d), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["removed_from_catalog"] == ["r1"] and res["added_to_catalog"] == ["r3"]
    assert sorted(r.name for r in Catalog(d / "catalog.sqlite").query()) == ["r2", "r3"]
    assert main(["recover", "--data", str(d)]) == 0
    assert "nothing to recover" in capsys.readouterr().out
