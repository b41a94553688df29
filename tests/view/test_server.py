"""The local server: the run's own data only, loopback Host only, a token in every URL
(compared in constant time, never on a command line), bounded threads and time per
connection, streamed bodies, a CSP that forbids framing, and no traceback on any request."""

from __future__ import annotations

import base64
import hashlib
import http.client
import json
import os
import re
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from thermoswarm.cli import main
from thermoswarm.errors import OutputError
from thermoswarm.tracks import make_tracks
from thermoswarm.view import server as server_mod
from thermoswarm.view.data import from_dataset
from thermoswarm.view.server import redirect_file, serve_in_thread, start_server, warn_public


def _data(rng, n: int = 4, frames: int = 5):
    return from_dataset(make_tracks(rng.normal(0, 50, (frames, 2, n)), fps=5.0), "small")


@pytest.fixture
def serve(rng):
    """Start servers on small data; every one is shut down after the test."""
    servers = []

    def _serve(data=None, **kw):
        server = start_server(data if data is not None else _data(rng), **kw)
        serve_in_thread(server)
        servers.append(server)
        return server

    yield _serve
    for server in servers:
        server.shutdown()
        server.server_close()


@pytest.fixture
def served(serve):
    return serve()


def _get(server, path: str, host: str | None = "default", method: str = "GET"):
    """Send ``path`` exactly as written; ``host`` None sends no Host header."""
    addr, port = server.server_address[:2]
    conn = http.client.HTTPConnection(addr, port, timeout=10)
    conn._encode_request = lambda r: r.encode("utf-8")  # send non-ASCII bytes as they are
    conn.putrequest(method, path, skip_host=True, skip_accept_encoding=True)
    if host == "default":
        conn.putheader("Host", f"127.0.0.1:{port}")
    elif host is not None:
        conn.putheader("Host", host)
    conn.endheaders()
    resp = conn.getresponse()
    body = resp.read()
    headers = dict(resp.getheaders())
    conn.close()
    return resp.status, body, headers


def test_listens_on_loopback_only_by_default(served):
    assert served.server_address[0] == "127.0.0.1"
    assert served.url.startswith("http://127.0.0.1:")
    assert len(served.token) >= 32


def test_token_is_required(served):
    t = served.token
    assert _get(served, f"/{t}/")[0] == 200
    assert _get(served, f"/{t}/api/meta")[0] == 200
    wrong = ("/", "/api/meta", f"/{t[:-1]}/api/meta", f"/{t}x/api/meta")
    for path in wrong:
        status, body, _ = _get(served, path)
        assert status == 404 and b"small" not in body, path


def test_token_is_compared_in_constant_time(served, monkeypatch):
    seen = []
    real = server_mod.hmac.compare_digest

    def spy(a, b):
        seen.append((a, b))
        return real(a, b)

    monkeypatch.setattr(server_mod.hmac, "compare_digest", spy)
    assert _get(served, "/guess/api/meta")[0] == 404
    assert _get(served, f"/{served.token}/api/meta")[0] == 200
    assert seen == [(b"guess", served.token_bytes), (served.token_bytes, served.token_bytes)]


def test_no_file_is_served_not_even_a_sibling(tmp_path, rng, serve):
    """`view ~/data.nc` once served every file beside data.nc under /TOKEN/files/."""
    from thermoswarm.io.netcdf import write as write_nc
    from thermoswarm.view.source import open_source

    write_nc(make_tracks(rng.normal(0, 50, (5, 2, 3)), fps=5.0), tmp_path / "data.nc")
    (tmp_path / "secret.txt").write_text("SECRET")
    (tmp_path / "evil.html").write_text("<script>alert(1)</script>")
    server = serve(open_source(tmp_path / "data.nc"))
    t = server.token
    for rel in ("files/secret.txt", "files/evil.html", "files/data.nc", "secret.txt",
                "data.nc", "api/../files/secret.txt", "api/frame/../../secret.txt"):  # fmt: skip
        status, body, _ = _get(server, f"/{t}/{rel}")
        assert status == 404, rel
        assert b"SECRET" not in body and b"script" not in body and b"CDF" not in body


