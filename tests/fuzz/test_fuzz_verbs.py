"""Property-based fuzzing of every verb's inputs and options (Hypothesis, fixed seed).

Each verb is run in this process (:func:`harness.outcome`) on generated hostile input:
numbers at and beyond every limit (0, -1, 1e-300, 1e308, NaN, inf, 2**63, 2**70,
thousands of digits), values of the wrong type, nesting thousands deep, keys given
twice, damaged files.  The property: it ends with exit 0 and a correct result, or with
exit 2 and one ``error:`` line; never a traceback, a hang (60 s) or a memory blow-up.

``make test`` runs :data:`FAST` examples per verb; ``make test-slow`` the campaign of
:data:`SLOW` examples (``@pytest.mark.slow``).  The counts per verb are printed at the
end of a run without xdist (``THERMOSWARM_FUZZ_COUNTS=FILE`` writes them as JSON).
"""

from __future__ import annotations

import json
import math
import types
from pathlib import Path

import numpy as np
import pytest
from harness import assert_clean, outcome
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

FAST, SLOW = 12, 150
#: Examples of the verbs whose accepted runs take seconds (a whole analysis or run).
FAST_HEAVY = 4


def _settings(n: int):
    return settings(max_examples=n, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))  # fmt: skip


def both(fast: int = FAST, **strategies):
    """The decorated body as two Hypothesis tests over ``strategies``: ``fast``
    examples (``make test``) and SLOW examples (``@pytest.mark.slow``)."""

    def deco(body):
        def make(n: int):
            f = types.FunctionType(body.__code__, body.__globals__, body.__name__,
                                   body.__defaults__, body.__closure__)  # fmt: skip
            return _settings(n)(given(**strategies)(f))

        return make(fast), pytest.mark.slow(make(SLOW))

    return deco


# --------------------------------------------------------------------- values
HOSTILE_NUMBERS = ["0", "-1", "1", "0.5", "1e-300", "-1e-300", "1e308", "-1e308", "nan", "inf",
                   "-inf", str(2**31 + 1), str(2**63), str(2**64), str(2**70), "1e9", "1e12",
                   "1e29", "7" * 5000, "2.5", "-0.0", "3"]  # fmt: skip
HOSTILE_WORDS = ['"paper"', '"wide"', "paper", "true", "[]", "[1, 2]", '""', "{}",
                 "[" * 3000 + "]" * 3000, '"time:1e-300"', '["time:0"]', '"x" ']  # fmt: skip
value_text = st.sampled_from(HOSTILE_NUMBERS + HOSTILE_WORDS) | st.integers(
    -(2**80), 2**80
).map(str) | st.floats(allow_nan=True, allow_infinity=True).map(
    lambda f: "nan" if math.isnan(f) else ("inf" if f > 0 else "-inf") if math.isinf(f)
    else repr(f)
)  # fmt: skip


def _count(verb: str, res, correct: bool | None = None) -> None:
    assert_clean(verb, res, correct=correct)


# --------------------------------------------------------------------- analyze --config
ANALYZE_KEYS = [
    ("test", "n_bootstrap"), ("test", "seed"), ("test", "test_size"), ("test", "thin"),
    ("test", "alpha"), ("clean", "smooth"), ("clean", "max_gap"), ("clean", "polyorder"),
    ("steps", "mass"), ("steps", "gap_factor"), ("steps", "min_speed"),
    ("fit", "energy_bins"), ("fit", "group_by"), ("fit", "max_plausible_speed"),
    ("exclude", "max_speed"), ("exclude", "implausible_factor"), ("read", "fps"),
    ("read", "px_per_mm"), ("nosuch", "key"),
]  # fmt: skip


