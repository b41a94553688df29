"""Regions found as coloured patches (``detect --regions color:LO-HI``) on drawn tray
photos: a grey floor, an orange paper in each half that moves by a pixel from photo to
photo, loose orange paper at the border, dark ants on and off the papers."""

from __future__ import annotations

import csv

import cv2
import numpy as np
import pytest
from click.testing import CliRunner

from thermoswarm.cli import cli
from thermoswarm.errors import InputError
from thermoswarm.tracking.pipeline.patches import parse_color_regions

W, H, N = 400, 300, 14
PAPERS = [(50, 70, 160, 230), (240, 70, 350, 230)]  # x0, y0, x1, y1 (before drifting)


def _photo(rng: np.random.Generator) -> tuple[np.ndarray, list[int]]:
    """One photo (BGR) and its truth: ants on the left paper, the right, off both."""
    img = np.full((H, W, 3), 190, np.uint8)
    img += rng.integers(0, 6, img.shape, dtype=np.uint8)
    cv2.rectangle(img, (0, 0), (25, 50), (20, 165, 250), -1)  # loose paper at the border
    truth = []
    ants = []
    for x0, y0, x1, y1 in PAPERS:
        dx, dy = rng.integers(-1, 2, 2)  # a nudged camera
        x0, x1, y0, y1 = x0 + dx, x1 + dx, y0 + dy, y1 + dy
        cv2.rectangle(img, (int(x0), int(y0)), (int(x1), int(y1)), (20, 165, 250), -1)
        n = int(rng.integers(0, 5))
        cells = rng.permutation(6)[:n]  # 2 x 3 cells of the paper, one ant each
        ants += [(x0 + 30 + 50 * (c % 2), y0 + 30 + 50 * (c // 2)) for c in cells]
        truth.append(n)
    off = int(rng.integers(0, 3))
    for j in rng.permutation(3)[:off]:  # the gap between the papers, a new place each time
        ants.append((200 + rng.uniform(-5, 5), 60 + 90 * j + rng.uniform(-25, 25)))
    truth.append(off)
    for k, (x, y) in enumerate(ants):
        ang = float(rng.uniform(0, 180))
        cv2.ellipse(img, (int(x), int(y)), (10, 3), ang + 7 * k, 0, 360, (25, 30, 40), -1)
    return img, truth


@pytest.fixture(scope="module")
def tray(tmp_path_factory):
    rng = np.random.default_rng(21)
    folder = tmp_path_factory.mktemp("patches") / "tray"
    folder.mkdir()
    truth = []
    for k in range(N):
        img, t = _photo(rng)
        assert cv2.imwrite(str(folder / f"tray_{k:03d}.png"), img)
        truth.append(t)
    return folder, np.array(truth)


def _detect_counts(folder, out, spec: str) -> tuple[list[str], np.ndarray]:
    """``detect FOLDER --regions SPEC``: the CSV's files and (left, right, outside)."""
    res = CliRunner().invoke(cli, ["detect", str(folder), "--out", str(out), "--regions", spec])
    assert res.exit_code == 0, res.output
    with open(out / "tray_regions.csv") as f:
        rows = list(csv.DictReader(f))
    got = np.array([[int(r["left"]), int(r["right"]), int(r["outside"])] for r in rows])
    return [r["file"] for r in rows], got


def test_counts_on_coloured_patches(tray, tmp_path):
    folder, truth = tray
    out = tmp_path / "d"
    files, got = _detect_counts(folder, out, "color:8-45")
    assert files == [f"tray_{k:03d}.png" for k in range(N)]
    # Every ant on its paper or off it, in every photo (one miss or extra in all 14).
    assert np.abs(got - truth).sum() <= 1, np.column_stack([got, truth])
    pics = sorted((out / "tray_regions").iterdir())
    assert [p.name for p in pics] == [f"tray_{k:03d}.jpg" for k in range(N)]
    # The picture draws the left patch's outline (blue, RGB 0,114,178) around the paper.
    img = cv2.imread(str(pics[0]))[..., ::-1].astype(int)
    blue = np.abs(img - np.array([0, 114, 178])).sum(-1) < 60
    ys, xs = np.nonzero(blue[40:, :])
    assert xs.min() < PAPERS[0][0] and xs.max() > PAPERS[0][2] - 10 and xs.max() < W // 2


def test_another_hue_finds_no_patch(tray, tmp_path):
    folder, truth = tray
    _, got = _detect_counts(folder, tmp_path / "d", "color:90-130")
    assert got[:, :2].sum() == 0 and got[:, 2].sum() == pytest.approx(truth.sum(), abs=1)


@pytest.mark.parametrize(
    "spec",
    [
        "color:8",
        "color:45-8",
        "color:8-45,sat=300",
        "color:8-45,foo=1",
        "colr:8-45",
        "color:8-45,split=diag",
        "color:8-45+color:90-130",  # both would be left and right
        "color:8-45,name=outside",
        "color:8-45,name=2x",
    ],
)
def test_bad_colour_spec_is_a_one_line_error(tray, tmp_path, spec):
    folder, _ = tray
    res = CliRunner().invoke(
        cli, ["detect", str(folder), "--out", str(tmp_path / "o"), "--regions", spec]
    )
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and spec in lines[0], res.output


def test_colour_spec_options():
    (spec,) = parse_color_regions("color:8-45,sat=120,margin=0.25").patches
    assert (spec.hue, spec.min_sat, spec.min_val, spec.margin_bl) == ((8, 45), 120, 100, 0.25)
    assert spec.names == ("left", "right")
    two = parse_color_regions("color:8-45,name=sucrose+color:95-130,name=peptone,split=tb")
    assert two.names == ("sucrose", "peptone_top", "peptone_bottom")
    quad = parse_color_regions("color:8-45,split=quad").names
    assert quad == ("top_left", "top_right", "bottom_left", "bottom_right")
    assert parse_color_regions("color:8-45,split=none").names == ("patch",)
    with pytest.raises(InputError, match="margin"):
        parse_color_regions("color:8-45,margin=x")


#: Four baits in the four quarters: orange papers top left and bottom right, blue ones
#: top right and bottom left (x0, y0, x1, y1, BGR).
BAITS = [
    (40, 30, 150, 120, (20, 165, 250)),
    (250, 30, 360, 120, (220, 120, 30)),
    (40, 170, 150, 260, (220, 120, 30)),
    (250, 170, 360, 260, (20, 165, 250)),
]


@pytest.fixture(scope="module")
def four_baits(tmp_path_factory):
    """6 photos of a tray with four baits in two colours, ants on each; the truth per
    photo is the ants on each bait, in BAITS' order, then those on none."""
    rng = np.random.default_rng(5)
    folder = tmp_path_factory.mktemp("baits") / "quad"
    folder.mkdir()
    truth = []
    for k in range(6):
        img = np.full((H, W, 3), 190, np.uint8) + rng.integers(0, 6, (H, W, 3), dtype=np.uint8)
        ants, t = [], []
        for x0, y0, x1, y1, bgr in BAITS:
            cv2.rectangle(img, (x0, y0), (x1, y1), bgr, -1)
            n = int(rng.integers(0, 4))
            cells = rng.permutation(6)[:n]  # 3 x 2 cells of the paper, one ant each
            ants += [(x0 + 20 + 35 * (c % 3), y0 + 25 + 40 * (c // 3)) for c in cells]
            t.append(n)
        off = int(rng.integers(0, 3))
        ants += [(200, 40 + 110 * j) for j in range(off)]  # the cross between the baits
        t.append(off)
        for j, (x, y) in enumerate(ants):
            cv2.ellipse(img, (int(x), int(y)), (10, 3), 30 + 40 * j, 0, 360, (25, 30, 40), -1)
        assert cv2.imwrite(str(folder / f"quad_{k:03d}.png"), img)
        truth.append(t)
    return folder, np.array(truth)


QUARTERS = ("top_left", "top_right", "bottom_left", "bottom_right")


def _detect_columns(folder, out, spec: str, columns: list[str]) -> np.ndarray:
    """``detect FOLDER --regions SPEC``: the CSV's columns (checked) then ``outside``."""
    res = CliRunner().invoke(cli, ["detect", str(folder), "--out", str(out), "--regions", spec])
    assert res.exit_code == 0, res.output
    with open(out / "quad_regions.csv") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0])[2:] == [*columns, "outside"], list(rows[0])
    return np.array([[int(r[c]) for c in [*columns, "outside"]] for r in rows])


def test_baits_told_apart_by_colour_and_by_quarter(four_baits, tmp_path):
    folder, truth = four_baits
    spec = "color:8-45,name=sugar+color:95-130,name=protein"
    got = _detect_columns(folder, tmp_path / "c", spec, ["sugar", "protein"])
    by_colour = truth[:, [0, 1, 4]] + truth[:, [3, 2, 4]] * [1, 1, 0]
    assert np.abs(got - by_colour).sum() <= 1, np.column_stack([got, by_colour])
    spec = "color:8-45,name=sugar,split=quad+color:95-130,name=protein,split=quad"
    names = [f"{c}_{q}" for c in ("sugar", "protein") for q in QUARTERS]
    got = _detect_columns(folder, tmp_path / "q", spec, names)
    # BAITS' order: sugar top left, protein top right, protein bottom left, sugar bottom right
    cols = ["sugar_top_left", "protein_top_right", "protein_bottom_left", "sugar_bottom_right"]
    picked = got[:, [names.index(c) for c in cols] + [-1]]
    assert np.abs(picked - truth).sum() <= 1, np.column_stack([picked, truth])
    # the quarters without a paper of that colour hold no ant
    assert got[:, :-1].sum() == picked[:, :-1].sum()
