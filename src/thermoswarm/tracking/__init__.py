"""Ant video tracking, as rooms: make a video, find the animals, follow them, learn a model.

The rooms, bottom to top (a room imports only from rooms below it; ``tests/test_layers.py``
keeps it so):

- the floor, shared by every room: :mod:`~thermoswarm.tracking.anatomy` (the ant's shape,
  keypoints, body-centred boxes), :mod:`~thermoswarm.tracking.detection` (one frame's
  detections, the type every detector returns and the tracker reads),
  :mod:`~thermoswarm.tracking.video` (frames in from videos and image folders, overlays
  out) and :mod:`~thermoswarm.tracking.evaluate` (CLEAR-MOT, IDF1, HOTA: pure functions of
  two MOT tables, so any room may score itself with it);
- :mod:`~thermoswarm.tracking.synth`: synthetic ant videos with ground truth;
- :mod:`~thermoswarm.tracking.detect`: detectors (classical, U-Net) and detection files;
- :mod:`~thermoswarm.tracking.track`: the tracker (Kalman, association, track bank, results);
- :mod:`~thermoswarm.tracking.train`: training and validating the U-Net (above the three
  rooms it trains on, scores with and tracks with);
- the top, which may use every room: :mod:`~thermoswarm.tracking.pipeline` (video or
  detection file in, ``tracks.nc`` out: what ``thermoswarm track`` and ``detect`` run),
  and above it :mod:`~thermoswarm.tracking.batch` (many videos through the pipeline,
  resumable).

``synth``, ``detect`` and ``track`` never import each other. Modules are imported on
demand; OpenCV and imageio-ffmpeg come with the ``track`` extra, PyTorch with ``track`` too.
See ``docs/tracking.md`` and, for the walk of a video through ``track``,
``docs/development.md``.
"""
