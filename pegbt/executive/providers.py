"""Where `pegbt run` gets its clock and the resources a tree's behaviours declare.

Later packages register here instead of editing the run command: a clock by name (`--clock NAME`),
and a resource provider per resource name (e.g. `"arms": "pegbt.transport.arms:connect"`). A provider
is called once per run with the run's clock and returns the resource; if the resource has a `close()`
method, the run calls it at the end. Providers are imported only when a tree needs them.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any

from pegbt.errors import PegbtError
from pegbt.clock import Clock

CLOCKS: dict[str, str] = {
    "wall": "pegbt.clock:WallClock",
    "manual": "pegbt.clock:ManualClock",
}
RESOURCE_PROVIDERS: dict[str, str] = {}


def _load(target: str) -> Any:
    module_name, attribute = target.split(":")
    return getattr(importlib.import_module(module_name), attribute)


def make_clock(name: str) -> Clock:
    """The clock registered as `name` (a `PegbtError` naming the choices if there is none)."""
    if name not in CLOCKS:
        raise PegbtError(f"unknown clock {name!r}; known: {', '.join(CLOCKS)}", field="--clock")
    return _load(CLOCKS[name])()


def provide_resources(users: Mapping[str, str], clock: Clock) -> dict[str, Any]:
    """One instance of each resource in `users` (name -> who needs it); a `PegbtError` for any without a provider."""
    missing = [f"{name!r} (needed by {user})" for name, user in sorted(users.items()) if name not in RESOURCE_PROVIDERS]
    if missing:
        raise PegbtError(f"no provider for resource {'; '.join(missing)}; providers are registered in "
                         "pegbt/executive/providers.py", field="resources")
    return {name: _load(RESOURCE_PROVIDERS[name])(clock) for name in sorted(users)}


def close_resources(resources: dict[str, Any]) -> None:
    """Call `close()` on each resource that has one."""
    for resource in resources.values():
        close = getattr(resource, "close", None)
        if callable(close):
            close()
