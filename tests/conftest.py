"""Fixtures shared by test modules: a real PostgreSQL server for the catalog tests."""

from __future__ import annotations

from typing import Iterator

import pytest

import pg_server


@pytest.fixture(scope="session")
def pg_server_instance() -> Iterator[pg_server.Server]:
    """A throwaway PostgreSQL server for the whole session (one per xdist worker).

    Fails (never skips) when no server can start: see tests/pg_server.py."""
    try:
        server = pg_server.start()
    except pg_server.PostgresUnavailable as exc:
        pytest.fail(f"PostgreSQL test server: {exc}", pytrace=False)
    yield server
    server.stop()


@pytest.fixture
def pg_url(pg_server_instance: pg_server.Server) -> str:
    """URL of a fresh, empty PostgreSQL database (one per test)."""
    return pg_server_instance.new_database()


@pytest.fixture(params=["sqlite", "postgresql"])
def catalog_target(request: pytest.FixtureRequest, tmp_path) -> str:
    """Where a test's catalog lives, once per backend: a SQLite file, a PostgreSQL URL."""
    if request.param == "sqlite":
        return str(tmp_path / "catalog.sqlite")
    return request.getfixturevalue("pg_url")
