"""The catalog several machines share (issue 16 item 5): the same schema and queries on
SQLite and a real PostgreSQL server, versioned migrations, concurrent writers and
openers in separate processes, the CLI on a PostgreSQL catalog, and clear errors for an
unreachable server or wrong credentials."""

from __future__ import annotations

import asyncio
import json
import multiprocessing
import sqlite3

import httpx
import pytest

from labjoint.cli.main import main
from labjoint.config import CONFIG_DIR
from labjoint.errors import ConfigError, InputError
from labjoint.storage import Catalog, RunRecord
from labjoint.storage.migrations import MIGRATIONS, Migration, current_version, migrate
from labjoint.storage.sqldb import Database, redact_url
from pg_server import free_port

N_PROCS, N_ROWS = 4, 25
RESULT_COLUMNS = ["run", "pipeline", "options_hash", "version", "status", "computed_at",
                  "labjoint_version", "input_sha256", "options", "summary", "error"]


def _columns(db: Database, table: str) -> list[str]:
    if db.dialect == "sqlite":
        return [r["name"] for r in db.fetchall(f"PRAGMA table_info({table})")]
    return [r["column_name"] for r in db.fetchall(
        "SELECT column_name FROM information_schema.columns WHERE table_name = ? "
        "ORDER BY ordinal_position", [table])]


def test_migrations_are_versioned_and_applied_once(catalog_target):
    cat = Catalog(catalog_target)
    rows = cat.sql.fetchall("SELECT version, description FROM schema_version ORDER BY version")
    assert [r["version"] for r in rows] == [m.version for m in MIGRATIONS] == [1, 2]
    assert _columns(cat.sql, "results") == RESULT_COLUMNS
    assert migrate(cat.sql) == [] and current_version(Catalog(catalog_target).sql) == 2
    # adding a table later is one entry in the list
    more = (*MIGRATIONS, Migration(3, "notes", ("CREATE TABLE notes (k TEXT PRIMARY KEY)",)))
    assert migrate(cat.sql, more) == [3] and migrate(cat.sql, more) == []
    assert _columns(cat.sql, "notes") == ["k"]
    # a catalog migrated by a newer labjoint is refused, not misread
    with pytest.raises(ConfigError, match="schema version 3, newer than this labjoint knows"):
        Catalog(catalog_target)


def test_other_modules_run_their_sql_through_the_catalogs_adapter(catalog_target):
    """What the reprocess results module does: an upsert keyed by (run, pipeline,
    options_hash) through :attr:`Catalog.sql`, one row per key, the last write kept."""
    cat = Catalog(catalog_target)
    sql = cat.sql.upsert_sql("results", RESULT_COLUMNS, ["run", "pipeline", "options_hash"])
    for version, status in (("v1", "failed"), ("v2", "complete")):
        with cat.sql.transaction() as tx:
            tx.execute(sql, ["r1", "analyze", "h", version, status, "2026-01-01T00:00:00Z",
                             "0.1", "ab" * 32, "{}", '{"k": 1.5}', None])
    rows = cat.sql.fetchall("SELECT * FROM results WHERE run = ?", ["r1"])
    assert len(rows) == 1 and rows[0]["version"] == "v2" and rows[0]["error"] is None
    with pytest.raises(RuntimeError), cat.sql.transaction() as tx:     # rolled back
        tx.execute("DELETE FROM results")
        raise RuntimeError("stop")
    assert cat.sql.fetchone("SELECT COUNT(*) AS n FROM results")["n"] == 1


def test_a_catalog_from_before_versioning_is_adopted(tmp_path):
    """The SQLite file earlier labjoint versions wrote (no schema_version) keeps its rows."""
    path = tmp_path / "catalog.sqlite"
    con = sqlite3.connect(path)
    con.execute("CREATE TABLE runs (name TEXT PRIMARY KEY, path TEXT NOT NULL, uid TEXT, "
                "plan TEXT, plan_step, frequency_hz REAL, excitation_vpp REAL, torque_nm REAL, "
                "normal_force_n REAL, sample_rate_hz REAL, n_samples INTEGER, status TEXT, "
                "start_time TEXT, start_ts REAL, end_time TEXT, source TEXT, extra TEXT)")
    con.execute("INSERT INTO runs (name, path, torque_nm, plan_step, extra) "
                "VALUES ('old', '/x/old.h5', 5.0, 3, '{\"operator\": \"ms\"}')")
    con.commit()
    con.close()
    cat = Catalog(path)
    rec = cat.get("old")
    assert rec.torque_nm == 5.0 and rec.plan_step == 3 and rec.metadata == {"operator": "ms"}
    assert current_version(cat.sql) == 2 and [r.name for r in cat.query(torque_nm=5)] == ["old"]


