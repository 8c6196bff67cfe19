"""Catalog: runs indexed by metadata; one query answers "5 Nm between 1 and 20 Vpp".

Every test runs on both backends: the embedded SQLite file and a real PostgreSQL server."""

from __future__ import annotations

import sqlite3

import numpy as np
import pytest

from labjoint.errors import InputError
from labjoint.storage import Catalog
from test_storage_fixtures import write_run

# (name, torque Nm, Vpp, frequency Hz, status, start time) of seed 002's sweeps, plus edge cases
RUNS = [
    ("t5_v1", 5.0, 1.0, 400.0, "complete", "2026-03-01T10:00:00+00:00"),
    ("t5_v10", 5.0, 10.0, 400.0, "complete", "2026-03-01T11:00:00+00:00"),
    ("t5_v20", 5.0, 20.0, 400.0, "complete", "2026-03-01T12:00:00+00:00"),
    ("t5_v0p5", 5.0, 0.5, 400.0, "complete", "2026-03-01T09:00:00+00:00"),
    ("t5_v25", 5.0, 25.0, 400.0, "complete", "2026-03-01T13:00:00+00:00"),
    ("t3_v10", 3.0, 10.0, 400.0, "complete", "2026-03-02T10:00:00+00:00"),
    ("t8_v10", 8.0, 10.0, 200.0, "limit", "2026-03-03T10:00:00+00:00"),
    ("t4p999_v10", 4.999, 10.0, 400.0, "complete", "2026-03-04T10:00:00+00:00"),
    ("t5_v5_failed", 5.0, 5.0, 400.0, "failed", "2026-03-05T10:00:00+00:00"),
]


def _target(backend, request, directory):
    """A new catalog's place: a SQLite file in ``directory`` or a fresh PostgreSQL database."""
    if backend == "sqlite":
        return directory / "catalog.db"
    return request.getfixturevalue("pg_server_instance").new_database()


@pytest.fixture(scope="module", params=["sqlite", "postgresql"])
def catalog(request, tmp_path_factory):
    d = tmp_path_factory.mktemp("cat")
    cat = Catalog(_target(request.param, request, d))
    cat.test_data_dir = d / "data"
    for name, torque, vpp, f, status, t0 in RUNS:
        write_run(d / "data", name, np.zeros((4, 20)), catalog=cat, status=status,
                  metadata={"torque_nm": torque, "excitation_vpp": vpp, "frequency_hz": f,
                            "start_time": t0, "normal_force_n": 478.0 * torque,
                            "operator": "ms"})
    return cat


def _names(records):
    return sorted(r.name for r in records)


def test_5_nm_between_1_and_20_vpp_is_one_query(catalog):
    got = catalog.query(torque_nm=5, vpp=(1, 20))
    assert _names(got) == ["t5_v1", "t5_v10", "t5_v20", "t5_v5_failed"]
    assert _names(catalog.query(torque_nm=5, vpp=(1, 20), status="complete")) == \
        ["t5_v1", "t5_v10", "t5_v20"]


def test_query_counts_sql_statements(catalog, monkeypatch):
    """One SELECT, counted where every catalog statement passes (the adapter) and, on
    SQLite, by the driver itself."""
    from labjoint.storage.sqldb import Session

    through_adapter = []
    real_execute = Session.execute

    def spy_execute(self, sql, args=()):
        through_adapter.append(sql)
        return real_execute(self, sql, args)

    monkeypatch.setattr(Session, "execute", spy_execute)
    statements = []
    real = sqlite3.connect

    def spy(*a, **k):
        con = real(*a, **k)
        con.set_trace_callback(statements.append)
        return con

    monkeypatch.setattr(sqlite3, "connect", spy)
    catalog.query(torque_nm=5, vpp=(1, 20))
    assert len([s for s in through_adapter if s.lstrip().upper().startswith("SELECT")]) == 1
    if catalog.sql.dialect == "sqlite":
        assert len([s for s in statements if s.lstrip().upper().startswith("SELECT")]) == 1


