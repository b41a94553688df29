"""`thermoswarm reproduce` (what `make run` executes) end to end, at a toy scale.

Every step of the quick setting runs, with sizes cut down (the numbers mean nothing at
this scale); the test reads results.json and report.html back.
"""

from __future__ import annotations

import dataclasses
import html
import json
import math
import re

import pytest

from thermoswarm.report.paper import COMPARISONS
from thermoswarm.reproduce import SMOKE, TITLES, _Pool, reproduce

TINY = dataclasses.replace(
    SMOKE,
    name="tiny",
    road_duration=20.0,
    compression_duration=60.0,
    pictures_duration=20.0,
    connected_duration=10.0,
    free_duration=10.0,
    free_n=100,
    variant_duration=5.0,
    study_overrides={"n": 60, "duration": 8.0, "warmup": 2.0},
    scaling_ns=(30, 60),
    unified_robots=100,
    unified_duration=5.0,
    gas_duration=10.0,
    ant_frames=60,
    n_bootstrap=9,
)

VERDICTS = {"reproduced", "partly", "differs", "not resolved at this scale", "not measured"}


@pytest.fixture(scope="module")
def done(tmp_path_factory):
    out = tmp_path_factory.mktemp("repro") / "nested" / "out"  # parents are created
    res = reproduce(out, plan=TINY, seed=0, workers=1, verbose=False)
    return out, res


def test_results_json_holds_every_experiment_with_its_verdicts(done):
    out, res = done
    on_disk = json.loads((out / "results.json").read_text())
    assert on_disk["setting"] == "tiny" and on_disk["seed"] == 0
    assert set(COMPARISONS) <= set(on_disk)
    assert set(on_disk["seconds"]) == set(COMPARISONS)
    for name in COMPARISONS:
        v = on_disk["verdicts"][name]
        assert v["claims"], name
        assert {c["verdict"] for c in v["claims"]} <= VERDICTS
        assert v["overall"] in VERDICTS
    road = on_disk["narrow_road"]
    assert road["duration_s"] == TINY.road_duration
    c = road["crossings"]
    assert c["total"] == c["+x"] + c["-x"]
    iso = on_disk["compression"]["isotherm"]
    assert len(iso) == 5 and all(math.isfinite(r["Z"]) and r["Z"] > 0 for r in iso)
    # the walls' pressure falls as the free area grows (an isotherm), even this short
    by_area = sorted(iso, key=lambda r: r["free_area"])
    assert by_area[0]["pressure"] > by_area[-1]["pressure"]
    free = on_disk["transport_free"]
    assert free["default"]["seeds"] == TINY.free_seeds and free["default"]["n"] == TINY.free_n
    assert len(free["default"]["time_to_target"]) == TINY.free_seeds
    times = [t for t in free["default"]["time_to_target"] if t is not None]
    assert free["default"]["reached"] == len(times)
    assert free["default"]["time_to_target_min"] == (min(times) if times else None)
    phase = free["default"]["phase_by_region_mean"]
    assert all(phase[k] is None or 0 <= phase[k] <= 1 for k in phase if "fraction" in k)
    regime = on_disk["regime"]
    assert regime["maps"] == list(TINY.regime_maps) and len(regime["rows"]) == 9  # 3 x 3
    for r in regime["rows"]:  # each cell's verdict from its own interval
        assert r["seeds"] == TINY.study_seeds
        lo, hi = r["drift_ci_low"], r["drift_ci_high"]
        want = "toward target" if lo > 0 else "away from target" if hi < 0 else "no detect"
        assert r["verdict"].startswith(want)
    assert sum(r["default"] for r in regime["rows"]) == 1  # the default regime's cell
    assert [r["n"] for r in on_disk["scaling"]["rows"]] == list(TINY.scaling_ns)
    assert len(on_disk["mechanism"]["rows"]) == 8  # 2 mappings x 2 heading laws x 2 sensings
    assert on_disk["transport_connected"]["seeds"] == TINY.connected_seeds
    assert {"ants", "ants_real", "gas", "robots"} <= set(on_disk["unified_law"])
    real = on_disk["unified_law"]["ants_real"]  # the real ant excerpt, with its source
    assert "anTraX-data" in real["source"] and "JS16" in real["source"]
    assert real["samples"]["total"] == 16 * 2400 and real["steps"]["used"] > 0
    # the walking steps alone: the standing ones (at or below twice the jitter) left out
    walk = real["walking"]
    assert walk["resting_speed_mm_s"] == float(f"{2 * real['jitter']['speed_mm_s']:.2g}")
    assert walk["resting_left_out"] > real["steps"]["resting_left_out"]
    assert 0 < walk["n_steps"] < real["n_steps"]
    assert on_disk == json.loads(json.dumps(res))  # what the function returned


