"""The local server of ``thermoswarm view``: the standard library's ThreadingHTTPServer.

Safety, by construction:

- it listens on 127.0.0.1 unless another host is asked for (then the CLI warns);
- every URL starts with a random token (``secrets.token_urlsafe``): another local
  user's page or program that does not know it gets 404 for everything;
- the only files it serves are under the folder it was opened on (``/TOKEN/files/...``),
  after percent-decoding, with no ``..`` segment, and resolved (symbolic links
  included) inside that folder; anything else is 404;
- it answers GET and HEAD only, and sends ``no-store`` and ``nosniff`` headers.

Routes under ``/TOKEN/``: the page; ``api/meta`` (JSON); ``api/frame/K?var=NAME``
(float32 LE, see :mod:`thermoswarm.view.data`); ``api/series/I`` (JSON);
``api/video/K`` (JPEG); ``files/PATH``.
"""

from __future__ import annotations

import errno
import mimetypes
import secrets
import socket
import sys
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, unquote, urlsplit

from thermoswarm.errors import OutputError, ThermoswarmError
from thermoswarm.view.data import ViewData, to_json
from thermoswarm.view.page import page_html

__all__ = ["ViewServer", "start_server", "safe_file", "serve_in_thread", "warn_public"]


def safe_file(root: Path, rel: str) -> Path | None:
    """The file ``rel`` (percent-encoded URL path) under ``root``, or None if outside."""
    text = unquote(unquote(rel))  # a doubly encoded %252e%252e is caught too
    if "\x00" in text or "\\" in text:
        return None
    parts = [p for p in text.split("/") if p not in ("", ".")]
    if any(p == ".." for p in parts) or not parts:
        return None
    base = root.resolve()
    try:
        target = base.joinpath(*parts).resolve()
    except (OSError, RuntimeError):
        return None
    if not target.is_relative_to(base) or not target.is_file():
        return None
    return target


class _Handler(BaseHTTPRequestHandler):
    server: ViewServer
    protocol_version = "HTTP/1.1"

    def log_message(self, format: str, *args: Any) -> None:  # quiet: the page is chatty
        pass

    def setup(self) -> None:
        super().setup()
        # headers and body go out as two writes: without NODELAY, Nagle's algorithm and
        # the browser's delayed ACK hold small frames back by tens of milliseconds
        self.connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def _send(self, code: int, body: bytes, ctype: str) -> None:
        self.send_response(code)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        self.send_header("Referrer-Policy", "no-referrer")
        self.end_headers()
        if self.command != "HEAD":
            self.wfile.write(body)

    def _not_found(self) -> None:
        self._send(404, b"not found", "text/plain; charset=utf-8")

    def do_HEAD(self) -> None:
        self.do_GET()

    def do_GET(self) -> None:
        url = urlsplit(self.path)
        token = "/" + self.server.token
        raw = url.path
        if not (raw == token or raw.startswith(token + "/")):
            return self._not_found()
        rest = raw[len(token) :].lstrip("/")
        try:
            self._route(rest, parse_qs(url.query))
        except ThermoswarmError as exc:
            self._send(400, str(exc).encode(), "text/plain; charset=utf-8")
        except (BrokenPipeError, ConnectionResetError):
            pass
        except Exception as exc:  # the page shows this line; the server keeps serving
            line = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
            self._send(500, line.encode(), "text/plain; charset=utf-8")

    def _route(self, rest: str, query: dict[str, list[str]]) -> None:
        data = self.server.data
        if rest == "":
            return self._send(200, self.server.page, "text/html; charset=utf-8")
        if rest == "api/meta":
            return self._send(200, to_json(data.meta()).encode(), "application/json")
        head, _, arg = rest.rpartition("/")
        if head in ("api/frame", "api/series", "api/video") and arg.isdigit():
            k = int(arg)
            if head == "api/frame":
                var = query.get("var", [""])[0] or None
                body = data.frame_bytes(k, var)
                return self._send(200, body, "application/octet-stream")
            if head == "api/series":
                return self._send(200, to_json(data.series(k)).encode(), "application/json")
            if data.video is None:
                return self._not_found()
            return self._send(200, data.video.jpeg(k), "image/jpeg")
        if rest.startswith("files/"):
            target = safe_file(self.server.root, rest[len("files/") :])
            if target is None:
                return self._not_found()
            ctype = mimetypes.guess_type(target.name)[0] or "application/octet-stream"
            return self._send(200, target.read_bytes(), ctype)
        return self._not_found()


class ViewServer(ThreadingHTTPServer):
    """Serves one :class:`ViewData` and the files under ``root``."""

    daemon_threads = True
    allow_reuse_address = False

    def __init__(self, data: ViewData, root: Path, host: str, port: int) -> None:
        self.data = data
        self.root = Path(root)
        self.token = secrets.token_urlsafe(24)
        self.page = page_html().encode("utf-8")
        if ":" in host:
            self.address_family = socket.AF_INET6
        super().__init__((host, port), _Handler)

    @property
    def url(self) -> str:
        host, port = self.server_address[:2]
        shown = f"[{host}]" if ":" in str(host) else host
        return f"http://{shown}:{port}/{self.token}/"


def start_server(
    data: ViewData, root: str | Path, *, host: str = "127.0.0.1", port: int = 0
) -> ViewServer:
    """Bind the viewer's server (port 0: a free one); call ``serve_forever`` on it.

    Raises
    ------
    OutputError
        The port is taken or the address cannot be bound (one line, naming them).
    """
    try:
        return ViewServer(data, Path(root), host, int(port))
    except OSError as exc:
        if exc.errno == errno.EADDRINUSE:
            raise OutputError(
                f"port {port} on {host} is already taken; pass another --port, or --port 0 "
                "for a free one"
            ) from None
        raise OutputError(f"cannot listen on {host}:{port} ({exc.strerror or exc})") from None


def serve_in_thread(server: ViewServer) -> threading.Thread:
    """Run ``server`` in a daemon thread (tests, benchmarks); stop with ``shutdown()``."""
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    return thread


def warn_public(host: str) -> None:
    """The warning printed when the server listens beyond this machine."""
    if host not in ("127.0.0.1", "localhost", "::1"):
        print(
            f"warning: listening on {host}: other machines on the network can reach this "
            "viewer (anyone with the URL's token can read the data)",
            file=sys.stderr,
        )
