"""Finding the animals in frames (the room ``tracking.detect``).

Owns the detector registry (:mod:`.registry`) and the classical detector (background
subtraction and blob moments, no training: :mod:`.classical`, its options in
:mod:`.config`, its blob measurement in :mod:`.blobs`), the animals' size measured
without a scale (:mod:`.size`), camera registration for moving
cameras (:mod:`.register`), the trained U-Net + pose detector (:mod:`.unet`, its networks
in :mod:`.unet_model`; needs PyTorch) and the detection files other tools write (MOT,
COCO, YOLO: :mod:`.files`). May import the floor (``tracking.anatomy``,
``tracking.detection``, ``tracking.video``) and the configuration helpers; never
``synth``, ``track``, ``train`` or the pipeline.
"""

from thermoswarm.tracking.detect.classical import (
    NOTHING_FOUND_HINT,
    ClassicalConfig,
    ClassicalDetector,
    Detector,
    DetectorEntry,
    detectors,
    make_detector,
    register_detector,
    typical_area,
)
from thermoswarm.tracking.detect.size import SizeEstimate, estimate_length_px

__all__ = [
    "Detector", "DetectorEntry", "register_detector", "detectors", "make_detector",
    "ClassicalConfig", "ClassicalDetector", "SizeEstimate", "estimate_length_px",
    "typical_area", "NOTHING_FOUND_HINT",
]  # fmt: skip