def _analyze_config(tmp: Path, tracks_nc: Path, pairs) -> None:
    lines: dict[str, list[str]] = {}
    for (section, key), text in pairs:
        lines.setdefault(section, []).append(f"{key} = {text}")
    toml = "\n".join(f"[{s}]\n" + "\n".join(v) for s, v in lines.items()) + "\n"
    cfg = tmp / "c.toml"
    cfg.write_text(toml)
    out = tmp / "res"
    res = outcome(["analyze", tracks_nc, "--config", cfg, "--out", out, "--quiet",
                   "--bootstrap", "0", "--no-report"])  # fmt: skip
    ok = res.kind == "ok" and (out / "fits.json").is_file()
    _count("analyze", res, correct=ok if res.kind == "ok" else None)
    if res.kind == "error":
        assert not out.exists()


@both(FAST_HEAVY, pairs=st.lists(st.tuples(st.sampled_from(ANALYZE_KEYS), value_text), min_size=1,
                      max_size=3, unique_by=lambda p: p[0]))  # fmt: skip
def _analyze(tmp_path_factory, tracks_nc, pairs):
    _analyze_config(tmp_path_factory.mktemp("a"), tracks_nc, pairs)


test_fuzz_analyze_config, test_fuzz_analyze_config_slow = _analyze


# --------------------------------------------------------------------- simulate --set
SIM_KEYS = ["kT", "diameter", "packing_fraction", "engine.dt", "record.interval",
            "record.block", "seed", "n", "duration", "nosuch", "engine.nosuch"]  # fmt: skip


@both(FAST_HEAVY, key=st.sampled_from(SIM_KEYS), text=value_text, seed=st.sampled_from(
    [None, "0", "-1", str(2**63), str(2**70), "x"]))  # fmt: skip
def _simulate(tmp_path_factory, key, text, seed):
    out = tmp_path_factory.mktemp("s") / "run"
    argv = ["simulate", "box", "--out", out, "--set", "n=12", "--set", "duration=0.5",
            "--set", f"{key}={text}", "--no-progress"]  # fmt: skip
    if seed is not None:
        argv += ["--seed", seed]
    res = outcome(argv)
    ok = res.kind == "ok" and (out / "tracks.nc").is_file()
    _count("simulate", res, correct=ok if res.kind == "ok" else None)
    if res.kind == "error":
        assert not out.exists()


test_fuzz_simulate_set, test_fuzz_simulate_set_slow = _simulate


# --------------------------------------------------------------------- sweep --seeds/--grid
seeds_text = st.lists(
    st.one_of(st.integers(-5, 2**70).map(str),
              st.tuples(st.integers(-5, 2**66), st.integers(-5, 2**66)).map(
                  lambda ab: f"{ab[0]}-{ab[1]}"),
              st.sampled_from(["", "a", "1-", "-", "0x10", "\u00b2", " 3 ", "1e3"])),
    min_size=1, max_size=4,
).map(",".join)  # fmt: skip


GRID = st.lists(
    st.tuples(
        st.sampled_from(["kT", "diameter", "n"]), st.lists(value_text, min_size=1, max_size=3)
    ),
    max_size=3,
)


@both(FAST_HEAVY, seeds=seeds_text, grid=GRID)
def _sweep(tmp_path_factory, seeds, grid):
    """The sweep's options are parsed and checked before any run: a grid the check
    accepts is run only when it is one tiny run."""
    from thermoswarm.cli.sweep import MAX_RUNS, _parse_grid, _parse_seeds
    from thermoswarm.errors import ThermoswarmError

    items = tuple(f"{k}={','.join(v)}" for k, v in grid)
    try:
        got = _parse_seeds(seeds)
        parsed = _parse_grid(items)
    except ThermoswarmError:
        got = None
    if got is not None:
        assert len(got) == len(set(got)) <= MAX_RUNS
        assert all(0 <= s < 2**63 for s in got)
        assert len(parsed) == len({k for k, _ in grid})
    out = tmp_path_factory.mktemp("w") / "sw"
    argv = ["sweep", "box", "--out", out, "--seeds", seeds, "--set", "n=12",
            "--set", "duration=0.5", "--workers", "1", "--no-progress"]  # fmt: skip
    for item in items:
        argv += ["--grid", item]
    if got is not None and (len(got) > 1 or grid):
        argv += ["--cluster", "local:1", "--scheduler", "tcp://x:1"]  # refused after parsing
    res = outcome(argv)
    ok = res.kind == "ok" and (out / "sweep.json").is_file()
    _count("sweep", res, correct=ok if res.kind == "ok" else None)


