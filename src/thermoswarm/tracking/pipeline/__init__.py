"""Video (or detections) in, trajectories out: what ``thermoswarm track`` runs.

:func:`track_video` streams a video through a detector and the tracker:

1. the detector's ``prepare`` (if any) sees the first ``prepare_s`` seconds (the
   classical detector learns the empty road there; decoded once more, a small cost
   on long videos);
2. each frame is decoded in a background thread, detected (with the tracker's
   predictions as hints where the detector takes them) and tracked;
3. frames whose tracks are final (after the tracker's fixed lag) are drawn into the
   overlay video, so nothing but a short ring of small frames is kept in memory.

:func:`track_detection_file` runs the tracker on another detector's boxes without
video (MOTChallenge, YOLO txt or COCO JSON; :mod:`~thermoswarm.tracking.detect.files`):
head and tail are then unknown (NaN), the body point is the box centre, the boxes
written are the detections' own, the tracker's unit of length is the objects' size
measured from the boxes, and the frames keep the input's numbering.

Without a scale ``px_per_mm`` the animals' body length is measured from the video
(:func:`~thermoswarm.tracking.detect.size.estimate_length_px`); the tracker works in body
lengths either way.  :func:`detect_inputs` runs the same detectors without the tracker
and writes COCO keypoints and MOTChallenge detections (``thermoswarm detect``).

Both tracking functions write into ``out_dir``: ``tracks.nc`` (trajectory format, s,
keypoints head/body/tail; mm with a scale, else px with ``space_unit = "px"``),
``tracks_mot.txt`` (MOTChallenge boxes in px), ``detections.txt`` (video only: MOT
detection rows, to re-track without the video), ``overlay.mp4`` (unless disabled) and
``summary.json``; every file is written atomically.

The room's modules: :mod:`.video` (:func:`track_video`), :mod:`.stages` (the frame
loop and the outputs it shares with :mod:`.series_track`, ``track`` on a photo
series), :mod:`.boxes` (:func:`track_detection_file`), :mod:`.detect_run`
(:func:`detect_inputs`; :mod:`.series` for photo series) and :mod:`.common` (the
detector's preparation and the summary they share). The pipeline may
import every room below it (``detect``, ``track``, the floor); only ``batch`` is above it.
"""

from thermoswarm.tracking.pipeline.boxes import detections_from_table, track_detection_file
from thermoswarm.tracking.pipeline.common import build_detector, pixel_dataset
from thermoswarm.tracking.pipeline.detect_run import detect_inputs
from thermoswarm.tracking.pipeline.video import track_video

__all__ = [
    "track_video",
    "track_detection_file",
    "detections_from_table",
    "detect_inputs",
    "build_detector",
    "pixel_dataset",
]