@pytest.mark.parametrize(
    "rel",
    ["../secret.txt", "%2e%2e/secret.txt", "%252e%252e%252fsecret.txt", "..%5csecret.txt",
     "%2fetc%2fpasswd", "/etc/passwd", "inside.txt%00"],
)  # fmt: skip
def test_traversals_get_404(served, rel):
    status, body, _ = _get(served, f"/{served.token}/files/{rel}")
    assert status == 404
    assert b"root:" not in body


@pytest.mark.parametrize(
    "host",
    [None, "evil.example", "evil.example:{port}", "127.0.0.1", "127.0.0.1:1",
     "localhost.evil.example:{port}", "127.0.0.1:{port}.evil.example", ""],
)  # fmt: skip
def test_a_foreign_host_header_is_refused(served, host):
    """A DNS-rebinding page's requests carry its own host name: 421, token or not."""
    port = served.server_address[1]
    status, body, _ = _get(
        served, f"/{served.token}/api/meta", host=None if host is None else host.format(port=port)
    )
    assert status == 421 and b"small" not in body


@pytest.mark.parametrize("host", ["127.0.0.1:{port}", "localhost:{port}", "LOCALHOST:{port}"])
def test_the_loopback_host_is_answered(served, host):
    port = served.server_address[1]
    status, body, _ = _get(served, f"/{served.token}/api/meta", host=host.format(port=port))
    assert status == 200 and json.loads(body)["n"] == 4


def test_any_host_header_when_listening_beyond_loopback(serve):
    server = serve(host="0.0.0.0")
    assert not server.check_host
    assert _get(server, f"/{server.token}/api/meta", host="viewer.lab:80")[0] == 200


def test_security_headers(served):
    status, body, headers = _get(served, f"/{served.token}/")
    assert status == 200
    csp = headers["Content-Security-Policy"]
    assert "frame-ancestors 'none'" in csp and "default-src 'none'" in csp
    script_src = re.search(r"script-src ([^;]*)", csp).group(1)
    assert "unsafe-inline" not in script_src and "http" not in script_src
    scripts = re.findall(rb"<script>(.*?)</script>", body, flags=re.DOTALL)
    assert len(scripts) == 2
    for s in scripts:  # each inline script is allowed by its hash, and nothing else
        digest = base64.b64encode(hashlib.sha256(s).digest()).decode()
        assert f"'sha256-{digest}'" in script_src
    assert len(script_src.split()) == 2
    assert headers["X-Frame-Options"] == "DENY"
    assert headers["X-Content-Type-Options"] == "nosniff"
    assert _get(served, f"/{served.token}/api/meta")[2]["Cache-Control"] == "no-store"


@pytest.mark.parametrize(
    "rel",
    ["api/frame/\u00b2", "api/frame/%C2%B2", "api/series/\u0663", "api/frame/" + "9" * 10_000,
     "api/frame/1" + "/x" * 15_000, "api/frame/-1", "api/frame/1e3", "api/frame/ 1"],
)  # fmt: skip
def test_odd_numbers_and_long_urls_are_refused_without_500(served, rel, capsys):
    """A superscript digit passed str.isdigit and failed int(): 500 with the exception."""
    path = f"/{served.token}/{rel}"
    try:
        status, body, _ = _get(served, path)
    except (ConnectionError, http.client.HTTPException):
        status, body = None, b""  # a request line over 64 KiB: the server hangs up (414)
    assert status in (404, 414, None), (status, body[:200])
    assert b"Error" not in body and b"/" not in body
    assert "Traceback" not in capsys.readouterr().err


def test_frame_and_errors(served):
    t = served.token
    status, body, _ = _get(served, f"/{t}/api/frame/2?var=speed")
    assert status == 200
    arr = np.frombuffer(body, dtype="<f4")
    assert arr.size == 3 * served.data.n
    want = served.data.ds["position"].values[2, :, 0].astype("f4")
    np.testing.assert_array_equal(arr[: 2 * served.data.n].reshape(2, -1), want)
    status, body, _ = _get(served, f"/{t}/api/frame/99")
    assert status == 400 and b"outside 0..4" in body
    status, body, _ = _get(served, f"/{t}/api/frame/1?var=nope")
    assert status == 400 and b"unknown variable 'nope'" in body
    status, body, _ = _get(served, f"/{t}/api/frame/1?" + "&".join(f"a{i}=1" for i in range(9)))
    assert status == 400 and body == b"bad query"
    meta = json.loads(_get(served, f"/{t}/api/meta")[1])
    assert meta["n"] == 4 and meta["n_frames"] == 5
    status, body, headers = _get(served, f"/{t}/api/meta", method="HEAD")
    assert status == 200 and body == b"" and int(headers["Content-Length"]) > 0


