"""Fixtures shared by test modules: a real PostgreSQL server for the catalog tests."""

from __future__ import annotations

import os
from typing import Iterator

import pytest

# One BLAS thread per test process: `make test` runs one xdist worker per core, and a
# BLAS that adds its own threads oversubscribes the cores; its threads then spin waiting
# for each other (an SVD of a fit's tall Jacobian: 6x slower at load 11 on 2 cores).
# The variable reaches the CLI subprocesses; the limit, the BLAS already loaded here.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy  # noqa: E402,F401  (loads the BLAS the limit applies to)
import scipy.linalg  # noqa: E402,F401
from threadpoolctl import threadpool_limits  # noqa: E402

_ONE_BLAS_THREAD = threadpool_limits(limits=1, user_api="blas")

import pg_server  # noqa: E402


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
