"""Synthetic ant videos with ground truth (the room ``tracking.synth``).

Owns the ants' motion on the paper's road (:mod:`.motion`), their rendering as
head/mesosoma/gaster shapes (:mod:`.render`) and the clip with its ground truth, written as
a video, an image sequence and MOT rows (:mod:`.clip`). May import the floor
(``tracking.anatomy``), ``thermoswarm.maxent``, ``thermoswarm.tracks`` and the
configuration helpers; never ``detect``, ``track``, ``train`` or the pipeline.
``python -m thermoswarm.tracking.synth OUT`` writes a clip.
"""

from thermoswarm.tracking.synth.clip import (
    Road,
    SynthConfig,
    SynthVideo,
    generate,
    write_sequence,
    write_video,
)

__all__ = ["SynthConfig", "Road", "SynthVideo", "generate", "write_video", "write_sequence"]