def test_a_large_frame_is_streamed_whole(serve, rng, monkeypatch):
    """Bodies go out in CHUNK-byte writes (here 64 KiB; a 3.6 MB frame is 55 writes)."""
    monkeypatch.setattr(server_mod, "CHUNK", 64 * 1024)
    writes = []
    real = server_mod._Handler._send

    def counting(self, code, body, ctype):
        wfile = self.wfile

        class W:
            def write(self, b):
                writes.append(len(b))
                return wfile.write(b)

            def flush(self):
                wfile.flush()

        self.wfile = W()
        try:
            return real(self, code, body, ctype)
        finally:
            self.wfile = wfile

    monkeypatch.setattr(server_mod._Handler, "_send", counting)
    n = 300_000
    server = serve(_data(rng, n=n, frames=2))
    status, body, _ = _get(server, f"/{server.token}/api/frame/1")
    assert status == 200 and len(body) == 3 * 4 * n
    want = server.data.ds["position"].values[1, :, 0].astype("f4")
    np.testing.assert_array_equal(np.frombuffer(body, "<f4")[: 2 * n].reshape(2, -1), want)
    big = [w for w in writes if w > 1000]
    assert max(big) <= 64 * 1024 and sum(big) == len(body)


def _half_request(server) -> socket.socket:
    sock = socket.create_connection(server.server_address[:2], timeout=10)
    sock.sendall(f"GET /{server.token}/api/meta HTTP/1.1\r\nHost: 127".encode())
    return sock


def test_a_slow_client_is_dropped_after_the_timeout(serve):
    server = serve(request_timeout=0.5)
    sock = _half_request(server)
    t0 = time.monotonic()
    assert sock.recv(100) == b""  # the server closed the connection
    assert time.monotonic() - t0 < 8
    sock.close()
    assert _get(server, f"/{server.token}/api/meta")[0] == 200


def test_connections_are_capped_and_freed(serve):
    """40 half-sent requests once held 40 threads; now 4 are served, the rest get 503."""
    server = serve(request_timeout=1.0, max_connections=4)
    held = [_half_request(server) for _ in range(4)]
    time.sleep(0.2)
    extra = socket.create_connection(server.server_address[:2], timeout=10)
    extra.sendall(f"GET /{server.token}/api/meta HTTP/1.1\r\nHost: x\r\n\r\n".encode())
    assert extra.recv(100).startswith(b"HTTP/1.1 503")
    extra.close()
    for sock in held:
        assert sock.recv(100) == b""  # each dropped after its timeout, its slot freed
        sock.close()
    assert _get(server, f"/{server.token}/api/meta")[0] == 200


def test_a_client_that_disconnects_gets_no_traceback(serve, rng, capfd):
    server = serve(_data(rng, n=200_000, frames=2))
    for path in (f"/{server.token}/api/frame/1", "/nothing-here", f"/{server.token}/"):
        sock = socket.create_connection(server.server_address[:2], timeout=10)
        # RST on close: the server's writes fail with a broken pipe or a reset
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, b"\x01\x00\x00\x00\x00\x00\x00\x00")
        port = server.server_address[1]
        sock.sendall(f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode())
        sock.close()
    time.sleep(0.5)
    assert _get(server, f"/{server.token}/api/meta")[0] == 200
    err = capfd.readouterr().err
    assert "Traceback" not in err and "Error" not in err


