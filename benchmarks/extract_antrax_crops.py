"""Bring anTraX's JS16 ant crops and background frame out of a clone of anTraX-data,
for ``thermoswarm track train --real-crops DIR --background PNG --roi PNG``.

    python benchmarks/extract_antrax_crops.py ANTRAX_DATA_GIT_DIR OUT_DIR [--per-individual 200]

Writes ``OUT_DIR/crops/<LABEL>/*.png`` (up to ``--per-individual`` crops of each
individual, evenly spaced in name order), ``OUT_DIR/crops/labels.csv``,
``OUT_DIR/background.png`` and ``OUT_DIR/roimask.png``, all unchanged bytes of commit
HEAD of the clone (GPL-3.0; keep them out of this repository).

Only the JS16 colony recording is taken: files of
``JS16/antrax_demo/classifier/examples/<LABEL>/`` whose names start with
``15_10_08_15_47_56_colony_tracking`` and of the individuals' labels (``ant_labels``
in ``labels.csv``).  That folder also holds crops of other experiments (names with
``FOR1`` among them, reserved for acceptance): they are never read.
"""

from __future__ import annotations

import argparse
import subprocess
from collections import defaultdict
from pathlib import Path

BASE = "JS16/antrax_demo"
PREFIX = "15_10_08_15_47_56_colony_tracking"


def _git(git_dir: str, *args: str) -> bytes:
    return subprocess.run(["git", "--git-dir", git_dir, *args], check=True,
                          capture_output=True).stdout  # fmt: skip


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("git_dir")
    ap.add_argument("out", type=Path)
    ap.add_argument("--per-individual", type=int, default=200)
    args = ap.parse_args(argv)
    labels = _git(args.git_dir, "show", f"HEAD:{BASE}/parameters/labels.csv").decode()
    rows = [r.replace("\t", ",").split(",") for r in labels.splitlines()]
    ants = {r[0].strip() for r in rows if len(r) >= 2 and r[1].strip() == "ant_labels"}
    listing = _git(args.git_dir, "ls-tree", "-r", "HEAD", f"{BASE}/classifier/examples/")
    by_ant: dict[str, list[tuple[str, str]]] = defaultdict(list)
    for line in listing.decode().splitlines():
        meta, path = line.split("\t")
        label, name = path.split("/")[-2:]
        if label in ants and name.startswith(PREFIX) and "FOR1" not in name:
            by_ant[label].append((name, meta.split()[2]))
    crops = args.out / "crops"
    crops.mkdir(parents=True, exist_ok=True)
    (crops / "labels.csv").write_text(labels)
    batch = subprocess.Popen(["git", "--git-dir", args.git_dir, "cat-file", "--batch"],
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE)  # fmt: skip
    n = 0
    for label, items in sorted(by_ant.items()):
        items.sort()
        step = max(1, len(items) // args.per_individual)
        (crops / label).mkdir(exist_ok=True)
        for name, sha in items[::step][: args.per_individual]:
            batch.stdin.write(f"{sha}\n".encode())
            batch.stdin.flush()
            size = int(batch.stdout.readline().split()[2])
            (crops / label / name).write_bytes(batch.stdout.read(size))
            batch.stdout.read(1)
            n += 1
    batch.stdin.close()
    batch.wait()
    for src, dst in [("backgrounds/background.png", "background.png"),
                     ("masks/roimask.png", "roimask.png")]:  # fmt: skip
        (args.out / dst).write_bytes(_git(args.git_dir, "show", f"HEAD:{BASE}/parameters/{src}"))
    print(f"{n} crops of {len(by_ant)} individuals -> {crops}")


if __name__ == "__main__":
    main()
