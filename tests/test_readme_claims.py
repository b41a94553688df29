"""What README.md and docs/*.md quote must exist: every test they name, every benchmark
script and its options, every ``thermoswarm`` verb and its options quoted inline.

The fenced examples are run by ``tests/docs/test_examples.py``; this file covers the
sentences and tables: a claim that names ``tests/x.py::test_y`` fails here once that
test is renamed or removed, and ``python benchmarks/b.py --opt`` fails once the script
or its option is gone.  Also the sentences of the README that describe behaviour this
file checks directly (stepping in place).
"""

from __future__ import annotations

import ast
import re
import shlex
from pathlib import Path

import click
import numpy as np

from thermoswarm.cli import cli

REPO = Path(__file__).resolve().parents[1]
PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]

# a test named by path, optionally with its function: tests/a/b.py or tests/a/b.py::test_c
TEST_REF = re.compile(r"(tests/[\w/]+\.py)(?:::(\w+))?")
# a benchmark command quoted inline or in a block: python benchmarks/x.py [args]
BENCH_CMD = re.compile(r"python (benchmarks/\w+\.py)((?:[ \t]+(?:\\\n\s*)?[^`\n|;)]+)?)")
# an inline code span that starts with the command
VERB_SPAN = re.compile(r"`(thermoswarm [^`]+)`")


def _text(page: Path) -> str:
    return page.read_text(encoding="utf-8")


def _refs(regex: re.Pattern) -> list[tuple[str, re.Match]]:
    return [(p.name, m) for p in PAGES for m in regex.finditer(_text(p))]


def _functions(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return {n.name for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)}


