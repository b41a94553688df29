"""The scenario registry: the classes registered by name with :func:`register`.

Scenario modules import this module to register themselves; the package
(:mod:`thermoswarm.scenarios`) maps names to modules and imports a module when its
scenario is asked for.  Kept apart from the package so that the two do not import each
other.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from thermoswarm.scenarios.base import Scenario

__all__ = ["register", "REGISTRY"]

#: name -> scenario class, filled as scenario modules are imported
REGISTRY: dict[str, type[Scenario]] = {}


def register(cls: type[Scenario]) -> type[Scenario]:
    """Class decorator: make a scenario available by its ``name``."""
    REGISTRY[cls.name] = cls
    return cls
