"""What a running tree gives its behaviours: the clock and named resources (transport handles, skills).

Behaviours never reach for globals: the runner builds one `RunContext` and every leaf receives it. A
leaf fetches its resources in `setup()` (not in its constructor), so that `pegbt tree show` and
`pegbt tree check` can build and inspect a tree without a robot attached.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, TypeVar

from pegbt.clock import Clock, WallClock
from pegbt.errors import PegbtError
from pegbt.executive.work import WorkPool

T = TypeVar("T")


@dataclass
class RunContext:
    """The clock, the named resources and the worker threads of one run.

    `resources` maps a name (e.g. `"arms"`, `"camera"`, `"skills"`) to whatever object the
    behaviours that declared that name expect; the runner's caller fills it. `work` runs leaves'
    heavy computations off the tick (`Leaf.offload`). `period`: s between the runner's ticks (`run` sets
    it), for a leaf that must act a tick ahead of a time it waits for.
    """

    clock: Clock = field(default_factory=WallClock)
    resources: Mapping[str, Any] = field(default_factory=dict)
    work: WorkPool = field(default_factory=WorkPool)
    period: float = 0.02

    def resource(self, name: str, kind: type[T] | None = None) -> T:
        """The resource called `name`; a `PegbtError` if this run lacks it or it is not a `kind`."""
        if name not in self.resources:
            available = ", ".join(sorted(self.resources)) or "none"
            raise PegbtError(f"this run provides no resource {name!r} (available: {available})", field=name)
        value = self.resources[name]
        if kind is not None and not isinstance(value, kind):
            raise PegbtError(
                f"resource {name!r} is a {type(value).__name__}, expected {kind.__name__}", field=name
            )
        return value