def _option_literals(path: Path) -> set[str]:
    """Every string constant of a script that looks like an option (``--name``)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return {
        n.value
        for n in ast.walk(tree)
        if isinstance(n, ast.Constant) and isinstance(n.value, str) and n.value.startswith("-")
    }


def test_the_pages_quote_tests_benchmarks_and_commands():
    # the checks below must have something to check (a regex that matches nothing
    # would pass them all)
    assert len(_refs(TEST_REF)) >= 20
    assert len(_refs(BENCH_CMD)) >= 15
    assert len(_refs(VERB_SPAN)) >= 20


def test_every_named_test_exists():
    missing = []
    for page, m in _refs(TEST_REF):
        path = REPO / m.group(1)
        if not path.is_file():
            missing.append(f"{page}: {m.group(0)} (no such file)")
        elif m.group(2) and m.group(2) not in _functions(path):
            missing.append(f"{page}: {m.group(0)} (no such test)")
    assert not missing, "\n".join(missing)


def test_every_quoted_benchmark_script_and_option_exists():
    missing = []
    for page, m in _refs(BENCH_CMD):
        path = REPO / m.group(1)
        if not path.is_file():
            missing.append(f"{page}: {m.group(0).strip()} (no such script)")
            continue
        known = _option_literals(path)
        args = re.sub(r"\\\n\s*", " ", m.group(2) or "")
        try:
            words = shlex.split(args)
        except ValueError:
            words = args.split()
        for w in words:
            opt = w.split("=")[0]
            if re.fullmatch(r"--[a-z][\w-]*", opt) and opt not in known:
                missing.append(f"{page}: {m.group(1)} has no option {opt}")
    assert not missing, "\n".join(missing)


def _command(words: list[str]) -> tuple[click.Command, str] | None:
    """The (sub)command a quoted ``thermoswarm`` span names, or None if it names none."""
    cmd: click.Command = cli
    name = "thermoswarm"
    if words[:2] == ["track", "train"]:  # routed to `track-train` by the command group
        words = ["track-train", *words[2:]]
    for w in words:
        if not isinstance(cmd, click.Group) or w.startswith("-"):
            break
        sub = cmd.get_command(click.Context(cmd), w)
        if sub is None:
            return None
        cmd, name = sub, f"{name} {w}"
    return cmd, name


def test_every_inline_thermoswarm_command_and_option_exists():
    bad = []
    for page, m in _refs(VERB_SPAN):
        try:
            words = shlex.split(m.group(1))[1:]
        except ValueError:
            words = m.group(1).split()[1:]
        if not words or words[0].startswith("-") or words[0] in ("...", "VERB"):
            continue
        found = _command(words)
        if found is None:
            bad.append(f"{page}: `{m.group(1)}`: no such command")
            continue
        cmd, name = found
        opts = {o for p in cmd.params for o in (*p.opts, *p.secondary_opts)}
        opts |= {"--help"}
        for w in words:
            opt = w.split("=")[0]
            if re.fullmatch(r"--[a-z][\w-]*", opt) and opt not in opts:
                bad.append(f"{page}: `{m.group(1)}`: {name} has no option {opt}")
    assert not bad, "\n".join(bad)


def test_step_advances_the_state_in_place():
    """README, "From Python": ``step`` returns the same state object, advanced in
    place; a position array read before the step is not a copy to keep."""
    from thermoswarm.policy import BoltzmannUniform
    from thermoswarm.sim import EngineParams, box_world, place_lattice, simulator

    world = box_world(1000.0, 1000.0)
    init, step = simulator(world, EngineParams(dt=0.1, tau=1.0), BoltzmannUniform(kT=63.7))
    rng = np.random.default_rng(1)
    state = init(place_lattice(world.bounds, 200, 16.5, rng), rng)
    kept = state.by_id(state.pos).copy()
    arrays = []
    for _ in range(5):
        arrays.append(state.pos)
        assert step(state) is state
    assert state.step == 5
    moved = np.hypot(*(state.by_id(state.pos) - kept).T)
    assert np.all(np.isfinite(moved)) and moved.max() > 0
    # the state's arrays are reused: no new position array per step
    assert len({id(a) for a in arrays}) <= 2


def _benchmark(name: str):
    """Import ``benchmarks/NAME.py`` as a module."""
    import importlib.util
    import sys

    path = REPO / "benchmarks" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"_bench_{name}", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up
    sys.path.insert(0, str(path.parent))
    try:
        spec.loader.exec_module(mod)
    finally:
        sys.path.remove(str(path.parent))
    return mod


#: Benchmarks that ``make bench`` does not run, and why (anything else must be a step).
ON_THEIR_OWN = {
    "bench_real_footage": "needs the user's own labelled footage",
    "bench_niche_counts": "needs the Niche-Lab photos, which may not be redistributed",
    "bench_moving_camera": "needs a real still clip (SLEAP's fly clip), not in git",
}


def test_make_bench_runs_every_benchmark():
    """README, "Performance": `make bench` runs every benchmark but the ones it names."""
    run_all = _benchmark("run_all")
    steps = {s.script for s in run_all.STEPS}
    scripts = {p.stem for p in (REPO / "benchmarks").glob("bench_*.py")}
    missing = scripts - steps - set(ON_THEIR_OWN)
    assert not missing, f"benchmarks that make bench does not run: {sorted(missing)}"
    every = {p.stem for p in (REPO / "benchmarks").glob("*.py")}
    assert steps <= every, f"steps without a script: {sorted(steps - every)}"


def _readme_rows() -> list[str]:
    """The table rows of README.md (its headline figures, wherever the table sits)."""
    lines = _text(REPO / "README.md").splitlines()
    return [ln for ln in lines if ln.startswith("| ") and "---" not in ln]


def _words(cmd: str) -> list[str]:
    """A command's words, ``--json``, leading ``NAME=value`` settings and a leading
    ``nice -n N`` dropped."""
    w = [x for x in shlex.split(cmd) if x != "--json"]
    while w and re.fullmatch(r"[A-Z_]+=\S*", w[0]):
        w = w[1:]
    return w[3:] if w[:1] == ["nice"] else w


def test_every_benchmark_figure_of_the_readme_is_printed_by_make_bench():
    """Item 5 of issue 23: every headline figure the README quotes from a benchmark
    command is printed by `make bench`, which runs that same command (its arguments as
    quoted, ``--json`` aside), or the script is one `make bench` cannot run
    (:data:`ON_THEIR_OWN`, with its reason)."""
    run_all = _benchmark("run_all")
    printed = [_words(run_all.command(s)) for s in run_all.STEPS]
    rows = _readme_rows()
    assert len(rows) >= 8
    quoted, bad = 0, []
    for row in rows:
        for m in re.finditer(r"`(python benchmarks/(\w+)\.py[^`]*)`", row):
            quoted += 1
            if m.group(2) in ON_THEIR_OWN:
                continue
            if _words(m.group(1)) not in printed:
                bad.append(m.group(1))
    assert quoted >= 5
    assert not bad, "quoted in the README, not run by make bench: " + "; ".join(bad)


def test_make_bench_prints_each_command_beside_its_table(capsys, monkeypatch):
    """`make bench` prints, for each step, its header and the command (the same line
    the README quotes), then the step's output; a step that fails says so."""
    run_all = _benchmark("run_all")
    seen = []

    metrics = {"mota": 0.931, "idf1": 0.9, "track_fps": 12.0}
    results = {
        "tracking": {"runs": [metrics, {**metrics, "mota": 0.95}], "video": {"n_ants": 40}},
        "unet": {"runs": [{"classical": metrics, "unet": {**metrics, "mota": 0.977}}]},
    }

    def fake_run(step, args):
        seen.append((step.name, args))
        if step.name == "io":
            return None  # a step that failed
        return results[step.name] if step.json else "TABLE " + step.name

    monkeypatch.setattr(run_all, "_run", fake_run)
    monkeypatch.setattr(run_all.importlib.util, "find_spec", lambda name: object())
    assert run_all.main([]) == 0
    out = capsys.readouterr().out
    assert [name for name, _ in seen] == [s.name for s in run_all.STEPS]
    for step in run_all.STEPS:
        head = out.index(f"## {step.name}")
        if step.name != "tracking_real":
            assert out.index("command: " + run_all.command(step), head) > head
    assert "TABLE engine" in out and "TABLE limit" in out and "TABLE gpu_rehearse" in out
    assert "2 seeds (1080p, 40 ants): MOTA 0.931-0.950" in out
    assert "unet      1 seeds: MOTA 0.977" in out
    assert "TABLE io" not in out
    engine = dict(seen)["engine"]
    assert "1000000" in engine and "--budget-s" in engine


