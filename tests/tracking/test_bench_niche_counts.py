"""benchmarks/bench_niche_counts.py: the food patches ("on a patch": the tool's
``detect --regions color:8-45``), the labels reader and the table, on tray photos
drawn here (the Niche-Lab photos carry no licence; the benchmark's numbers on them are
in docs/real_footage.md)."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import cv2
import numpy as np
import pytest
from click.testing import CliRunner
from tracking_fixtures import bench_module

from thermoswarm.cli import cli

W, H = 400, 300
L = 24.0  # drawn ant length, px
LEFT_PAPER = (40, 60, 150, 200)  # x0, y0, x1, y1
RIGHT_PAPER = (250, 80, 360, 220)


@pytest.fixture(scope="module")
def bench():
    return bench_module("bench_niche_counts")


def _tray(ants: list[tuple[float, float]]) -> np.ndarray:
    """An RGB tray: grey floor, two clear dishes with pale liquid, an orange and a
    lime paper, loose orange paper at the top-left border, dark elliptic ants."""
    img = np.full((H, W, 3), 200, np.uint8)
    for cx in (100, 300):
        cv2.circle(img, (cx, 150), 95, (225, 220, 180), -1)  # pale liquid: low saturation
        cv2.circle(img, (cx, 150), 95, (170, 170, 170), 2)  # the rim
    cv2.rectangle(img, LEFT_PAPER[:2], LEFT_PAPER[2:], (250, 165, 20), -1)
    cv2.rectangle(img, RIGHT_PAPER[:2], RIGHT_PAPER[2:], (210, 230, 20), -1)
    cv2.rectangle(img, (0, 0), (30, 60), (250, 165, 20), -1)  # loose paper at the border
    for k, (x, y) in enumerate(ants):
        axes = (int(L / 2), int(L / 6))
        cv2.ellipse(img, (int(x), int(y)), axes, 37.0 * k, 0, 360, (40, 30, 25), -1)
    return img


def test_patches_and_margin():
    # The patch finder is the tool's (detect --regions color:8-45); the benchmark uses it.
    from thermoswarm.tracking.pipeline import patches

    # Truth: on the left paper 3 ants, one 8 px outside its right edge (within the
    # margin of L/2 = 12 px), one 40 px outside (off); on the right paper 2; one on
    # the loose border paper (not a patch).
    ants = [(60, 100), (90, 150), (120, 180), (158, 130), (190, 130), (280, 120), (330, 200)]
    ants.append((15, 30))
    img = _tray(ants)
    masks = patches.find_patches(img, L)
    grown = {k: patches.grow(m, 0.5 * L) for k, m in masks.items()}
    bodies = np.array(ants, float)
    assert patches.on_patch(bodies, grown["left"]).tolist() == [1, 1, 1, 1, 0, 0, 0, 0]
    assert patches.on_patch(bodies, grown["right"]).tolist() == [0, 0, 0, 0, 0, 1, 1, 0]
    # The patch is the paper with the ants' holes filled: its area is the paper's.
    x0, y0, x1, y1 = LEFT_PAPER
    assert masks["left"].sum() == pytest.approx((x1 - x0 + 1) * (y1 - y0 + 1), rel=0.02)


def _xlsx(path: Path, sheets: dict[str, list[list]]) -> None:
    """A minimal workbook (inline numbers, shared strings for the text)."""
    strings: list[str] = []

    def cell(ref: str, v) -> str:
        if isinstance(v, str):
            strings.append(v)
            return f'<c r="{ref}" t="s"><v>{len(strings) - 1}</v></c>'
        return f'<c r="{ref}"><v>{v}</v></c>'

    ns = 'xmlns="http://schemas.openxmlformats.org/spreadsheetml/2006/main"'
    rns = 'xmlns:r="http://schemas.openxmlformats.org/officeDocument/2006/relationships"'
    with zipfile.ZipFile(path, "w") as z:
        entries, rels = [], []
        for i, (name, rows) in enumerate(sheets.items(), start=1):
            body = "".join(
                f'<row r="{r + 1}">'
                + "".join(cell(f"{chr(65 + c)}{r + 1}", v) for c, v in enumerate(row))
                + "</row>"
                for r, row in enumerate(rows)
            )
            sheet = f"<worksheet {ns}><sheetData>{body}</sheetData></worksheet>"
            z.writestr(f"xl/worksheets/sheet{i}.xml", sheet)
            entries.append(f'<sheet name="{name}" sheetId="{i}" r:id="rId{i}"/>')
            rels.append(f'<Relationship Id="rId{i}" Target="worksheets/sheet{i}.xml"/>')
        book = f"<workbook {ns} {rns}><sheets>{''.join(entries)}</sheets></workbook>"
        z.writestr("xl/workbook.xml", book)
        z.writestr(
            "xl/_rels/workbook.xml.rels",
            '<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">'
            + "".join(rels)
            + "</Relationships>",
        )
        sst = "".join(f"<si><t>{s}</t></si>" for s in strings)
        z.writestr("xl/sharedStrings.xml", f"<sst {ns}>{sst}</sst>")


def test_labels_from_the_workbook_read_only_the_trials_asked(bench, tmp_path):
    head = ["Photo Number G0011...", "Time", "Sucrose", "Peptone", "Total Foragers"]
    _xlsx(
        tmp_path / "t.xlsx",
        {
            "Set-up": [["x"]],
            "P v S 1": [head, [411, 0.73, 0, 0, 0], [1053, 0.75, 12, 5, 17], [999, 0.8, "", 1, 1]],
            "P v S 7": [head, [647, 0.4, 8, 3, 11]],
        },
    )
    labels = bench.labels_from_xlsx(tmp_path / "t.xlsx", (1, 2))
    # The authors' names: the photo number's last three digits; a row without a
    # sucrose count is skipped; trial 7 is not read.
    assert labels == {"t1_411.JPG": (1, 0, 0), "t1_053.JPG": (1, 12, 5)}


def _write_split(root: Path, split: str, trial: int, counts: list[tuple[int, int]], rng) -> None:
    (root / split).mkdir(parents=True)
    rows = ["filename,time,sucrose,peptone,total_foragers,trial,split"]
    for k, (n_left, n_right) in enumerate(counts):
        ants = [
            (rng.uniform(LEFT_PAPER[0] + 15, LEFT_PAPER[2] - 15), 70 + 40 * j)
            for j in range(n_left)
        ]
        ants += [
            (rng.uniform(RIGHT_PAPER[0] + 15, RIGHT_PAPER[2] - 15), 95 + 40 * j)
            for j in range(n_right)
        ]
        ants += [(200.0, rng.uniform(40, 260)), (rng.uniform(60, 340), 285.0)]  # off
        name = f"t{trial}_{k:03d}.JPG"
        img = _tray(ants)
        jpeg = [cv2.IMWRITE_JPEG_QUALITY, 92]
        assert cv2.imwrite(str(root / split / name), img[..., ::-1], jpeg)
        side = {1: "left", 6: "right"}[trial]  # as bench.SUCROSE_SIDE
        s, p = (n_left, n_right) if side == "left" else (n_right, n_left)
        rows.append(f"{name},00:00,{s},{p},{s + p},trial_{trial},{split}")
    (root / split / "annotation.txt").write_text("\n".join(rows) + "\n")


def test_table_on_drawn_trials(bench, tmp_path):
    # 10 train photos (trial 1, sucrose on the left) and 6 val photos (trial 6, on the
    # right), 0-3 ants on each paper and 2 on the floor, at new places in every photo.
    # The ants are drawn apart, so every count should be exact; allowed: one
    # miscounted photo per patch in val (MAE <= 1/6).
    rng = np.random.default_rng(3)
    _write_split(tmp_path, "train", 1, [tuple(rng.integers(0, 4, 2)) for _ in range(10)], rng)
    _write_split(tmp_path, "val", 6, [tuple(rng.integers(0, 4, 2)) for _ in range(6)], rng)
    out = tmp_path / "r.json"
    assert bench.main([str(tmp_path), "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    assert res["tuned_sides"] == {"1": "left"}
    for patch in ("sucrose", "peptone"):
        assert res["table"]["val"][patch]["mae"] <= 1 / 6 + 1e-9, res["table"]["val"]
        assert res["table"]["val"][patch]["n"] == 6
    # The benchmark detects with the tool: the drawn photos, ants elsewhere in each,
    # are a photo series to it.
    assert res["photo_series"]["1"]["recognised_by"] == "changes"
    # A finished `thermoswarm detect t<N> --out D/t<N>` per trial scores the same.
    runs = tmp_path / "runs"
    for trial, split in ((1, "train"), (6, "val")):
        (tmp_path / f"t{trial}").symlink_to(tmp_path / split)
        args = ["detect", str(tmp_path / f"t{trial}"), "--out", str(runs / f"t{trial}")]
        assert CliRunner().invoke(cli, args).exit_code == 0
    out2 = tmp_path / "r2.json"
    assert bench.main([str(tmp_path), "--detections-dir", str(runs), "--json", str(out2)]) == 0
    res2 = json.loads(out2.read_text())
    for split in ("train", "val"):
        for patch in ("sucrose", "peptone", "total"):
            a, b = res["table"][split][patch], res2["table"][split][patch]
            assert a["mae"] == pytest.approx(b["mae"]) and a["rho"] == pytest.approx(b["rho"])


def test_missing_folder_is_one_line_error(bench, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        bench.main([str(tmp_path / "nope")])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and "nope" in err[0]
