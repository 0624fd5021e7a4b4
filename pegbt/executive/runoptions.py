"""`RunOptions`: everything one run of a tree file is run with, in one frozen object.

`pegbt run`, `pegbt eval` and code that runs trees build one; `run_tree_file` runs it, and the tick log's
header records it (`record()`), so a tick log says what was run: the tree, its variant and condition, the
providers' options (interface, endpoint, seed, fault plan...), the clock and period, and what the caller
knows of the world it ran on (`world`: the simulator's physics and speed; empty for a robot). A folder of
tick logs then sorts itself into cells (variant × condition) from the headers alone.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pegbt.executive.compact import compact
from pegbt.executive.providers import run_options
from pegbt.numbers import checked_number
from pegbt.runconditions import protocol_policies


@dataclass(frozen=True)
class RunOptions:
    """One run's options. `options` are the providers' (`RUN_OPTIONS` names; defaults filled in and checked
    on construction); `clock` None takes the clock a resource supplies, else the wall clock; `blackboard`
    replaces initial values the tree file declares, over the policies of the `protocol` option
    (`protocol_policies`); `record` names an MCAP file for what the resources'
    links carry; `variant` defaults to the tree file's name; `world` is recorded, never acted on."""

    tree: Path
    log: Path
    options: Mapping[str, Any] = field(default_factory=dict)
    clock: str | None = None
    period: float = 0.02
    timeout: float | None = None
    blackboard: Mapping[str, Any] = field(default_factory=dict)
    record: Path | None = None
    record_cloud_step: int = 10
    allow_include_outside: bool = False
    variant: str = ""
    world: Mapping[str, Any] = field(default_factory=dict)
    # the keys of `blackboard` the caller set, not the protocol (`asked_by`)
    callers_keys: frozenset[str] = field(init=False, repr=False, compare=False, default=frozenset())

    def __post_init__(self) -> None:
        checked_number(self.period, "--period", above=0.0)
        if self.timeout is not None:
            checked_number(self.timeout, "--timeout", above=0.0)
        object.__setattr__(self, "tree", Path(self.tree))
        object.__setattr__(self, "log", Path(self.log))
        object.__setattr__(self, "record", None if self.record is None else Path(self.record))
        object.__setattr__(self, "options", run_options(self.options))
        object.__setattr__(self, "callers_keys", frozenset(map(_absolute, self.blackboard)))
        object.__setattr__(self, "variant", self.variant or self.tree.stem)
        object.__setattr__(self, "blackboard", self.protocol_policies | dict(self.blackboard))
        object.__setattr__(self, "world", dict(self.world))

    @property
    def protocol(self) -> str:
        """The protocol the run follows (pegbt, paper)."""
        return str(self.options["protocol"])

    @property
    def protocol_policies(self) -> dict[str, bool]:
        """The blackboard policies the protocol sets for the run's variant under its condition
        (`runconditions`)."""
        return protocol_policies(self.protocol, self.condition, self.variant)

    def asked_by(self, key: str) -> str:
        """What asked for blackboard `key`, for the error when the tree declares no such key: the protocol
        option (`--protocol paper`) for a policy it sets, unless the caller set the key itself (then "",
        and the key is refused in the tree's words: the protocol is not to blame)."""
        if _absolute(key) in self.callers_keys or key not in self.protocol_policies:
            return ""
        return f"--protocol {self.protocol}"

    @property
    def condition(self) -> str | None:
        """The skills' condition (uncalibrated, calibrated, optimized)."""
        return self.options.get("condition")

    def record_fields(self, *, met_world: bool = True) -> dict[str, Any]:
        """What the tick log's header records: `variant`, `condition` and `run` (every option, JSON-safe);
        `world` empty unless `met_world` (a tree that uses no resource meets no robot or simulator)."""
        return {
            "variant": self.variant,
            "condition": self.condition,
            "run": {
                "tree": str(self.tree),
                "variant": self.variant,
                "options": {name: compact(value) for name, value in self.options.items()},
                "clock": self.clock,
                "period": self.period,
                "timeout": self.timeout,
                "blackboard": {key: compact(value) for key, value in self.blackboard.items()},
                "record": None if self.record is None else str(self.record),
                "record_cloud_step": self.record_cloud_step,
                "allow_include_outside": self.allow_include_outside,
                "world": {key: compact(value) for key, value in self.world.items()} if met_world else {},
            },
        }


def _absolute(key: str) -> str:
    return key if key.startswith("/") else "/" + key