def test_analysis_benchmark_compares_the_same_optimum(capsys):
    """README, "Other benchmarks": ours and SciPy do the same work and reach the same
    optimum (log-likelihoods per sample within 1e-6, LR p-values within their Monte
    Carlo error); a tiny instance of the benchmark itself."""
    bench = _benchmark("bench_analysis")
    out = bench.main(["--n-tracks", "20", "--n-frames", "500", "--bootstrap", "9", "--json"])
    capsys.readouterr()
    assert out["same_optimum"] == {"two_phase_fit": True, "lr_statistic": True, "lr_p_value": True}
    fit = out["same_work"]["two_phase_fit_all_energies"]
    assert fit["loglik_gap_per_sample"] <= 1e-6
    assert fit["n"] == out["n_energy_samples"]
    lr = out["same_work"]["lr_test_bootstrap"]
    assert lr["replicates"] == 9 and lr["statistic_gap_per_sample"] <= 1e-6


def test_light_benchmark_runs_ours_on_numpys_single_thread():
    """README, "Other benchmarks": the light benchmark times ours on one thread, as
    NumPy, unless asked otherwise; its answer matches the NumPy shadow test."""
    import numba

    before = numba.get_num_threads()
    try:
        res = _benchmark("bench_light").run(sizes=(2000,), repeat=1)
        assert res["numba_threads"] == 1
        assert res["sizes"][0]["light_level_mismatches_vs_numpy"] == 0
    finally:
        numba.set_num_threads(before)
