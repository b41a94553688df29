"""Following the animals from frame to frame (the room ``tracking.track``).

Owns the tracker (:mod:`.tracker`: its options and the per-frame predict/update loop), the
adaptive Kalman filter (:mod:`.kalman`), the costs and the Hungarian assignment
(:mod:`.association`), the live tracks (:mod:`.bank`) and the tracker's output with its
clean-up (:mod:`.result`). May import the floor (``tracking.anatomy``,
``tracking.detection``) and the configuration helpers; never ``synth``, ``detect``,
``train`` or the pipeline.
"""

from thermoswarm.tracking.track.tracker import (
    Tracker,
    TrackerConfig,
    TrackResult,
    track_detections,
)

__all__ = ["TrackerConfig", "Tracker", "TrackResult", "track_detections"]
