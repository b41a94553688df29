"""Cut one video's real detector output and ground truth into frame ranges, as sequence
folders that ``bench_tracking_real.py DATA --use-det`` reads.

Each range ``A-B`` becomes ``OUT/<name>-A-B/det/det.txt`` and ``.../gt/gt.txt``: the
rows of frames ``A`` to ``B`` (inclusive), renumbered from frame 1.  Tune on some ranges
and report on the others (``--tune <name>-A-B``)::

    python benchmarks/split_mot_sequence.py track_clip/detections.txt clip_gt.txt DATA \\
        --name fly --ranges 979-1239 1240-1500
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from thermoswarm.errors import InputError
from thermoswarm.io.mot import read_mot_table, write_mot_table


def _range(text: str) -> tuple[int, int]:
    a, _, b = text.partition("-")
    if not (a.isdigit() and b.isdigit() and 1 <= int(a) <= int(b)):
        raise argparse.ArgumentTypeError(
            f"expected a frame range A-B with 1 <= A <= B, got {text!r}"
        )
    return int(a), int(b)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "det", type=Path, help="MOT rows of detector output (frame, -1, x, y, w, h, score)"
    )
    ap.add_argument("gt", type=Path, help="MOT ground truth of the same frames")
    ap.add_argument("out", type=Path, help="folder for the sequence folders")
    ap.add_argument("--name", default="seq", help="sequence name prefix")
    ap.add_argument("--ranges", nargs="+", type=_range, required=True, metavar="A-B")
    args = ap.parse_args(argv)
    try:
        tables = {"det": read_mot_table(args.det), "gt": read_mot_table(args.gt)}
    except InputError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for a, b in args.ranges:
        seq = args.out / f"{args.name}-{a}-{b}"
        for kind, t in tables.items():
            part = t[(t[:, 0] >= a) & (t[:, 0] <= b)].copy()
            part[:, 0] -= a - 1
            (seq / kind).mkdir(parents=True, exist_ok=True)
            write_mot_table(seq / kind / f"{kind}.txt", part)
        counts = {k: int(((t[:, 0] >= a) & (t[:, 0] <= b)).sum()) for k, t in tables.items()}
        print(f"{seq}: {counts['det']} detections, {counts['gt']} ground-truth boxes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