test_fuzz_sweep_options, test_fuzz_sweep_options_slow = _sweep


# --------------------------------------------------------------------- convert
@both(to=st.sampled_from(["mot", "tidy_csv", "netcdf", "wide_csv", "nosuch"]),
       opts=st.lists(st.tuples(st.sampled_from(["px_per_mm", "box_size_px", "nosuch"]),
                               value_text), max_size=2),
       read=st.lists(st.tuples(st.sampled_from(["units", "x"]), value_text), max_size=1),
       fps=st.sampled_from([None, "0", "1e308", "nan", "30", "-1"]))  # fmt: skip
def _convert(tmp_path_factory, tracks_nc, to, opts, read, fps):
    tmp = tmp_path_factory.mktemp("c")
    ext = {"mot": ".txt", "netcdf": ".nc"}.get(to, ".csv")
    dest = tmp / f"out{ext}"
    argv = ["convert", tracks_nc, dest, "--to", to]
    for k, v in opts:
        argv += ["--write-option", f"{k}={v}"]
    for k, v in read:
        argv += ["--read-option", f"{k}={v}"]
    if fps is not None:
        argv += ["--fps", fps]
    res = outcome(argv)
    ok = None
    if res.kind == "ok":
        ok = dest.is_file() and dest.stat().st_size > 0
        if to == "netcdf":
            from thermoswarm.io import read_tracks

            a, b = read_tracks(tracks_nc), read_tracks(dest)
            ok = ok and np.allclose(a["position"].values, b["position"].values, equal_nan=True)
    _count("convert", res, correct=ok)
    if res.kind == "error":
        assert not dest.exists()


test_fuzz_convert, test_fuzz_convert_slow = _convert


# --------------------------------------------------------------------- track --detections
json_value = st.recursive(
    st.none() | st.booleans() | st.integers(-(2**70), 2**70)
    | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=5),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner,
                                                                max_size=3),
    max_leaves=6,
)  # fmt: skip
number = st.sampled_from([0, 1, 5, -1, 1e300, 2**70, float("nan"), float("inf"), 1e7, 10**11])
ann = st.fixed_dictionaries(
    {"image_id": number | json_value,
     "bbox": st.lists(st.sampled_from([1, 5, 0, -3, 1e300, float("nan")]) | json_value,
                      min_size=4, max_size=4) | json_value},
    optional={"score": number | json_value, "keypoints": json_value},
)  # fmt: skip
coco = st.fixed_dictionaries(
    {"annotations": st.lists(ann, max_size=4) | json_value},
    optional={"images": st.lists(st.fixed_dictionaries(
        {"id": number | json_value}, optional={"width": number | json_value,
                                              "height": number | json_value,
                                              "frame_id": number | json_value})),
              "categories": json_value, "info": json_value},
) | json_value  # fmt: skip


def _track_dets(tmp: Path, dets: Path, extra: list[str], verb: str = "track --detections"):
    out = tmp / "o"
    res = outcome(["track", "--detections", dets, "--fps", "30", "--out", out, *extra])
    ok = res.kind == "ok" and (out / "tracks_mot.txt").is_file()
    _count(verb, res, correct=ok if res.kind == "ok" else None)
    if res.kind == "error":
        assert not out.exists()


@both(doc=coco)
def _coco(tmp_path_factory, doc):
    tmp = tmp_path_factory.mktemp("k")
    dets = tmp / "d.json"
    dets.write_text(json.dumps(doc, allow_nan=True))
    _track_dets(tmp, dets, [])


