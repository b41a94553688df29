"""``python -m thermoswarm.tracking.synth OUT``: write a synthetic clip with ground truth."""

from thermoswarm.tracking.synth.clip import _main

_main()