def test_port_taken_is_one_line_error(small_run, capsys):
    with socket.socket() as blocker:
        blocker.bind(("127.0.0.1", 0))
        blocker.listen(1)
        port = blocker.getsockname()[1]
        with pytest.raises(OutputError, match=f"port {port} on 127.0.0.1 is already taken"):
            start_server(from_dataset(make_tracks(np.zeros((2, 2, 1)), fps=1.0)), port=port)
        with pytest.raises(SystemExit) as exc:
            main(["view", str(small_run), "--port", str(port), "--no-browser"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: port") and err.count("\n") == 1


def test_other_interfaces_warn(capsys):
    warn_public("127.0.0.1")
    assert capsys.readouterr().err == ""
    warn_public("0.0.0.0")
    assert "warning: listening on 0.0.0.0" in capsys.readouterr().err


def test_redirect_file_is_private(tmp_path):
    url = "http://127.0.0.1:1/TOKEN/"
    path = redirect_file(url)
    try:
        assert oct(path.stat().st_mode & 0o777) == "0o600"
        assert oct(path.parent.stat().st_mode & 0o777) == "0o700"
        assert f'content="0;url={url}"' in path.read_text()
    finally:
        for p in path.parent.iterdir():
            p.unlink()
        path.parent.rmdir()


def _serve_cli(args, env=None):
    """Start ``thermoswarm view ARGS``; return the process and its first line."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "thermoswarm", "view", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    line = proc.stdout.readline()
    return proc, line


def _stop(proc) -> str:
    proc.terminate()
    proc.wait(timeout=30)
    err = proc.stderr.read()
    proc.stdout.close()
    proc.stderr.close()
    return err


@pytest.mark.parametrize("host", ["127.0.0.1", "0.0.0.0"])
def test_cli_serves_the_run(small_run, host):
    import urllib.request

    proc, line = _serve_cli([str(small_run), "--host", host, "--no-browser"])
    try:
        assert line.startswith("thermoswarm view: http://"), line + proc.stderr.read()
        url = line.split()[2]
        if host != "127.0.0.1":
            url = url.replace(host, "127.0.0.1")
        with urllib.request.urlopen(url + "api/meta", timeout=30) as r:
            meta = json.load(r)
        assert meta["geometry"]["scenario"] == "transport-free"
    finally:
        err = _stop(proc)
    assert ("warning: listening on 0.0.0.0" in err) == (host != "127.0.0.1")


def _cmdlines() -> list[bytes]:
    out = []
    for pid in os.listdir("/proc"):
        if pid.isdigit():
            try:
                out.append(Path(f"/proc/{pid}/cmdline").read_bytes())
            except OSError:
                pass
    return out


@pytest.mark.skipif(not Path("/proc/self/cmdline").exists(), reason="needs /proc")
def test_the_token_is_on_no_command_line(small_run, tmp_path):
    """The browser is started on a private file that redirects, not on the URL."""
    record = tmp_path / "browser_args"
    browser = tmp_path / "fake-browser"
    browser.write_text(f'#!/bin/sh\necho "$@" > {record}.part && mv {record}.part {record}\n')
    browser.chmod(0o700)
    env = dict(os.environ, BROWSER=f"{browser} %s")
    proc, line = _serve_cli([str(small_run)], env=env)
    try:
        assert line.startswith("thermoswarm view: http://"), line + proc.stderr.read()
        token = line.split()[2].rstrip("/").rsplit("/", 1)[1]
        for _ in range(300):
            if record.exists():
                break
            time.sleep(0.1)
        opened = record.read_text().strip()
        assert opened.startswith("file:///") and token not in opened
        page = Path(opened[len("file://") :])
        assert token in page.read_text()  # the redirect holds it, readable by us only
        assert oct(page.stat().st_mode & 0o777) == "0o600"
        assert not [c for c in _cmdlines() if token.encode() in c]
    finally:
        _stop(proc)
    assert not page.exists()  # removed when the server stops


def test_cli_out_writes_one_file(small_run, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["view", str(small_run), "--out", str(tmp_path / "run.html")])
    assert exc.value.code == 0
    assert "-> " in capsys.readouterr().out
    text = (tmp_path / "run.html").read_text()
    assert text.startswith("<!doctype html>") and "window.__EMBED__" in text
    assert not list(tmp_path.glob(".run.html*"))  # no temporary left behind
