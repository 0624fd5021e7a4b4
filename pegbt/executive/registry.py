"""The behaviour registry: leaf behaviours by name, with typed parameters and declared blackboard keys.

A behaviour module registers each leaf once, with a decorator::

    @behaviour(
        "grasp",
        "Close the jaw on the block at `pose`.",
        params=(
            Param("arm", str, "which arm", choices=("PSM1", "PSM2")),
            Param("pose", list[float], "grasp pose", blackboard=True),
            Param("effort", float, "jaw effort, N", default=0.5),
        ),
        reads=("block_pose",),
        writes=("holding",),
        resources=("arms",),
    )
    class Grasp(Leaf): ...

The decorated object is called with one `LeafSetup` and returns a py_trees `Behaviour` (a `Leaf`
subclass, or a function returning any py_trees behaviour). pegbt's own leaves are declared instead in a
table (`pegbt.behaviours.leaves`), with `declare` and the implementation named `module:attribute`: the
validator checks trees against these declarations without constructing anything, or importing what the
leaves run with, and `pegbt tree schema` prints them. Modules that register or declare behaviours are
listed in `BEHAVIOUR_MODULES` and imported on first use.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeVar

from pegbt.executive.params import Param

if TYPE_CHECKING:
    import py_trees

    from pegbt.executive.context import RunContext

BEHAVIOUR_MODULES: tuple[str, ...] = ("pegbt.behaviours.leaves",)

Factory = Callable[["LeafSetup"], "py_trees.behaviour.Behaviour"]
F = TypeVar("F", bound=Callable[..., Any])


@dataclass(frozen=True)
class BehaviourSpec:
    """Everything the executive knows about a leaf behaviour before building it."""

    name: str
    doc: str
    implementation: Factory | str  # the factory, or `module:attribute` naming it (imported when first asked)
    params: tuple[Param, ...] = ()
    reads: tuple[str, ...] = ()
    writes: tuple[str, ...] = ()
    resources: tuple[str, ...] = ()

    @property
    def factory(self) -> Factory:
        """What builds the leaf, its module imported now if the declaration only named it."""
        if not isinstance(self.implementation, str):
            return self.implementation
        module, _, attribute = self.implementation.partition(":")
        factory: Factory = getattr(importlib.import_module(module), attribute)
        return factory


@dataclass(frozen=True)
class LeafSetup:
    """What a leaf's factory receives: its name, checked parameters, blackboard namespace and the run context.

    `params` holds every declared parameter (defaults filled in); a value written `$key` in the tree is a
    `BlackboardRef`, which `Leaf.param` reads from the blackboard when asked.
    """

    name: str
    params: Mapping[str, Any]
    namespace: str
    spec: BehaviourSpec
    context: RunContext

    def absolute_key(self, key: str) -> str:
        """`key` as an absolute blackboard name in this node's namespace (`/` keys stay as they are)."""
        import py_trees

        return py_trees.blackboard.Blackboard.absolute_name(self.namespace, key)


class BehaviourRegistry:
    """Leaf behaviours by name."""

    def __init__(self, modules: tuple[str, ...] = ()) -> None:
        self._specs: dict[str, BehaviourSpec] = {}
        self._modules = modules
        self._loaded = not modules

    def add(self, spec: BehaviourSpec) -> None:
        """Register `spec`; a programming error (ValueError) if its name or a parameter name is taken."""
        if spec.name in self._specs:
            raise ValueError(f"behaviour {spec.name!r} is registered twice")
        names = [param.name for param in spec.params]
        if len(set(names)) != len(names) or "name" in names:
            raise ValueError(f"behaviour {spec.name!r}: parameter names must be unique and not 'name'")
        self._specs[spec.name] = spec

    def _load(self) -> None:
        if not self._loaded:
            self._loaded = True
            for module in self._modules:
                importlib.import_module(module)

    def get(self, name: str) -> BehaviourSpec | None:
        self._load()
        return self._specs.get(name)

    def names(self) -> list[str]:
        self._load()
        return sorted(self._specs)

    def __iter__(self) -> Iterator[BehaviourSpec]:
        return iter(self._specs[name] for name in self.names())


REGISTRY = BehaviourRegistry(BEHAVIOUR_MODULES)


def behaviour(
    name: str,
    doc: str,
    *,
    params: tuple[Param, ...] = (),
    reads: tuple[str, ...] = (),
    writes: tuple[str, ...] = (),
    resources: tuple[str, ...] = (),
    registry: BehaviourRegistry = REGISTRY,
) -> Callable[[F], F]:
    """Class or function decorator registering a leaf behaviour (see the module docstring)."""

    def register(factory: F) -> F:
        registry.add(
            BehaviourSpec(name, doc, factory, tuple(params), tuple(reads), tuple(writes), tuple(resources))
        )
        return factory

    return register


def declare(
    name: str,
    doc: str,
    implementation: str,
    *,
    params: tuple[Param, ...] = (),
    reads: tuple[str, ...] = (),
    writes: tuple[str, ...] = (),
    resources: tuple[str, ...] = (),
    registry: BehaviourRegistry = REGISTRY,
) -> None:
    """Register leaf behaviour `name` built by `implementation` (`module:attribute`), without importing it."""
    registry.add(BehaviourSpec(name, doc, implementation, params, reads, writes, resources))
