"""Settings of the REST service: the ``[api]`` table of the rig config plus environment.

Keys of ``[api]`` (all optional)::

    [api]
    host = "127.0.0.1"            # bind address; anything else must be asked for
    port = 8000
    control_tokens = []           # tokens allowed to move hardware or write (also read)
    read_tokens = []              # tokens allowed to read
    read_requires_token = false   # true: every read endpoint needs a read or control token
    allowed_origins = []          # other web pages allowed to write (own page always is)
    max_request_bytes = 1048576   # larger request bodies are refused with 413
    analysis_workers = 2          # threads running analysis/model jobs
    max_points = 20000            # most points one data slice may return
    reprocess_scheduler = "local" # reprocess jobs: "local" (a Dask LocalCluster per job),
                                  # "none" (in the job's thread) or tcp://HOST:PORT

Environment: ``LABJOINT_API_TOKEN`` and ``LABJOINT_API_READ_TOKEN`` add a control and a
read token (each may hold several, comma-separated), so secrets need not live in files.

>>> s = ApiSettings(data_dir="/tmp/x", control_tokens=["control-1"], read_tokens=["reader-1"])
>>> s.scope_of("control-1"), s.scope_of("reader-1"), s.scope_of("nope")
('control', 'read', None)
"""

from __future__ import annotations

import hmac
import os
from pathlib import Path
from typing import Any, Literal, Mapping

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from labjoint.errors import ConfigError
from labjoint.tomlfile import read_toml

ENV_CONTROL = "LABJOINT_API_TOKEN"
ENV_READ = "LABJOINT_API_READ_TOKEN"
MIN_TOKEN_CHARS = 8

Scope = Literal["read", "control"]


class ApiSettings(BaseModel):
    """Everything :func:`labjoint.api.app.create_app` needs besides the daemon and queue."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    data_dir: Path
    host: str = "127.0.0.1"
    #: names a request's Host header may carry (DNS rebinding); empty: loopback names, the
    #: bound address, and on a wildcard bind this machine's name and addresses
    allowed_hosts: tuple[str, ...] = ()
    #: web pages of other origins allowed to write (``https://lab.example``); the
    #: service's own page always is (labjoint.api.hosts.OriginCheck)
    allowed_origins: tuple[str, ...] = ()
    port: int = Field(8000, ge=0, le=65535)
    control_tokens: tuple[str, ...] = ()
    read_tokens: tuple[str, ...] = ()
    read_requires_token: bool = False
    max_request_bytes: int = Field(1 << 20, ge=1024)
    analysis_workers: int = Field(2, ge=1, le=64)
    max_points: int = Field(20000, ge=10, le=1_000_000)
    #: the run catalog ([rig] catalog_url of the config): "" = data_dir/catalog.sqlite
    catalog_url: str = ""
    reprocess_scheduler: str = Field("local", pattern=r"^(local|none|(tcp|tls)://\S+)$")

    @field_validator("control_tokens", "read_tokens")
    @classmethod
    def _tokens(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        for t in v:
            if len(t) < MIN_TOKEN_CHARS or any(c.isspace() for c in t):
                raise ValueError(f"tokens need at least {MIN_TOKEN_CHARS} characters and no "
                                 "whitespace")
        return tuple(dict.fromkeys(v))

    def host_names(self) -> set[str]:
        """The Host names this service answers to (lower case, without port)."""
        if self.allowed_hosts:
            return {h.lower().strip("[]") for h in self.allowed_hosts}
        names = {"localhost", "127.0.0.1", "::1", self.host.lower().strip("[]")}
        if self.host in ("0.0.0.0", "::", ""):
            import socket
            name = socket.gethostname()
            names |= {name.lower(), socket.getfqdn().lower()}
            try:
                names |= set(socket.gethostbyname_ex(name)[2])
            except OSError:
                pass
        return names

    def scope_of(self, token: str | None) -> Scope | None:
        """'control', 'read' or None for ``token`` (constant-time comparisons)."""
        if not token:
            return None
        given = token.encode()
        control = any(hmac.compare_digest(given, t.encode()) for t in self.control_tokens)
        if control:
            return "control"
        if any(hmac.compare_digest(given, t.encode()) for t in self.read_tokens):
            return "read"
        return None


def _env_tokens(name: str, env: Mapping[str, str]) -> list[str]:
    return [t.strip() for t in env.get(name, "").split(",") if t.strip()]


def api_table(config_path: str | Path | None) -> dict[str, Any]:
    """The ``[api]`` table of a TOML config file ({} when absent or no file given)."""
    if config_path is None:
        return {}
    p = Path(config_path)
    data = read_toml(p, ConfigError, "config file")
    table = data.get("api", {})
    if not isinstance(table, dict):
        raise ConfigError("[api] must be a table", file=str(p), field="api")
    return table


def load_settings(data_dir: str | Path, config_path: str | Path | None = None,
                  env: Mapping[str, str] | None = None, **overrides: Any) -> ApiSettings:
    """Settings from ``[api]`` of ``config_path``, the environment and ``overrides``.

    Environment tokens are added to those of the file; ``overrides`` (e.g. host, port
    from the command line) win over both. Errors name the file and the key.
    """
    env = os.environ if env is None else env
    table = dict(api_table(config_path))
    table["control_tokens"] = list(table.get("control_tokens", [])) + _env_tokens(ENV_CONTROL, env)
    table["read_tokens"] = list(table.get("read_tokens", [])) + _env_tokens(ENV_READ, env)
    table.update({k: v for k, v in overrides.items() if v is not None})
    table["data_dir"] = Path(data_dir)
    try:
        return ApiSettings.model_validate(table)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = ".".join(str(x) for x in ("api", *err["loc"]))
        raise ConfigError(err["msg"], file=None if config_path is None else str(config_path),
                          field=loc) from None