def test_ranges_open_ends_lists_and_time_window(catalog):
    assert _names(catalog.query(torque_nm=(None, 4))) == ["t3_v10"]
    assert _names(catalog.query(torque_nm=(7, None))) == ["t8_v10"]
    assert _names(catalog.query(frequency_hz=200)) == ["t8_v10"]
    assert _names(catalog.query(status=["limit", "failed"])) == ["t5_v5_failed", "t8_v10"]
    assert _names(catalog.query(since="2026-03-03T00:00:00+00:00",
                                until="2026-03-04T23:00:00+00:00")) == ["t4p999_v10", "t8_v10"]
    assert _names(catalog.query(normal_force_n=(2389.9, 2500), vpp=10)) == ["t5_v10"]


def test_order_limit_offset(catalog):
    by_time = [r.name for r in catalog.query(order="start_time")]
    assert by_time[:3] == ["t5_v0p5", "t5_v1", "t5_v10"]
    assert [r.name for r in catalog.query(order="-excitation_vpp", limit=2)] == ["t5_v25", "t5_v20"]
    page = [r.name for r in catalog.query(order="start_time", limit=3, offset=3)]
    assert page == by_time[3:6]
    assert [r.name for r in catalog.query(order="start_time", offset=7)] == by_time[7:]


def test_records_carry_all_metadata(catalog):
    r = catalog.get("t8_v10")
    assert r.torque_nm == 8.0 and r.excitation_vpp == 10.0 and r.status == "limit"
    assert r.normal_force_n == pytest.approx(3824.0) and r.sample_rate_hz == 50_000.0
    assert r.n_samples == 20 and r.source == "acquired" and r.plan == "amplitude_sweep"
    assert r.metadata["operator"] == "ms" and r.path.endswith("t8_v10.h5")
    assert catalog.get("nope") is None


def test_filter_values_are_data_not_sql(catalog):
    assert catalog.query(status="complete' OR '1'='1") == []
    assert catalog.query(plan=["x); DROP TABLE runs; --"]) == []
    assert len(catalog) == len(RUNS)
    for bad in [dict(order="name; DROP TABLE runs"), dict(order="extra"),
                dict(torque_nm="five"), dict(vpp=(1, 2, 3)), dict(since="yesterday"),
                dict(vpp=1, excitation_vpp=1), dict(limit=-1)]:
        with pytest.raises(InputError):
            catalog.query(**bad)


def test_rebuild_from_files_gives_the_same_index(catalog, tmp_path, request):
    fresh = Catalog(_target(catalog.sql.dialect, request, tmp_path))
    data_dir = catalog.test_data_dir
    (data_dir / "junk.h5").write_text("not a run")
    assert fresh.rebuild(data_dir) == len(RUNS)
    q = dict(torque_nm=5, vpp=(1, 20))
    assert _names(fresh.query(**q)) == _names(catalog.query(**q))
    assert fresh.get("t3_v10") == catalog.get("t3_v10")
    (data_dir / "junk.h5").unlink()


def test_running_runs_are_indexed_at_start_and_updated_at_stop(tmp_path, catalog_target):
    from labjoint.documents import Block, RunStart, RunStop
    from labjoint.storage.writer import RunWriter
    from test_storage_fixtures import rig_channels

    cat = Catalog(catalog_target)
    w = RunWriter(tmp_path, catalog=cat)
    w("start", RunStart("u", "live", rig_channels(), 1000.0, {"torque_nm": 6.0}))
    assert cat.get("live").status == "running"
    w("block", Block("u", 0, np.zeros((4, 30))))
    w("stop", RunStop("u", "complete"))
    rec = cat.get("live")
    assert rec.status == "complete" and rec.n_samples == 30 and rec.end_time
    assert cat.remove("live") and cat.get("live") is None and not cat.remove("live")


def test_catalog_uses_wal(tmp_path):
    Catalog(tmp_path / "w.db")
    con = sqlite3.connect(tmp_path / "w.db")
    assert con.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    con.close()
