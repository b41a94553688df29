"""Rebuild this fixture from SLEAP's test data (talmolab/sleap at commit 7785f660).

Usage, from the repository root::

    git --git-dir SLEAP_GIT show 7785f660:tests/data/tracks/clip.mp4 > clip_full.mp4
    git --git-dir SLEAP_GIT show 7785f660:tests/data/tracks/clip.slp > clip_full.slp
    python benchmarks/bench_real_footage.py clip_full.slp --px-per-mm 14.94 \\
        --nodes head,thorax,abdomen --gt-mot clip_full_gt.txt
    python tests/data/sleap_fly_clip/make_fixture.py clip_full.mp4 clip_full_gt.txt

What it makes: every 3rd frame of the 1,500 (30 frames/s, so 10 frames/s), shrunk 4x
(1024 x 1024 to 256 x 256, OpenCV's area average) and encoded with x264 (the project's
``write_video``, quality 3); and the labelled boxes of those frames (head, thorax and
abdomen of SLEAP's user instances, the box ``bench_real_footage.py`` makes from them),
their frames renumbered 1..500 and their coordinates divided by 4.
"""

import gzip
import sys
from pathlib import Path

import cv2
import numpy as np

from thermoswarm.tracking.synth.clip import write_video
from thermoswarm.tracking.video import open_video

STEP, SHRINK, SIDE = 3, 4, 256


def main(video: str, gt: str) -> None:
    here = Path(__file__).resolve().parent
    src = open_video(video)
    frames = (
        cv2.resize(f, (SIDE, SIDE), interpolation=cv2.INTER_AREA)
        for f in src.frames(src.n_frames, step=STEP)
    )
    write_video(frames, here / "clip.mp4", 30.0 / STEP, quality=3)
    rows = np.loadtxt(gt, delimiter=",", ndmin=2)
    rows = rows[(rows[:, 0] - 1) % STEP == 0]
    rows[:, 0] = (rows[:, 0] - 1) // STEP + 1
    rows[:, 2:6] /= SHRINK
    with gzip.open(here / "gt.txt.gz", "wt") as f:
        for r in rows:
            f.write("{:.0f},{:.0f},{:.3f},{:.3f},{:.3f},{:.3f},1,1,1\n".format(*r[:6]))


if __name__ == "__main__":
    main(*sys.argv[1:3])