test_fuzz_track_coco, test_fuzz_track_coco_slow = _coco

mot_row = st.tuples(
    st.sampled_from(["1", "0", "-1", "10000000", "100000000000", "1e300", "nan", "x", "2.5"]),
    st.sampled_from(["-1", "1", str(2**31 + 1)]),
    *[st.sampled_from(["5", "0", "-3", "1e300", "inf", "nan", "12.5"])] * 4,
    st.sampled_from(["0.9", "-1", "2", "nan"]),
).map(lambda r: ",".join(r) + ",-1,-1,-1")  # fmt: skip


@both(rows=st.lists(mot_row, min_size=1, max_size=6),
       opts=st.lists(st.sampled_from([["--object-size-px", "1e308"], ["--object-size-px", "0"],
                                      ["--first-frame", "1"], ["--set", "tracker.confirm_s=1e9"],
                                      ["--set", "tracker.max_gap_s=1e308"],
                                      ["--px-per-mm", "0"], ["--px-per-mm", "paper"]]),
                     max_size=2))  # fmt: skip
def _mot(tmp_path_factory, rows, opts):
    tmp = tmp_path_factory.mktemp("m")
    dets = tmp / "d.txt"
    dets.write_text("\n".join(rows) + "\n")
    _track_dets(tmp, dets, [a for o in opts for a in o])


test_fuzz_track_mot, test_fuzz_track_mot_slow = _mot


@both(names=st.lists(st.sampled_from(["frame_1.txt", "frame_9999.txt", "x.txt",
       f"frame_{10**20}.txt", "frame_10000000.txt", "a.TXT"]), min_size=1, max_size=4,
       unique=True), lines=st.lists(st.sampled_from(["0 0.5 0.5 0.1 0.1", "0 5 5 1 1",
       "0 nan 0.5 0.1 0.1", "1 2", "0 0.5 0.5 0.1 0.1 0.9", "\xff"]), max_size=3),
       as_dir=st.booleans(),
       size=st.sampled_from(["64x48", "0x0", "1x1", "99999999x1"]))  # fmt: skip
def _yolo(tmp_path_factory, names, lines, as_dir, size):
    tmp = tmp_path_factory.mktemp("y")
    folder = tmp / "yolo"
    folder.mkdir()
    for i, name in enumerate(names):
        if as_dir and i == 0:
            (folder / name).mkdir()
        else:
            (folder / name).write_text("\n".join(lines) + "\n")
    _track_dets(tmp, folder, ["--image-size", size])


test_fuzz_track_yolo, test_fuzz_track_yolo_slow = _yolo


# --------------------------------------------------------------------- evaluate
@both(gt=st.lists(mot_row, min_size=1, max_size=5), pred=st.lists(mot_row, max_size=5))
def _evaluate(tmp_path_factory, gt, pred):
    tmp = tmp_path_factory.mktemp("e")
    (tmp / "gt.txt").write_text("\n".join(gt) + "\n")
    (tmp / "pred.txt").write_text("\n".join(pred) + "\n")
    res = outcome(["evaluate", tmp / "gt.txt", tmp / "pred.txt"])
    ok = None
    if res.kind == "ok":
        m = json.loads(res.out)
        ok = all(0 <= m[k] <= 1 for k in ("idf1", "hota", "precision", "recall"))
    _count("evaluate", res, correct=ok)


test_fuzz_evaluate, test_fuzz_evaluate_slow = _evaluate


# --------------------------------------------------------------------- TRex folders
@both(damage=st.lists(st.sampled_from(["empty", "truncated", "garbage", "foreign", "pickle",
                                        "lengths", "none"]), min_size=1, max_size=3))  # fmt: skip
