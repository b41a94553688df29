"""The local server: loopback only, a token in every URL, nothing outside its folder."""

from __future__ import annotations

import http.client
import json
import socket

import numpy as np
import pytest

from thermoswarm.cli import main
from thermoswarm.errors import OutputError
from thermoswarm.tracks import make_tracks
from thermoswarm.view.data import from_dataset
from thermoswarm.view.server import safe_file, serve_in_thread, start_server, warn_public


@pytest.fixture
def served(tmp_path, rng):
    """A server opened on ``tmp_path/site`` with a secret file beside that folder."""
    site = tmp_path / "site"
    (site / "sub").mkdir(parents=True)
    (site / "sub" / "inside.txt").write_text("inside")
    (tmp_path / "secret.txt").write_text("SECRET")
    (site / "escape").symlink_to(tmp_path / "secret.txt")
    data = from_dataset(make_tracks(rng.normal(0, 50, (5, 2, 4)), fps=5.0), "small")
    server = start_server(data, site)
    serve_in_thread(server)
    yield server
    server.shutdown()
    server.server_close()


def _get(server, path: str) -> tuple[int, bytes]:
    """Send ``path`` exactly as written (no client-side normalisation of ``..``)."""
    host, port = server.server_address[:2]
    conn = http.client.HTTPConnection(host, port, timeout=10)
    conn.putrequest("GET", path, skip_accept_encoding=True)
    conn.endheaders()
    resp = conn.getresponse()
    body = resp.read()
    conn.close()
    return resp.status, body


def test_listens_on_loopback_only_by_default(served):
    assert served.server_address[0] == "127.0.0.1"
    assert served.url.startswith("http://127.0.0.1:")
    assert len(served.token) >= 32


def test_token_is_required(served):
    t = served.token
    assert _get(served, f"/{t}/")[0] == 200
    assert _get(served, f"/{t}/api/meta")[0] == 200
    wrong = ("/", "/api/meta", f"/{t[:-1]}/api/meta", f"/{t}x/api/meta", "/files/sub/inside.txt")
    for path in wrong:
        status, body = _get(served, path)
        assert status == 404 and b"small" not in body


@pytest.mark.parametrize(
    "rel",
    [
        "../secret.txt",
        "sub/../../secret.txt",
        "%2e%2e/secret.txt",
        "%2E%2E%2Fsecret.txt",
        "..%2fsecret.txt",
        "%252e%252e%252fsecret.txt",
        "sub/%2e%2e/%2e%2e/secret.txt",
        "..%5csecret.txt",
        "%2fetc%2fpasswd",
        "/etc/passwd",
        "escape",
        "inside.txt%00",
    ],
)
def test_traversals_get_404(served, rel):
    status, body = _get(served, f"/{served.token}/files/{rel}")
    assert status == 404
    assert b"SECRET" not in body and b"root:" not in body


def test_files_inside_the_folder_are_served(served):
    status, body = _get(served, f"/{served.token}/files/sub/inside.txt")
    assert (status, body) == (200, b"inside")
    assert _get(served, f"/{served.token}/files/sub/%69nside.txt") == (200, b"inside")


def test_safe_file_refuses_outside(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "f").write_text("x")
    (tmp_path / "g").write_text("y")
    assert safe_file(tmp_path / "a", "f") == (tmp_path / "a" / "f").resolve()
    assert safe_file(tmp_path / "a", "../g") is None
    assert safe_file(tmp_path / "a", "") is None


def test_api_frame_and_errors(served):
    t = served.token
    status, body = _get(served, f"/{t}/api/frame/2?var=speed")
    assert status == 200
    arr = np.frombuffer(body, dtype="<f4")
    assert arr.size == 3 * served.data.n
    want = served.data.ds["position"].values[2, :, 0].astype("f4")
    np.testing.assert_array_equal(arr[: 2 * served.data.n].reshape(2, -1), want)
    status, body = _get(served, f"/{t}/api/frame/99")
    assert status == 400 and b"outside 0..4" in body
    status, body = _get(served, f"/{t}/api/frame/1?var=nope")
    assert status == 400 and b"unknown variable 'nope'" in body
    meta = json.loads(_get(served, f"/{t}/api/meta")[1])
    assert meta["n"] == 4 and meta["n_frames"] == 5


def test_port_taken_is_one_line_error(small_run, capsys):
    with socket.socket() as blocker:
        blocker.bind(("127.0.0.1", 0))
        blocker.listen(1)
        port = blocker.getsockname()[1]
        with pytest.raises(OutputError, match=f"port {port} on 127.0.0.1 is already taken"):
            start_server(from_dataset(make_tracks(np.zeros((2, 2, 1)), fps=1.0)), ".", port=port)
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


def _serve_cli(args):
    """Start ``thermoswarm view ARGS --no-browser``; return the process and its URL."""
    import subprocess
    import sys

    proc = subprocess.Popen(
        [sys.executable, "-m", "thermoswarm", "view", *args, "--no-browser"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    line = proc.stdout.readline()
    return proc, line


@pytest.mark.parametrize("host", ["127.0.0.1", "0.0.0.0"])
def test_cli_serves_the_run(small_run, host):
    import urllib.request

    proc, line = _serve_cli([str(small_run), "--host", host])
    try:
        assert line.startswith("thermoswarm view: http://"), line + proc.stderr.read()
        url = line.split()[2]
        if host != "127.0.0.1":
            url = url.replace(host, "127.0.0.1")
        with urllib.request.urlopen(url + "api/meta", timeout=30) as r:
            meta = json.load(r)
        assert meta["geometry"]["scenario"] == "transport-free"
    finally:
        proc.terminate()
        proc.wait(timeout=30)
    err = proc.stderr.read()
    assert ("warning: listening on 0.0.0.0" in err) == (host != "127.0.0.1")
    proc.stdout.close()
    proc.stderr.close()


def test_cli_out_writes_one_file(small_run, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["view", str(small_run), "--out", str(tmp_path / "run.html")])
    assert exc.value.code == 0
    assert "-> " in capsys.readouterr().out
    text = (tmp_path / "run.html").read_text()
    assert text.startswith("<!doctype html>") and "window.__EMBED__" in text
    assert not list(tmp_path.glob(".run.html*"))  # no temporary left behind
