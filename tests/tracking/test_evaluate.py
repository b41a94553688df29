"""CLEAR-MOT / IDF1: hand-computed cases and agreement with TrackEval (counts equal, floats
to 1e-12; the tie-breaking case is in test_evaluate_ties.py)."""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest
import trackeval

from thermoswarm.errors import InputError
from thermoswarm.io.mot import write_mot_table
from thermoswarm.tracking.evaluate import METRIC_KEYS, evaluate_files, evaluate_tables


def _row(frame, ident, x, y, w=10.0, h=10.0, conf=1.0, cls=1.0):
    return [frame, ident, x, y, w, h, conf, cls, 1.0, -1.0]


def test_hand_computed_case_counts():
    gt = np.array(
        [_row(f, 1, 0, 0) for f in range(1, 5)] + [_row(f, 2, 50, 0) for f in range(1, 5)]
    )
    pred = np.array(
        [_row(f, 7, 0, 0) for f in range(1, 5)]
        + [_row(1, 8, 55, 0), _row(2, 8, 50, 0), _row(4, 9, 50, 0), _row(2, 5, 200, 200)]
    )
    m = evaluate_tables(gt, pred)
    # Frame 1: obj2 vs box 8 IoU 1/3 -> FN + FP.  Frame 2: match + FP (box 5).
    # Frame 3: obj2 FN.  Frame 4: obj2 matched to 9, last matched to 8 -> IDSW.
    assert (m["tp"], m["fn"], m["fp"], m["idsw"]) == (6, 2, 2, 1)
    assert m["mota"] == pytest.approx(1 - (2 + 2 + 1) / 8)
    assert m["motp"] == pytest.approx(1.0)
    assert (m["mt"], m["pt"], m["ml"]) == (1, 1, 0)
    assert set(m) == set(METRIC_KEYS)
    assert m["n_gt"] == 8 and m["n_pred"] == 8
    assert m["idsw_rate"] == pytest.approx(1 / 8)
    # Identity: gt1<->7 share 4 frames, gt2<->8 and gt2<->9 one each: IDTP = 5.
    assert m["idf1"] == pytest.approx(2 * 5 / (8 + 8))


def test_perfect_and_empty_predictions():
    gt = np.array([_row(f, i, 20 * i, 0) for f in range(1, 4) for i in (1, 2)])
    m = evaluate_tables(gt, gt.copy())
    assert m["mota"] == 1.0 and m["idf1"] == 1.0 and m["motp"] == pytest.approx(1.0)
    m = evaluate_tables(gt, np.zeros((0, 10)))
    assert m["fn"] == 6 and m["mota"] == 0.0 and m["idf1"] == 0.0


def test_zero_marked_ground_truth_is_ignored():
    gt = np.array([_row(1, 1, 0, 0), _row(1, 2, 50, 0, conf=0.0)])
    pred = np.array([_row(1, 3, 0, 0)])
    m = evaluate_tables(gt, pred)
    assert (m["n_gt"], m["tp"], m["fp"], m["fn"]) == (1, 1, 0, 0)


def test_duplicate_ids_are_an_input_error():
    gt = np.array([_row(1, 1, 0, 0), _row(1, 1, 50, 0)])
    with pytest.raises(InputError, match="id 1 appears twice in frame 1"):
        evaluate_tables(gt, gt)