def _record(name: str, i: int) -> RunRecord:
    return RunRecord(name=name, path=f"/shared/runs/{name}.h5", uid=f"uid-{name}", plan="p",
                     plan_step=i, torque_nm=float(i % 5), excitation_vpp=0.5 * i,
                     status="complete", start_time="2026-03-01T10:00:00+00:00",
                     metadata={"worker": name.split("_")[0]})


def _writer(target: str, worker: int, barrier) -> None:
    cat = Catalog(target)
    barrier.wait()
    for i in range(N_ROWS):
        cat.put(_record(f"w{worker}_{i:03d}", i))
        cat.put(_record("shared", 1))            # every writer upserts the same row too
        assert cat.get(f"w{worker}_{i:03d}").excitation_vpp == 0.5 * i


def _opener(target: str, barrier) -> None:
    barrier.wait()
    Catalog(target).put(_record(f"opened_{multiprocessing.current_process().name}", 0))


def _in_processes(target, args_of, n=N_PROCS):
    ctx = multiprocessing.get_context("fork")
    barrier = ctx.Barrier(n)
    procs = [ctx.Process(target=target, args=(*args_of(k), barrier), name=f"p{k}")
             for k in range(n)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(120)
    return [p.exitcode for p in procs]


def test_concurrent_writers_in_separate_processes(catalog_target):
    parent = Catalog(catalog_target)
    parent.put(_record("before", 0))       # the parent's kept connection, inherited by forks
    codes = _in_processes(_writer, lambda k: (catalog_target, k))
    assert codes == [0] * N_PROCS
    assert len(parent) == N_PROCS * N_ROWS + 2
    for k in range(N_PROCS):
        names = [r.name for r in parent.query(search=f"w{k}_", order="name")]
        assert names == [f"w{k}_{i:03d}" for i in range(N_ROWS)]
    assert parent.get("shared").metadata == {"worker": "shared"}
    assert parent.count(torque_nm=0) == N_PROCS * 5 + 1     # i % 5 == 0 of each, and "before"
    parent.put(_record("after", 2))        # the forks did not end the parent's session
    assert parent.get("after").plan_step == 2


def _same_name(target: str, path: str, barrier) -> None:
    cat = Catalog(target)
    barrier.wait()
    try:
        cat.put(RunRecord(name="dup", path=path, uid=path))
    except InputError as exc:
        assert "already holds a run named 'dup'" in str(exc)
        raise SystemExit(3) from None


def test_two_machines_adding_one_name_one_wins_the_others_are_refused(catalog_target,
                                                                     tmp_path):
    files = []
    for k in range(N_PROCS):
        files.append(tmp_path / f"m{k}" / "dup.h5")
        files[-1].parent.mkdir()
        files[-1].write_bytes(b"")
    codes = _in_processes(_same_name, lambda k: (catalog_target, str(files[k])))
    assert sorted(codes) == [0] + [3] * (N_PROCS - 1)
    winner = files[codes.index(0)]
    assert Catalog(catalog_target).get("dup").path == str(winner)


def test_concurrent_first_open_migrates_once(catalog_target):
    codes = _in_processes(_opener, lambda k: (catalog_target,))
    assert codes == [0] * N_PROCS
    cat = Catalog(catalog_target)
    versions = [r["version"] for r in cat.sql.fetchall("SELECT version FROM schema_version")]
    assert sorted(versions) == [1, 2]
    assert sorted(r.name for r in cat.query()) == [f"opened_p{k}" for k in range(N_PROCS)]


def test_unreachable_server_or_wrong_password_is_one_clear_error(pg_server_instance, tmp_path,
                                                                 capsys):
    secret = "hunter2-not-shown"
    refused = f"postgresql://lab:{secret}@127.0.0.1:{free_port()}/labjoint"
    wrong = pg_server_instance.database_url("postgres").replace(
        f":{pg_server_instance.password}@", f":{secret}@")
    for url, why in ((refused, "refused"), (wrong, "password authentication failed")):
        with pytest.raises(ConfigError) as info:
            Catalog(url)
        msg = str(info.value)
        assert f"cannot connect to the PostgreSQL catalog {redact_url(url)}" in msg
        assert why in msg and secret not in msg and msg.count("\n") == 0
    # through the CLI: the config names the URL, stderr names it without the password
    cfg = _config(tmp_path, refused)
    assert main(["runs", "--config", str(cfg), "--data", str(tmp_path / "d")]) != 0
    err = capsys.readouterr().err
    assert redact_url(refused) in err and secret not in err
    bad = tmp_path / "bad.toml"
    bad.write_text(cfg.read_text().replace(refused, "mysql://db/lab"))
    assert main(["runs", "--config", str(bad)]) != 0
    assert "rig.catalog_url" in capsys.readouterr().err


def _config(tmp_path, url: str):
    """The simulated rig's config with ``[rig] catalog_url = url``."""
    text = (CONFIG_DIR / "rig-sim.toml").read_text()
    assert '\ndata_dir = "data"\n' in text
    cfg = tmp_path / "rig.toml"
    cfg.write_text(text.replace('\ndata_dir = "data"\n',
                                f'\ndata_dir = "data"\ncatalog_url = "{url}"\n'))
    return cfg


def test_simulated_runs_recorded_and_queried_through_a_postgresql_catalog(pg_url, tmp_path,
                                                                          capsys):
    """`labjoint simulate` and `labjoint runs` with ``catalog_url`` in the config: the rows
    live in PostgreSQL (no SQLite file in the data directory) and the query finds them."""
    cfg, data = _config(tmp_path, pg_url), tmp_path / "data"
    assert main(["simulate", "--sweep", "2,6", "--frequency", "400", "--torque", "5",
                 "--cycles", "3", "--sample-rate", "10000", "--out", str(data),
                 "--config", str(cfg), "--json", "--quiet"]) == 0
    capsys.readouterr()
    assert not (data / "catalog.sqlite").exists()
    assert main(["runs", "--config", str(cfg), "--data", str(data), "--vpp", "1:3",
                 "--json"]) == 0
    runs = json.loads(capsys.readouterr().out)["runs"]
    assert [(r["excitation_vpp"], r["torque_nm"], r["status"]) for r in runs] == \
        [(2.0, 5.0, "complete")]
    assert runs[0]["path"].startswith(str(data.resolve()))
    assert main(["runs", "--config", str(cfg), "--data", str(data), "--json"]) == 0
    assert len(json.loads(capsys.readouterr().out)["runs"]) == 2 == len(Catalog(pg_url))
    # the REST service built from the same config answers /runs from PostgreSQL
    from labjoint.api.server import build

    svc = build(cfg, data_dir=data, port=0, daemon=False, log_level="warning", env={})
    assert svc.app.state.catalog.location == redact_url(pg_url)

    async def get():
        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=svc.app),
                                     base_url="http://127.0.0.1:8000") as http:
            return await http.get("/api/v1/runs", params={"vpp_min": 5})
    r = asyncio.run(get())
    assert r.status_code == 200, r.text
    assert [(x["excitation_vpp"], x["status"]) for x in r.json()["items"]] == [(6.0, "complete")]


