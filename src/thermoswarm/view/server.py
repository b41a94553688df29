"""The local server of ``thermoswarm view``: the standard library's ThreadingHTTPServer.

It serves one run and nothing else, by construction:

- no file route: the page and the run's own data (``api/...``) are the only answers;
  a sibling file of the opened run, or any other path, is 404;
- it listens on 127.0.0.1 unless another host is asked for (then the CLI warns), and,
  on loopback, answers only requests whose ``Host`` header names that loopback address
  and port (``127.0.0.1:P``, ``localhost:P``, ``[::1]:P``): a DNS-rebinding page,
  whose requests carry its own host name, gets 421 before the token is even looked at;
- every URL starts with a random token (``secrets.token_urlsafe``), compared in
  constant time (:func:`hmac.compare_digest`); a request without it gets 404;
- the browser is opened on a private temporary file that redirects to the URL
  (:func:`redirect_file`), never on the URL itself, so that the token does not appear
  on a command line (``/proc/PID/cmdline`` is readable by every local user);
- responses are written in chunks of :data:`CHUNK` bytes; each connection's socket
  times out after ``request_timeout`` seconds (a slow or half-sent request does not
  hold its thread), and at most ``max_connections`` are served at once (more get 503
  at once, without a thread);
- it answers GET and HEAD only, and sends ``no-store``, ``nosniff``, a
  Content-Security-Policy that allows only the page's own two inline scripts (by
  hash), its own origin for data and no framing (``frame-ancestors 'none'``, and
  ``X-Frame-Options: DENY``);
- a client that disconnects is dropped quietly; any other failure answers 500 with one
  line (the error's type and the first 200 characters of its message, which the page
  shows; the server's stderr gets the same line), never a traceback.

Routes under ``/TOKEN/``: the page; ``api/meta`` (JSON); ``api/frame/K?var=NAME``
(float32 LE, see :mod:`thermoswarm.view.data`); ``api/series/I`` (JSON);
``api/video/K`` (JPEG).  ``K`` and ``I`` are ASCII digits, at most 12 of them.
"""

from __future__ import annotations

import base64
import errno
import hashlib
import hmac
import os
import re
import secrets
import socket
import sys
import tempfile
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlsplit

from thermoswarm.errors import OutputError, ThermoswarmError
from thermoswarm.view.data import ViewData, to_json
from thermoswarm.view.page import page_html

__all__ = [
    "ViewServer",
    "start_server",
    "serve_in_thread",
    "warn_public",
    "redirect_file",
    "content_security_policy",
    "CHUNK",
]

#: Bytes written per ``send`` of a response body.
CHUNK = 256 * 1024
#: A route's number: ASCII digits only (``str.isdigit`` also accepts superscripts).
_NUMBER = re.compile(r"[0-9]{1,12}")
_LOOPBACK = ("127.0.0.1", "localhost", "::1")
_QUIET = (ConnectionError, TimeoutError, socket.timeout)


def content_security_policy(page: str) -> str:
    """The page's Content-Security-Policy: its inline scripts by hash, nothing foreign.

    Parameters
    ----------
    page
        The HTML the server sends; every ``<script>`` element's text is hashed (SHA-256).
    """
    scripts = re.findall(r"<script>(.*?)</script>", page, flags=re.DOTALL)
    hashes = " ".join(
        "'sha256-" + base64.b64encode(hashlib.sha256(s.encode("utf-8")).digest()).decode() + "'"
        for s in scripts
    )
    return (
        f"default-src 'none'; script-src {hashes}; style-src 'unsafe-inline'; "
        "img-src 'self' blob: data:; connect-src 'self'; base-uri 'none'; "
        "form-action 'none'; frame-ancestors 'none'"
    )


