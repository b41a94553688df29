"""Analysis A/B: ``thermoswarm analyze`` from two git revisions on the same inputs, and
the diff of their ``fits.json`` files (empty when the two agree byte for byte).

The base revision's ``src/`` is exported with ``git archive`` into a temporary
directory and put first on ``PYTHONPATH``; the new side is this worktree (or
``--new DIR``, a checkout's root).  Both run with this interpreter, so the installed
libraries are the same; only the package differs.  Each case runs in a fresh process
per side, into its own output directory; the script prints, per case, ``identical``
(with the file's size and SHA-256) or the unified diff of the two files.

Cases: the built-in list (``--list`` prints it): the test data of the repository (a
synthetic two-phase file written here, with regions, groups, smoothing and gaps; the
TRex locusts and the SLEAP flies of ``tests/data``) and, where ``--ants DIR`` names
the directory of the *Polyrhachis* CSV files of docs/real_data.md (data outside git),
that dataset's two commands.  ``--bootstrap N`` replaces the documented 200 bootstrap
replicates of every case (the statistics run the same code at any N).

Usage::

    python benchmarks/analyze_ab.py --base 662e3a3 --ants /tmp/ants
    python benchmarks/analyze_ab.py --base 662e3a3 --only locusts --only flies
"""

from __future__ import annotations

import argparse
import difflib
import hashlib
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data"
ANTS = ("3610", "3615", "3625", "3627", "3633", "3637", "3639")


def cases(synthetic: Path, ants: Path | None) -> dict[str, list[str]]:
    """Case name -> the ``analyze`` arguments (inputs and options, no ``--out``)."""
    regions = synthetic.parent / "regions.toml"
    out = {
        "synthetic": [str(synthetic), "--regions", str(regions), "--group-by", "colony",
                      "--group-by", "region", "--group-by", "time:3", "--energy-bins", "4",
                      "--test-size", "1000", "--seed", "3"],
        "synthetic-clean": [str(synthetic), "--smooth", "0.2", "--max-gap", "0.2",
                            "--min-track-extent", "5", "--body-length", "2",
                            "--drop-stationary", "--resting-speed", "0.5", "--keep-resting",
                            "--held-positions", "missing", "--mass", "1e-5",
                            "--steering-by", "speed", "--energy-bins", "0,10,20,40",
                            "--thin", "2", "--alpha", "0.1", "--max-plausible-speed", "80"],
        "locusts": [str(DATA / "trex_locusts"), "--fps", "5", "--max-plausible-speed", "100",
                    "--regions", str(DATA / "trex_locusts" / "regions.toml"),
                    "--group-by", "region", "--group-by", "time:120"],
        "flies": [str(DATA / "sleap_flies" / "flies.analysis.h5"), "--fps", "25",
                  "--px-per-mm", "30", "--max-plausible-speed", "50", "--group-by", "time:30"],
    }  # fmt: skip
    if ants is not None:
        files = [str(ants / f"{v}.csv") for v in ANTS]
        out["ants-all"] = [*files, "--read-option", "units=m"]
        out["ants"] = [*files, "--read-option", "units=m", "--min-track-extent", "30",
                       "--body-length", "6.5", "--group-by", "recording"]  # fmt: skip
    return out


def write_synthetic(where: Path) -> Path:
    """A two-phase synthetic file with a categorical variable, some gaps and a region file."""
    import numpy as np

    from thermoswarm.analysis.synthetic import synthetic_tracks
    from thermoswarm.io import write_tracks
    from thermoswarm.maxent import EnergyMixture

    ds, _ = synthetic_tracks(12, 151, energy=EnergyMixture(0.6, 20.0, 80.0), fps=25.0, rng=5)
    ds["colony"] = ("individuals", np.array(["A", "B"] * 6))
    pos = ds["position"].values.copy()
    pos[40:43, :, 0, 2] = np.nan  # a short gap in one track
    ds["position"] = (ds["position"].dims, pos)
    path = where / "tracks.nc"
    write_tracks(ds, path)
    (where / "regions.toml").write_text(
        '[[region]]\nname = "left"\nrect = [-1e5, -1e5, 0, 1e5]\n'
        '[[region]]\nname = "right"\nrect = [0, -1e5, 1e5, 1e5]\n'
    )
    return path


def run_side(src: Path, args: list[str], out: Path, bootstrap: int | None) -> str:
    """Run ``analyze`` with package ``src`` first on the path; '' or the error's tail."""
    env = dict(os.environ, PYTHONPATH=str(src))
    extra = [] if bootstrap is None else ["--bootstrap", str(bootstrap)]
    cmd = [sys.executable, "-m", "thermoswarm", "analyze", *args, *extra, "--out", str(out),
           "-q", "--no-report"]  # fmt: skip
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    return "" if proc.returncode == 0 else (proc.stdout + proc.stderr)[-800:]


def compare(a: Path, b: Path) -> str:
    """``identical ...`` or the unified diff of two files."""
    x, y = a.read_bytes(), b.read_bytes()
    if x == y:
        return f"identical ({len(x)} bytes, sha256 {hashlib.sha256(x).hexdigest()[:16]})"
    diff = difflib.unified_diff(x.decode().splitlines(), y.decode().splitlines(),
                                "base/fits.json", "new/fits.json", lineterm="", n=1)  # fmt: skip
    return "DIFFERENT\n" + "\n".join(list(diff)[:80])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", required=True, help="git revision of the base side")
    ap.add_argument("--new", type=Path, default=ROOT, help="root of the new side's checkout")
    ap.add_argument("--ants", type=Path, default=None, help="directory of the ants' CSVs")
    ap.add_argument("--only", action="append", default=None, help="run only this case")
    ap.add_argument("--bootstrap", type=int, default=None, help="replicates (default 200)")
    ap.add_argument("--list", action="store_true", help="print the cases and exit")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="analyze_ab_") as tmp:
        tmp = Path(tmp)
        base = tmp / "base"
        base.mkdir()
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", args.base, "src"],
                                 check=True, capture_output=True).stdout  # fmt: skip
        subprocess.run(["tar", "-x", "-C", str(base)], input=archive, check=True)
        data = tmp / "data"
        data.mkdir()
        table = cases(write_synthetic(data), args.ants)
        if args.list:
            for name, a in table.items():
                print(f"{name}: analyze {' '.join(a)}")
            return 0
        bad = 0
        for name, a in table.items():
            if args.only and name not in args.only:
                continue
            outs = {side: tmp / side / name for side in ("base", "new")}
            errs = {"base": run_side(base / "src", a, outs["base"], args.bootstrap),
                    "new": run_side(args.new / "src", a, outs["new"], args.bootstrap)}  # fmt: skip
            if any(errs.values()):
                verdict = "FAILED " + " | ".join(f"{k}: {v}" for k, v in errs.items() if v)
            else:
                verdict = compare(outs["base"] / "fits.json", outs["new"] / "fits.json")
            bad += not verdict.startswith("identical")
            print(f"{name}: {verdict}", flush=True)
        return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