def test_missing_postgresql_binaries_fail_with_how_to_install():
    """The fixture fails (never skips) when the server cannot start; the reason says how."""
    import pg_server

    with pytest.raises(pg_server.PostgresUnavailable, match="make postgres"):
        pg_server.find_binary("initdb-that-does-not-exist")
    assert pg_server.find_binary("initdb").endswith("/initdb")


def test_reprocess_records_its_results_in_a_postgresql_catalog(pg_url, tmp_path, capsys):
    """`labjoint reprocess` with ``catalog_url`` in the config: results land in the shared
    catalog's results table (migration 2), and a second reprocess finds them and does nothing."""
    cfg, data = _config(tmp_path, pg_url), tmp_path / "data"
    assert main(["simulate", "--sweep", "4,8", "--frequency", "400", "--torque", "5",
                 "--cycles", "12", "--sample-rate", "20000", "--out", str(data),
                 "--config", str(cfg), "--json", "--quiet"]) == 0
    capsys.readouterr()
    argv = ["reprocess", "--config", str(cfg), "--data-dir", str(data), "--pipeline", "analyze",
            "--scheduler", "none", "--json"]
    assert main(argv) == 0
    first = json.loads(capsys.readouterr().out)
    assert (first["computed"], first["failed"]) == (2, 0)
    rows = Catalog(pg_url).sql.fetchall("SELECT run, status FROM results ORDER BY run")
    assert [r["status"] for r in rows] == ["complete", "complete"]
    assert main(argv) == 0
    again = json.loads(capsys.readouterr().out)
    assert (again["computed"], again["skipped"]) == (0, 2)