class _Handler(BaseHTTPRequestHandler):
    server: ViewServer
    protocol_version = "HTTP/1.1"

    def log_message(self, format: str, *args: Any) -> None:  # quiet: the page is chatty
        pass

    def setup(self) -> None:
        self.timeout = self.server.request_timeout  # StreamRequestHandler sets it on the socket
        super().setup()
        # headers and body go out as two writes: without NODELAY, Nagle's algorithm and
        # the browser's delayed ACK hold small frames back by tens of milliseconds
        self.connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def handle(self) -> None:
        try:
            super().handle()
        except _QUIET:  # the client went away or stalled: nothing to tell anyone
            self.close_connection = True

    def _send(self, code: int, body: bytes, ctype: str) -> None:
        self.send_response(code)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.send_header("X-Content-Type-Options", "nosniff")
        self.send_header("Referrer-Policy", "no-referrer")
        self.send_header("X-Frame-Options", "DENY")
        self.send_header("Content-Security-Policy", self.server.csp)
        self.end_headers()
        if self.command == "HEAD":
            return
        view = memoryview(body)
        for start in range(0, len(view), CHUNK):
            self.wfile.write(view[start : start + CHUNK])

    def _text(self, code: int, text: str) -> None:
        self._send(code, text.encode("utf-8"), "text/plain; charset=utf-8")

    def do_HEAD(self) -> None:
        self.do_GET()

    def do_GET(self) -> None:
        try:
            self._answer()
        except _QUIET:
            self.close_connection = True

    def _answer(self) -> None:
        if not self.server.host_allowed(self.headers.get("Host")):
            return self._text(421, "wrong Host header")
        url = urlsplit(self.path)
        token, _, rest = url.path.lstrip("/").partition("/")
        if not hmac.compare_digest(token.encode("utf-8", "replace"), self.server.token_bytes):
            return self._text(404, "not found")
        if rest == "" and not url.path.endswith("/"):  # /TOKEN -> /TOKEN/ (relative URLs)
            self.send_response(301)
            self.send_header("Location", f"/{self.server.token}/")
            self.send_header("Content-Length", "0")
            self.end_headers()
            return None
        try:
            self._route(rest, parse_qs(url.query, max_num_fields=4))
        except _QUIET:
            raise
        except ThermoswarmError as exc:
            self._text(400, str(exc).splitlines()[0] if str(exc) else "bad request")
        except ValueError:  # parse_qs' field limit
            self._text(400, "bad query")
        except Exception as exc:  # the page and the terminal show one line, no traceback
            first = (str(exc).splitlines() or [""])[0][:200]
            line = f"{type(exc).__name__}: {first}"
            print(f"thermoswarm view: {line} (on {rest[:80]!r})", file=sys.stderr)
            self._text(500, line)

    def _route(self, rest: str, query: dict[str, list[str]]) -> None:
        data = self.server.data
        if rest == "":
            return self._send(200, self.server.page, "text/html; charset=utf-8")
        if rest == "api/meta":
            return self._send(200, to_json(data.meta()).encode(), "application/json")
        head, _, arg = rest.rpartition("/")
        if head not in ("api/frame", "api/series", "api/video") or not _NUMBER.fullmatch(arg):
            return self._text(404, "not found")
        k = int(arg)
        if head == "api/frame":
            var = query.get("var", [""])[0] or None
            return self._send(200, data.frame_bytes(k, var), "application/octet-stream")
        if head == "api/series":
            return self._send(200, to_json(data.series(k)).encode(), "application/json")
        if data.video is None:
            return self._text(404, "not found")
        return self._send(200, data.video.jpeg(k), "image/jpeg")


