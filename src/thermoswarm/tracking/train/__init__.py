"""Training and validating the U-Net detector (the room ``tracking.train``).

Owns the labelled data (frames and SLEAP and COCO labels: :mod:`.data`; synthetic frames:
:mod:`.synthetic`), real-crop copy-paste (:mod:`.real`), augmentation (:mod:`.augment`),
the options (:mod:`.config`), validation (:mod:`.validate`) and training (:mod:`.fit`, its
steps and evaluations in :mod:`.loop`). Needs PyTorch. May import the floor, ``synth``
(synthetic training clips), ``detect`` (the U-Net it trains) and ``track`` (tracking a
validation clip); never the pipeline or ``batch``.
"""