def _trex(tmp_path_factory, damage):
    tmp = tmp_path_factory.mktemp("t")
    folder = tmp / "trex"
    folder.mkdir()
    rng = np.random.default_rng(len(damage))
    for i in range(4):
        f = np.arange(30)
        np.savez(folder / f"v_fish{i}.npz", **{"X#wcentroid": rng.random(30),
                 "Y#wcentroid": rng.random(30), "frame": f, "time": f / 20.0})  # fmt: skip
    for i, kind in enumerate(damage):
        p = folder / f"v_fish{i}.npz"
        whole = p.read_bytes()
        if kind == "empty":
            p.write_bytes(b"")
        elif kind == "truncated":
            p.write_bytes(whole[: len(whole) // 2])
        elif kind == "garbage":
            p.write_bytes(b"PK\x03\x04" + bytes(64))
        elif kind == "foreign":
            np.savez(p, weights=np.zeros(3))
        elif kind == "pickle":
            np.savez(p, frame=np.array([object()], dtype=object), **{"X#wcentroid": [1.0],
                     "Y#wcentroid": [1.0], "time": [0.0]})  # fmt: skip
        elif kind == "lengths":
            np.savez(p, frame=np.arange(3), **{"X#wcentroid": np.zeros(2),
                     "Y#wcentroid": np.zeros(3), "time": np.zeros(3)})  # fmt: skip
    dest = tmp / "out.nc"
    res = outcome(["convert", folder, dest, "--format", "trex"])
    ok = None
    if res.kind == "ok":
        from thermoswarm.io import read_tracks

        n = read_tracks(dest).sizes["individuals"]
        lost = damage.count("foreign")  # each entry damages its own file
        ok = n == 4 - lost and (lost == 0 or "warning:" in res.err)
    _count("convert (TRex folder)", res, correct=ok)
    if res.kind == "error" and any(k in ("empty", "truncated", "garbage") for k in damage):
        assert "v_fish" in res.err  # the damaged file is named


test_fuzz_trex_folder, test_fuzz_trex_folder_slow = _trex


# --------------------------------------------------------------------- view's server
@both(path=st.lists(st.sampled_from(["api", "frame", "series", "video", "meta", "files",
       "..", ".", "%2e%2e", "\u00b2", "9" * 40, "-1", "1", "", "%00", "secret.txt"]),
       max_size=6).map("/".join), query=st.sampled_from(["", "?var=speed", "?var=%00",
       "?" + "&".join(f"a{i}=1" for i in range(20)), "?var=" + "x" * 5000]),
       host=st.sampled_from(["good", "evil.example", "127.0.0.1", None]))  # fmt: skip
def _view(served_fuzz, path, query, host):
    import http.client

    server = served_fuzz
    addr, port = server.server_address[:2]
    conn = http.client.HTTPConnection(addr, port, timeout=10)
    conn._encode_request = lambda r: r.encode("utf-8")
    conn.putrequest("GET", f"/{server.token}/{path}{query}", skip_host=True)
    if host == "good":
        conn.putheader("Host", f"127.0.0.1:{port}")
    elif host is not None:
        conn.putheader("Host", host)
    conn.endheaders()
    resp = conn.getresponse()
    body = resp.read()
    conn.close()
    from harness import COUNTS

    c = COUNTS["view (server)"]
    c["runs"] += 1
    assert resp.status != 500 and b"Traceback" not in body and b"SECRET" not in body
    if host != "good":
        assert resp.status == 421
    c["clean errors" if resp.status >= 400 else "correct results"] += 1


@pytest.fixture(scope="module")
def served_fuzz(tmp_path_factory):
    from thermoswarm.io.netcdf import write
    from thermoswarm.tracks import make_tracks
    from thermoswarm.view.server import serve_in_thread, start_server
    from thermoswarm.view.source import open_source

    folder = tmp_path_factory.mktemp("v")
    write(make_tracks(np.zeros((3, 2, 2)), fps=1.0), folder / "data.nc")
    (folder / "secret.txt").write_text("SECRET")
    server = start_server(open_source(folder / "data.nc"))
    serve_in_thread(server)
    yield server
    server.shutdown()
    server.server_close()


test_fuzz_view_server, test_fuzz_view_server_slow = _view