def _random_fixture(seed: int, n_obj: int = 6, n_frames: int = 60):
    """Ground truth of boxes moving about, and a tracker output with jitter, missed
    boxes (FN), spurious boxes (FP), identity swaps and fragmented tracks (IDSW)."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(0, 300, (n_obj, 2))
    vel = rng.normal(0, 3, (n_obj, 2))
    gt, pred = [], []
    ids = np.arange(1, n_obj + 1)
    pred_id = ids + 100
    next_id = 200
    for f in range(1, n_frames + 1):
        pos += vel + rng.normal(0, 1, (n_obj, 2))
        alive = (np.arange(n_obj) + f) % 17 != 0  # objects leave now and then
        if f % 13 == 0:  # two tracks swap identities
            i, j = rng.choice(n_obj, 2, replace=False)
            pred_id[[i, j]] = pred_id[[j, i]]
        if f % 19 == 0:  # a track restarts with a new id
            i = rng.integers(n_obj)
            pred_id[i] = next_id
            next_id += 1
        for k in range(n_obj):
            if not alive[k]:
                continue
            w, h = 20 + 2 * k, 12 + k
            gt.append(_row(f, ids[k], pos[k, 0], pos[k, 1], w, h, 1, 1))
            if rng.random() < 0.1:
                continue  # missed
            jit = rng.normal(0, 2.5, 4)
            pred.append(
                _row(
                    f,
                    pred_id[k],
                    pos[k, 0] + jit[0],
                    pos[k, 1] + jit[1],
                    w + jit[2],
                    h + jit[3],
                    1,
                    -1,
                )
            )
        for _ in range(rng.poisson(0.5)):  # spurious boxes
            pred.append(_row(f, rng.integers(300, 310), *rng.uniform(0, 300, 2), 15, 15, 1, -1))
    gt = np.array(gt)
    pred = np.array(pred)
    # Spurious ids must be unique per frame.
    _, first = np.unique(pred[:, :2], axis=0, return_index=True)
    return gt, pred[np.sort(first)]


def _trackeval(tmp_path, gt: np.ndarray, pred: np.ndarray, iou: float) -> dict:
    n_frames = int(max(gt[:, 0].max(), pred[:, 0].max()))
    seq = "seq01"
    gt_dir = tmp_path / "gt" / seq / "gt"
    gt_dir.mkdir(parents=True)
    write_mot_table(gt_dir / "gt.txt", gt)
    tr_dir = tmp_path / "trackers" / "ours" / "data"
    tr_dir.mkdir(parents=True)
    write_mot_table(tr_dir / f"{seq}.txt", pred)
    ds_cfg = {
        "GT_FOLDER": str(tmp_path / "gt"),
        "TRACKERS_FOLDER": str(tmp_path / "trackers"),
        "SKIP_SPLIT_FOL": True,
        "SEQ_INFO": {seq: n_frames},
        "TRACKERS_TO_EVAL": ["ours"],
        "PRINT_CONFIG": False,
        "OUTPUT_FOLDER": str(tmp_path / "out"),
    }
    ev_cfg = {
        "USE_PARALLEL": False,
        "PRINT_RESULTS": False,
        "PRINT_ONLY_COMBINED": False,
        "PRINT_CONFIG": False,
        "TIME_PROGRESS": False,
        "DISPLAY_LESS_PROGRESS": True,
        "OUTPUT_SUMMARY": False,
        "OUTPUT_DETAILED": False,
        "PLOT_CURVES": False,
    }
    metric_cfg = {"THRESHOLD": iou, "PRINT_CONFIG": False}
    with contextlib.redirect_stdout(io.StringIO()):
        evaluator = trackeval.Evaluator(ev_cfg)
        dataset = trackeval.datasets.MotChallenge2DBox(ds_cfg)
        metrics = [
            trackeval.metrics.CLEAR(metric_cfg),
            trackeval.metrics.Identity(metric_cfg),
            trackeval.metrics.HOTA({"PRINT_CONFIG": False}),
        ]
        res, _ = evaluator.evaluate([dataset], metrics)
    out = res["MotChallenge2DBox"]["ours"][seq]["pedestrian"]
    hota = {k: float(np.mean(out["HOTA"][k])) for k in ("HOTA", "DetA", "AssA", "LocA")}
    return {**out["CLEAR"], **out["Identity"], **hota}


@pytest.mark.parametrize(("seed", "iou"), [(1, 0.5), (2, 0.5), (3, 0.3)])
def test_agrees_with_trackeval(tmp_path, seed, iou):
    gt, pred = _random_fixture(seed)
    # Round as the MOT writer does, so both read the same numbers.
    write_mot_table(tmp_path / "g.txt", gt)
    write_mot_table(tmp_path / "p.txt", pred)
    ours = evaluate_files(tmp_path / "g.txt", tmp_path / "p.txt", iou=iou)
    te = _trackeval(tmp_path, gt, pred, iou)
    # The fixture has every kind of error.
    assert ours["fp"] > 5 and ours["fn"] > 5 and ours["idsw"] > 3
    for key, te_key in [
        ("mota", "MOTA"),
        ("motp", "MOTP"),
        ("idf1", "IDF1"),
        ("idp", "IDP"),
        ("idr", "IDR"),
    ]:
        assert ours[key] == pytest.approx(float(te[te_key]), abs=1e-12), key
    # HOTA and its parts (means over the 19 thresholds), the same sums in the same order.
    for key, te_key in [("hota", "HOTA"), ("deta", "DetA"), ("assa", "AssA"), ("loca", "LocA")]:
        assert ours[key] == pytest.approx(te[te_key], abs=1e-12), key
    assert 0.1 < ours["assa"] < 0.95 and 0.1 < ours["deta"] < 0.95  # neither trivial
    for key, te_key in [
        ("idsw", "IDSW"),
        ("fp", "CLR_FP"),
        ("fn", "CLR_FN"),
        ("tp", "CLR_TP"),
        ("mt", "MT"),
        ("pt", "PT"),
        ("ml", "ML"),
        ("frag", "Frag"),
    ]:
        assert ours[key] == int(te[te_key]), key


def test_evaluate_files_errors(tmp_path):
    empty = tmp_path / "empty.txt"
    empty.write_text("")
    gt = tmp_path / "gt.txt"
    write_mot_table(gt, np.array([_row(1, 1, 0, 0)]))
    with pytest.raises(InputError, match="empty.txt: empty MOTChallenge file"):
        evaluate_files(empty, gt)
    m = evaluate_files(gt, empty)  # an empty prediction is legal: all missed
    assert m["fn"] == 1
    dets = tmp_path / "dets.txt"
    write_mot_table(dets, np.array([_row(1, -1, 0, 0)]))
    with pytest.raises(InputError, match="id -1 are detections"):
        evaluate_files(gt, dets)
    with pytest.raises(InputError, match="iou must be in"):
        evaluate_files(gt, gt, iou=0.0)


def test_hand_computed_hota():
    """One object over 4 frames, tracked as id 7 in frames 1-2 and id 8 in frames 3-4,
    all boxes exact (IoU 1): DetA 1 at every threshold; each matched pair's Jaccard
    index is 2 / (4 + 2 - 2) = 1/2, so AssA 1/2 and HOTA sqrt(1/2); LocA 1."""
    gt = np.array([_row(f, 1, 0, 0) for f in range(1, 5)])
    pred = np.array([_row(f, 7 if f <= 2 else 8, 0, 0) for f in range(1, 5)])
    m = evaluate_tables(gt, pred)
    assert m["deta"] == pytest.approx(1.0) and m["loca"] == pytest.approx(1.0)
    assert m["assa"] == pytest.approx(0.5) and m["hota"] == pytest.approx(np.sqrt(0.5))
    # A box of IoU 0.5 with its object counts only at thresholds <= 0.5 (10 of 19).
    pred = np.array([_row(f, 7, 0, 0, w=20.0) for f in range(1, 5)])
    m = evaluate_tables(gt, pred)
    assert m["deta"] == pytest.approx(10 / 19) and m["assa"] == pytest.approx(10 / 19)
    # LocA is 0.5 where boxes match and, by TrackEval's convention, 1 where none does.
    assert m["loca"] == pytest.approx((10 * 0.5 + 9 * 1.0) / 19)


def test_six_column_tables_and_frame_zero():
    """A 6-column table (frame, id, box) is a table (conf 1); rows of frame 0 count,
    with every frame counted from 0, never silently dropped."""
    gt6 = np.array([[f, 1, 0.0, 0.0, 10.0, 10.0] for f in range(0, 4)])
    pred6 = np.array([[f, 5, 0.0, 0.0, 10.0, 10.0] for f in range(0, 4) if f != 2])
    m = evaluate_tables(gt6, pred6)
    assert (m["n_gt"], m["tp"], m["fn"], m["fp"], m["n_frames"]) == (4, 3, 1, 0, 4)
    assert m["mota"] == pytest.approx(0.75)
    with pytest.raises(InputError, match="frame -1.0 is not an integer >= 0"):
        evaluate_tables(np.array([[-1, 1, 0, 0, 10, 10]]), pred6)
    with pytest.raises(InputError, match="6 to 10 columns"):
        evaluate_tables(np.array([[1, 1, 0, 0, 10]]), pred6)


def test_huge_frame_numbers_are_refused_not_allocated(tmp_path):
    gt = tmp_path / "gt.txt"
    gt.write_text("1,1,0,0,10,10,1\n100000000000,1,0,0,10,10,1\n")
    with pytest.raises(InputError, match="more than the 10,000,000 accepted"):
        evaluate_files(gt, gt)
    with pytest.raises(InputError, match="span more than"):
        evaluate_tables(
            np.array([[1, 1, 0, 0, 10, 10], [1e11, 1, 0, 0, 10, 10]]), np.zeros((0, 6))
        )


def test_files_that_count_frames_from_different_origins_are_named(tmp_path):
    """Ground truth counting frames from 0 and tracks from 1 (AntTracking's files): two
    walkers moving 8 px a frame (boxes 10 px) match one frame later only.  `evaluate`
    warns on stderr, names --frame-offset 1, and with it scores every box; a still scene
    matches at every offset alike and gets no warning."""
    from click.testing import CliRunner

    from thermoswarm.cli import cli
    from thermoswarm.tracking.evaluate import frame_offsets, offset_warning

    gt = np.array([_row(f, i, 8.0 * f, 40.0 * i) for f in range(0, 30) for i in (1, 2)])
    pred = gt.copy()
    pred[:, 0] += 1  # the same boxes, numbered from 1
    shares = frame_offsets(gt, pred)
    assert shares[1] == 1.0 and shares[0] == 0.0 and shares[2] == 0.0
    assert "--frame-offset 1 scores PRED's frame k + 1" in offset_warning(shares)
    assert evaluate_tables(gt, pred)["mota"] < 0
    still = gt.copy()
    still[:, 2] = 0.0
    moved = still.copy()
    moved[:, 0] += 1
    assert offset_warning(frame_offsets(still, moved)) is None
    g, p = tmp_path / "gt.txt", tmp_path / "pred.txt"
    write_mot_table(g, gt)
    write_mot_table(p, pred)
    r = CliRunner().invoke(cli, ["evaluate", str(g), str(p)])
    assert r.exit_code == 0 and "warning: PRED matches GT best 1 frame(s) later" in r.stderr
    assert '"mota"' in r.stdout and "warning" not in r.stdout
    r = CliRunner().invoke(cli, ["evaluate", str(g), str(p), "--frame-offset", "1"])
    assert r.exit_code == 0 and "warning" not in r.stderr
    assert '"mota": 1.0' in r.stdout
