"""Rebuild ``js16_xy_1_1_mm.csv`` from anTraX-data's ``JS16/antrax_demo/antdata/xy_1_1.csv``.

Usage (run from this folder): ``python make_excerpt.py XY_1_1.CSV OUT.CSV``.
Standard library only.

What it changes: positions from metres to mm, rounded to 0.01 mm (the camera's pixel
is 0.094 mm); the orientation (``_OR``) and ``_ass_type`` columns are dropped; columns
renamed ``<TAG>_x``/``<TAG>_y``; a ``frame`` column (0-based) and ``#`` metadata lines
(fps, unit, source) added.  NaN stays empty.  Coordinates shared by several ants
(anTraX gives every ant of a multi-ant blob the blob's position) are kept as they are:
the analysis must find and exclude them.
"""

import csv
import sys

FRAMES = 2400  # the first 240 s of movie 1 (10 frames/s), to stay under 500 KB


def main(src: str, dst: str) -> None:
    with open(src, newline="") as f:
        rows = list(csv.reader(f))
    head = rows[0]
    tags = [c[:-2] for c in head if c.endswith("_X")]
    col = {c: i for i, c in enumerate(head)}
    with open(dst, "w", newline="") as f:
        f.write("# fps: 10\n# space_unit: mm\n# source_software: anTraX\n")
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["frame"] + [f"{t}_{a}" for t in tags for a in ("x", "y")])
        for k, row in enumerate(rows[1 : FRAMES + 1]):
            out = [str(k)]
            for t in tags:
                for a in ("X", "Y"):
                    v = row[col[f"{t}_{a}"]]
                    out.append("" if v in ("NaN", "") else f"{float(v) * 1000:.2f}")
            w.writerow(out)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
