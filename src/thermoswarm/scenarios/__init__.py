"""The paper's experiments as ready scenarios, registered by name.

``thermoswarm simulate NAME`` runs one; ``thermoswarm scenarios`` lists them.  Each
scenario is one module of this package; the registry imports a module only when its
scenario is asked for.
"""

from __future__ import annotations

import importlib

from thermoswarm.errors import ConfigError
from thermoswarm.scenarios.base import Scenario
from thermoswarm.scenarios.registry import REGISTRY as _REGISTRY
from thermoswarm.scenarios.registry import register

# name -> module that defines and registers it
_MODULES: dict[str, str] = {
    "box": "thermoswarm.scenarios.box",
    "narrow-road": "thermoswarm.scenarios.narrow_road",
    "compression": "thermoswarm.scenarios.compression",
    "transport-connected": "thermoswarm.scenarios.transport_connected",
    "transport-free": "thermoswarm.scenarios.transport_free",
}


def names() -> list[str]:
    """Names of all scenarios."""
    return sorted(set(_MODULES) | set(_REGISTRY))


def get(name: str) -> type[Scenario]:
    """The scenario class called ``name``; a ConfigError lists the known names."""
    if name not in _REGISTRY and name in _MODULES:
        importlib.import_module(_MODULES[name])
    if name not in _REGISTRY:
        import difflib

        close = difflib.get_close_matches(str(name), names(), n=1, cutoff=0.6)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise ConfigError(
            f"unknown scenario {name!r}{hint}; expected one of: {', '.join(names())}"
        )
    return _REGISTRY[name]


__all__ = ["Scenario", "register", "names", "get"]