class ViewServer(ThreadingHTTPServer):
    """Serves one :class:`ViewData` (the page and its data; no files).

    Parameters
    ----------
    data
        What to show.
    host, port
        Address to listen on (port 0: a free one).
    request_timeout
        Seconds a connection may stay silent (reading a request or taking a response).
    max_connections
        Connections served at once; more are answered 503 at once.
    check_host
        Accept only loopback ``Host`` headers naming this port (default: when ``host``
        is a loopback address).
    """

    daemon_threads = True
    allow_reuse_address = False
    request_queue_size = 64

    def __init__(
        self,
        data: ViewData,
        host: str,
        port: int,
        *,
        request_timeout: float = 30.0,
        max_connections: int = 32,
        check_host: bool | None = None,
    ) -> None:
        self.data = data
        self.token = secrets.token_urlsafe(24)
        self.token_bytes = self.token.encode("ascii")
        page = page_html()
        self.page = page.encode("utf-8")
        self.csp = content_security_policy(page)
        self.request_timeout = float(request_timeout)
        self.max_connections = int(max_connections)
        self._slots = threading.BoundedSemaphore(self.max_connections)
        self.check_host = host in _LOOPBACK if check_host is None else check_host
        if ":" in host:
            self.address_family = socket.AF_INET6
        super().__init__((host, port), _Handler)
        self._hosts = self._allowed_hosts()

    def _allowed_hosts(self) -> set[str]:
        port = self.server_address[1]
        return {f"{h}:{port}" for h in ("127.0.0.1", "localhost", "[::1]")}

    def host_allowed(self, host: str | None) -> bool:
        """Whether a request's ``Host`` header may be answered."""
        if not self.check_host:
            return True
        return host is not None and host.strip().lower() in self._hosts

    @property
    def url(self) -> str:
        host, port = self.server_address[:2]
        shown = f"[{host}]" if ":" in str(host) else host
        return f"http://{shown}:{port}/{self.token}/"

    # at most max_connections threads: a connection beyond them is answered here, in
    # the accepting thread, with a short 503 that fits any socket buffer
    def process_request(self, request: Any, client_address: Any) -> None:
        if not self._slots.acquire(blocking=False):
            try:
                request.settimeout(1.0)
                request.sendall(
                    b"HTTP/1.1 503 Service Unavailable\r\nContent-Length: 4\r\n"
                    b"Connection: close\r\nRetry-After: 1\r\n\r\nbusy"
                )
            except OSError:
                pass
            self.shutdown_request(request)
            return
        try:
            super().process_request(request, client_address)
        except BaseException:
            self._slots.release()
            raise

    def process_request_thread(self, request: Any, client_address: Any) -> None:
        try:
            super().process_request_thread(request, client_address)
        finally:
            self._slots.release()

    def handle_error(self, request: Any, client_address: Any) -> None:
        exc = sys.exc_info()[1]
        if isinstance(exc, _QUIET):
            return
        print(f"thermoswarm view: {type(exc).__name__}: {exc}"[:300], file=sys.stderr)


def start_server(
    data: ViewData,
    *,
    host: str = "127.0.0.1",
    port: int = 0,
    request_timeout: float = 30.0,
    max_connections: int = 32,
    check_host: bool | None = None,
) -> ViewServer:
    """Bind the viewer's server (port 0: a free one); call ``serve_forever`` on it.

    The keyword arguments are :class:`ViewServer`'s.

    Raises
    ------
    OutputError
        The port is taken or the address cannot be bound (one line, naming them).
    """
    try:
        return ViewServer(
            data,
            host,
            int(port),
            request_timeout=request_timeout,
            max_connections=max_connections,
            check_host=check_host,
        )
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


def redirect_file(url: str) -> Path:
    """A private HTML file (mode 0600, in a private temporary folder) redirecting to ``url``.

    The browser is started on this file's path, so that the URL's token never appears
    on a command line; the caller removes the folder (``path.parent``) when done.
    """
    folder = Path(tempfile.mkdtemp(prefix="thermoswarm-view-"))  # mode 0700
    path = folder / "open.html"
    quoted = url.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;")
    text = (
        '<!doctype html>\n<html><head><meta charset="utf-8">\n'
        f'<meta http-equiv="refresh" content="0;url={quoted}">\n'
        "<title>thermoswarm view</title></head>\n"
        f'<body><p><a href="{quoted}">Open the viewer</a></p></body></html>\n'
    )
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "w", encoding="utf-8") as fh:
        fh.write(text)
    return path


def warn_public(host: str) -> None:
    """The warning printed when the server listens beyond this machine."""
    if host not in _LOOPBACK:
        print(
            f"warning: listening on {host}: other machines on the network can reach this "
            "viewer (anyone with the URL's token can read the data)",
            file=sys.stderr,
        )
