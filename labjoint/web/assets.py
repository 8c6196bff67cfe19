"""The dashboard's files answered from memory, gzip-compressed once, with ETags.

A page load asks for a dozen small files at once; answering each on the event loop from
memory (no worker-thread hops to stat, open and read the file, no compression per
request) keeps every one at well under a millisecond of server time. A file changed on
disk is read again (its modification time and size are checked on each request), so
editing the page needs no restart. Only the files found under the directory are
served: any other path, including one with ``..``, is a 404.
"""

from __future__ import annotations

import gzip
import hashlib
import mimetypes
from dataclasses import dataclass
from email.utils import formatdate
from pathlib import Path
from typing import Any

from starlette.datastructures import Headers
from starlette.responses import PlainTextResponse, Response
from starlette.types import Receive, Scope, Send

#: Files smaller than this are sent as they are (gzip's header would outweigh the gain).
GZIP_MIN_BYTES = 500
# ES modules must be served with a JavaScript MIME type whatever /etc/mime.types says.
mimetypes.add_type("text/javascript", ".js")
mimetypes.add_type("text/css", ".css")
mimetypes.add_type("image/svg+xml", ".svg")

#: Types sent compressed to clients that accept gzip.
COMPRESSIBLE = ("text/", "application/json", "application/javascript", "image/svg+xml")


@dataclass(frozen=True)
class Asset:
    """One file's bytes, gzip-compressed bytes (None when not worth it) and headers."""

    stamp: tuple[int, int]          # (mtime_ns, size) when read
    body: bytes
    gzipped: bytes | None
    media_type: str
    etag: str
    last_modified: str


def read_asset(path: Path) -> Asset:
    """``path`` read, hashed and (when it pays) compressed."""
    st = path.stat()
    body = path.read_bytes()
    media = mimetypes.guess_type(path.name)[0] or "application/octet-stream"
    if media.startswith("text/") or media == "application/javascript":
        media += "; charset=utf-8"
    gz = None
    if len(body) >= GZIP_MIN_BYTES and media.startswith(COMPRESSIBLE):
        gz = gzip.compress(body, compresslevel=9, mtime=0)
        gz = gz if len(gz) < len(body) else None
    return Asset((st.st_mtime_ns, st.st_size), body, gz, media,
                 '"' + hashlib.sha256(body).hexdigest()[:32] + '"',
                 formatdate(st.st_mtime, usegmt=True))


class MemoryAssets:
    """ASGI app serving the files under ``directory`` (GET and HEAD) from memory."""

    def __init__(self, directory: str | Path, headers: dict[str, str] | None = None) -> None:
        self.root = Path(directory)
        self.headers = dict(headers or {})
        self._names: set[str] = set()
        self._cache: dict[str, Asset] = {}
        self._scan()

    def _scan(self) -> None:
        self._names = {p.relative_to(self.root).as_posix() for p in self.root.rglob("*")
                       if p.is_file()}

    def asset(self, name: str) -> Asset | None:
        """The file ``name`` (relative, posix) if it is one of the directory's files."""
        if name not in self._names:
            self._scan()                      # a file added since: served from now on
            if name not in self._names:
                return None
        path = self.root / name
        try:
            st = path.stat()
        except OSError:
            self._names.discard(name)
            self._cache.pop(name, None)
            return None
        hit = self._cache.get(name)
        if hit is None or hit.stamp != (st.st_mtime_ns, st.st_size):
            hit = self._cache[name] = read_asset(path)
        return hit

    def response(self, asset: Asset, request_headers: Headers, head: bool = False) -> Response:
        """200 (gzipped when accepted and worth it), or 304 when the client's copy is current."""
        headers = {**self.headers, "ETag": asset.etag, "Last-Modified": asset.last_modified,
                   "Vary": "Accept-Encoding"}
        if asset.etag in [t.strip() for t in request_headers.get("if-none-match", "").split(",")]:
            return Response(status_code=304, headers=headers)
        body = asset.body
        if asset.gzipped is not None and "gzip" in request_headers.get("accept-encoding", ""):
            body = asset.gzipped
            headers["Content-Encoding"] = "gzip"
        resp = Response(b"" if head else body, media_type=asset.media_type, headers=headers)
        if head:
            resp.headers["content-length"] = str(len(body))
        return resp

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        assert scope["type"] == "http"
        method = scope["method"]
        if method not in ("GET", "HEAD"):
            resp: Any = PlainTextResponse("Method Not Allowed", 405, headers={"Allow": "GET, HEAD"})
        else:
            path, root = scope["path"], scope.get("root_path", "")
            name = (path[len(root):] if root and path.startswith(root + "/") else path).lstrip("/")
            asset = self.asset(name)
            resp = (PlainTextResponse("Not Found", 404) if asset is None
                    else self.response(asset, Headers(scope=scope), head=method == "HEAD"))
        await resp(scope, receive, send)
