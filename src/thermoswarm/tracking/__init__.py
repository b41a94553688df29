"""Ant video tracking: synthetic videos, detection, tracking, evaluation.

Modules (imported on demand; OpenCV and imageio-ffmpeg come with the ``track`` extra):

- :mod:`~thermoswarm.tracking.synth`: synthetic ant videos with ground truth;
- :mod:`~thermoswarm.tracking.detect`: the detector interface, registry and the
  classical (training-free) detector;
- :mod:`~thermoswarm.tracking.kalman` and :mod:`~thermoswarm.tracking.tracker`:
  adaptive Kalman prediction and Hungarian assignment (the tracker's live tracks in
  :mod:`~thermoswarm.tracking.track_bank`, its costs and assignment in
  :mod:`~thermoswarm.tracking.association`, its output in
  :mod:`~thermoswarm.tracking.track_result`);
- :mod:`~thermoswarm.tracking.evaluate`: CLEAR-MOT (MOTA, MOTP) and IDF1;
- :mod:`~thermoswarm.tracking.video` and :mod:`~thermoswarm.tracking.pipeline`: video
  in, ``tracks.nc`` out (what ``thermoswarm track`` runs);
- :mod:`~thermoswarm.tracking.anatomy`: the ant's shape, keypoints and body-centred box.

See ``docs/tracking.md``.
"""
