"""The driver of ``thermoswarm reproduce``: every step of the plan in order, each
result judged against the paper, the report and ``results.json`` written."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from thermoswarm import __version__
from thermoswarm.fsutil import atomic_write_json, prepare_output_dir
from thermoswarm.reproduce.physical import _compression, _narrow_road
from thermoswarm.reproduce.plans import FULL, PLANS, QUICK, Plan
from thermoswarm.reproduce.runs import _duration, _Log, _Pool
from thermoswarm.reproduce.studies import _mechanism, _regime, _scaling
from thermoswarm.reproduce.text import _notes_link
from thermoswarm.reproduce.transport import _transport_connected, _transport_free
from thermoswarm.reproduce.unified import _unified

TITLES = {
    "unified_law": "One law, three systems",
    "narrow_road": "Narrow road",
    "compression": "Compression",
    "transport_connected": "Transport with connection",
    "transport_free": "Transport without connection",
    "regime": "Where the object moves fastest",
    "mechanism": "The transport mechanism",
    "scaling": "Scaling with swarm size",
}


def _front_matter(rep: Any, out: Path, plan: Plan) -> None:
    """The report's opening: the law, how to read the verdicts, the notes, the plan."""
    rep.paragraph(
        "Ants, physical particles and robot swarms move by one maximum-entropy law, "
        "p(x) = exp(-x / kT) / kT (Yin, Yu, Spino, Rus, arXiv 2511.05785). Every experiment "
        "below was run by `thermoswarm reproduce`; results.json holds the numbers. Each "
        "section opens with the paper's figure or number beside ours and a verdict: "
        "reproduced, partly (the direction, not the size, or not every part), differs "
        "(with the reason) or not measured."
    )
    _notes_link(rep, out, "Where the paper contradicts itself and what we do: ", ".")
    if plan.name != "full":
        rep.paragraph(
            f"The {plan.name} setting shortens runs and studies (see results.json and the "
            "README); `thermoswarm reproduce --full` runs the full-length experiments.",
            note=True,
        )


def _judge(
    name: str, results: dict[str, Any], rep: Any, first: int, overview: list[dict[str, str]]
) -> None:
    """Step ``name``'s result against the paper (:mod:`thermoswarm.report.paper`): the
    comparison atop its section (which starts at section ``first``), one overview line
    per claim, and the verdicts in ``results``."""
    from thermoswarm.report.paper import compare, summary_verdict

    rows = compare(name, results[name])
    if rows and rep.n_sections > first:
        rep.section_top(first, rep.comparison_html(rows, caption="The paper beside ours"))
    for i, r in enumerate(rows):  # one line per claim, the experiment named once
        overview.append({"experiment": TITLES.get(name, name) if i == 0 else "",
                         "claim": r["claim"], "verdict": r["verdict"]})  # fmt: skip
    results.setdefault("verdicts", {})[name] = {
        "overall": summary_verdict(rows),
        "claims": [{"claim": r["claim"], "verdict": r["verdict"]} for r in rows],
    }


def reproduce(
    out: str | Path,
    *,
    quick: bool = True,
    seed: int = 0,
    workers: int | None = None,
    verbose: bool = True,
    plan: Plan | str | None = None,
) -> dict[str, Any]:
    """Run every experiment into ``out`` and write the report; returns ``results.json``.

    ``plan``: a :class:`Plan` or the name of one (``"smoke"``, ``"quick"``, ``"full"``);
    default ``"quick"`` if ``quick`` else ``"full"``.  Finished runs in ``out`` are
    reused (a rerun after an interruption continues).  ``verbose``: one line per step
    (with what is left), and progress bars on a terminal.
    """
    from thermoswarm.report.html import HtmlReport

    if plan is None:
        plan = QUICK if quick else FULL
    elif isinstance(plan, str):
        plan = PLANS[plan]
    out = prepare_output_dir(out)
    for sub in ("animations", "unified", "compression", "transport-connected", "transport-free"):
        (out / sub).mkdir(exist_ok=True)
    rep = HtmlReport(
        "thermoswarm: the paper's robot experiments",
        subtitle=f"thermoswarm {__version__}, {plan.name} setting, seed {seed}",
    )
    _front_matter(rep, out, plan)
    glance = rep.n_sections
    with rep.section("At a glance: the paper beside our results"):
        pass
    results: dict[str, Any] = {"version": __version__, "setting": plan.name, "seed": seed}
    steps: list[tuple[str, Callable[..., dict[str, Any]]]] = [
        ("unified_law", lambda b: _unified(out, plan, rep, seed, b)),
        ("narrow_road", lambda b: _narrow_road(out, plan, rep, seed, b)),
        ("compression", lambda b: _compression(out, plan, rep, seed, b, pool)),
        ("transport_connected", lambda b: _transport_connected(out, plan, rep, seed, b)),
        ("transport_free", lambda b: _transport_free(out, plan, rep, seed, b)),
        ("regime", lambda b: _regime(out, plan, rep, workers, b, pool)),
        ("mechanism", lambda b: _mechanism(out, plan, rep, workers, b, pool)),
        ("scaling", lambda b: _scaling(out, plan, rep, workers, b, pool)),
    ]
    log = _Log(verbose, plan, [name for name, _ in steps], workers)
    log.start_up()
    overview: list[dict[str, str]] = []
    pool = _Pool(workers)
    try:
        for name, fn in steps:
            done = log.step(name)
            first = rep.n_sections
            results[name] = fn(log.bars)
            _judge(name, results, rep, first, overview)
            done()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    rep.section_top(glance, rep.verdicts_html(overview))
    results["seconds"] = log.times
    results["cpu_seconds"] = log.cpu  # per step: [this process, the worker processes]
    with rep.section("Run"):
        rep.table([{"step": k, "wall time (s)": v} for k, v in log.times.items()],
                  floatfmt=".0f")  # fmt: skip
    rep.write(out / "report.html")
    atomic_write_json(out / "results.json", results)
    if verbose:
        print(
            f"wrote {out / 'report.html'} and {out / 'results.json'} "
            f"in {_duration(time.perf_counter() - log.t0)}",
            flush=True,
        )
    return results
