"""thermoswarm: ants, particles and robot swarms under one maximum-entropy law.

``p(x) = exp(-x / kT) / kT`` -- simulate swarms that follow it, analyse trajectories
for it, track ants in video, and run the same controller on a robot.
"""

__version__ = "0.1.0"

__all__ = ["__version__"]
