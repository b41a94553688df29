"""The body length measured without a scale (``estimate_length_px``) against the truth,
on rendered ants and on dark ants drawn on white (issue 32, item 3).

- rendered: the synthetic clip's ants (legs, antennae, blur 0.6 px; 12 ants, 40 frames,
  seed 1) at 4, 5, 8, 20 and 40 px (``test_body_length_within_10_percent_down_to_4_px``);
- drawn, exact: the paper's ant drawn dark on white by its exact pixel coverage, a
  lens blur of 0.5 px, a third split at the waist, 12 frames of 30 at 4, 6, 8 px
  (``test_drawn_ants_measured_within_10_percent``);
- stand-in: ``tests/tracking/test_split_join.py``'s scene of ants 6-7 px long (OpenCV's
  anti-aliased ellipses), a third split, 12 frames of 30, seeds 32 (the tests' and
  ``bench_split_join.py``'s) and 1-3.

    python benchmarks/bench_body_length.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "tracking"))

from test_footage_guards import _exact_frame  # noqa: E402
from test_split_join import frame, scene  # noqa: E402
from tracking_fixtures import small_video  # noqa: E402

from thermoswarm.tracking.detect.size import estimate_length_px  # noqa: E402


def main() -> int:
    """Print one row per case: truth, measured length (px), error, blobs."""
    print("case | true px | measured px | error | blobs (single)")

    def row(case: str, truth: float, est) -> None:
        err = est.length_px / truth - 1
        n = f"{est.n_blobs} ({est.n_single})"
        print(f"{case} | {truth:g} | {est.length_px:.2f} | {err:+.1%} | {n}")

    for L in (4.0, 5.0, 8.0, 20.0, 40.0):
        big = {} if L < 20 else {"width": 640, "height": 320}
        v = small_video(seed=1, n_frames=40, n_ants=12, px_per_mm=L / 7.14, **big)
        row("rendered", L, estimate_length_px(v.frames()))
    for L in (4.0, 6.0, 8.0):
        rng = np.random.default_rng(4)
        frames = [_exact_frame(rng, scene(rng, 30, (L, L), 1 / 3)) for _ in range(12)]
        row("drawn, exact", L, estimate_length_px(frames))
    for seed in (32, 1, 2, 3):
        rng = np.random.default_rng(seed)
        frames = [frame(rng, scene(rng, 30, (6.0, 7.0), 1 / 3)) for _ in range(12)]
        row(f"stand-in, seed {seed}", 6.5, estimate_length_px(frames, {"join_split": True}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