def test_the_report_sets_the_paper_beside_every_experiment(done):
    out, res = done
    page = (out / "report.html").read_text()
    # one comparison table per experiment, plus the overview at the top
    assert page.count('<table class="paper">') == len(COMPARISONS) + 1
    for name in COMPARISONS:
        section = page.split(f"<h2>{html.escape(_title(page, name))}</h2>")[1].split("<h2>")[0]
        assert '<table class="paper">' in section and "the paper" in section, name
        for claim in res["verdicts"][name]["claims"]:
            assert html.escape(claim["claim"]) in section, claim
    # the overview lists every claim with the verdict of results.json
    glance = page.split("At a glance")[2].split("<h2>")[0]
    cells = re.findall(r"<td>([^<]*)</td><td class=\"v [a-z]+\">([^<]*)</td>", glance)
    expected = [(html.escape(c["claim"]), c["verdict"]) for n in COMPARISONS
                for c in res["verdicts"][n]["claims"]]  # fmt: skip
    assert cells == expected


def test_tables_are_html_and_the_notes_are_linked(done):
    out, res = done
    page = (out / "report.html").read_text()
    assert "<pre>" not in page  # no Markdown tables in preformatted blocks
    cells = re.findall(r"<td[^>]*>([^<]*)</td>", page)
    assert cells and not [c for c in cells if c.lstrip().startswith(("{", "[&quot;", "{&quot;"))]
    assert "PAPER_NOTES" not in page.split("<body>")[1].split("Generated by")[0]
    href = re.search(r'<a href="([^"]*paper_notes\.md)"', page)
    assert href and (out / href.group(1)).resolve().is_file()
    assert "mm^2/s^2" in page and "(mm)" in page  # values carry units


def test_no_empty_plot_and_no_rejected_fit(done):
    out, res = done
    page = (out / "report.html").read_text()
    reached = sum(r["reached"] for r in res["scaling"]["rows"])
    sentence = "no run at any swarm size reached the target line"
    assert (sentence in page) == (reached == 0)
    # one fitted line per system: the model the analysis kept
    for key in ("ants_real", "ants", "gas", "robots"):
        assert res["unified_law"][key]["preferred"] in ("one_phase", "two_phase")
    assert page.count("<video") + page.count('src="data:image/gif') >= 4  # the animations


def _title(page: str, name: str) -> str:
    """The h2 of experiment ``name``: the first heading that starts with its title."""
    short = TITLES[name]
    for h in re.findall(r"<h2>([^<]*)</h2>", page):
        text = html.unescape(h)
        if text.startswith(short) or short.lower() in text.lower():
            return text
    raise AssertionError(f"no section for {name}")


def test_a_rerun_reuses_the_runs_and_logs_one_line_per_step(done, capfd):
    out, res = done
    again = reproduce(out, plan=TINY, seed=0, workers=1, verbose=True)
    logged = capfd.readouterr()
    text = logged.out + logged.err
    assert "\r" not in text and "it/s" not in text  # no progress bar in a log
    lines = [ln for ln in text.splitlines() if ln.strip()]
    steps = [ln for ln in lines if re.match(r"^\[ *[\d. a-z]+\] \d/8 \w+ done in ", ln)]
    assert len(steps) == 8 and len(lines) == 9 and lines[-1].startswith("wrote ")
    assert all("left" in ln for ln in steps[:-1]) and "left" not in steps[-1]
    # the same runs, the same numbers
    assert again["compression"] == res["compression"]
    assert again["transport_free"] == res["transport_free"]
    assert again["regime"] == res["regime"] and again["scaling"] == res["scaling"]


def test_the_shared_pool_runs_in_worker_processes():
    """With more than one worker the sweeps' runs go to other processes (the test above
    runs in-process); one pool serves every submission."""
    import os

    pool = _Pool(2)
    try:
        pids = {pool.submit(os.getpid).result(timeout=120) for _ in range(3)}
    finally:
        pool.shutdown(wait=True)
    assert pids and os.getpid() not in pids
