"""Training and validating the U-Net detector (the room ``tracking.train``).

Owns the labelled data (synthetic frames, SLEAP and COCO labels: :mod:`.data`), real-crop
copy-paste (:mod:`.real`), augmentation (:mod:`.augment`), the options (:mod:`.config`),
validation (:mod:`.validate`) and the training loop (:mod:`.fit`). Needs PyTorch. May
import the floor, ``synth`` (synthetic training clips), ``detect`` (the U-Net it trains)
and ``track`` (tracking a validation clip); never the pipeline or ``batch``.
"""
