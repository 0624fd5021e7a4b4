"""The builders of the control node types (`pegbt.executive.nodetypes`): each makes the py_trees node.

py_trees' own composites and decorators are used wherever py_trees has them; `guard`, `recover`,
`timeout` and `for_each` use the small subclasses in this package. `subtree` has no builder: the
validator expands it. Kept apart from the declarations, so that checking a tree imports no py_trees.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import py_trees
from py_trees.behaviour import Behaviour

from pegbt.executive.context import RunContext
from pegbt.executive.guard import BlackboardGuard
from pegbt.executive.loop import ForEach
from pegbt.executive.recover import Recover
from pegbt.executive.spec import NodeSpec
from pegbt.executive.timeout import ClockTimeout

Builder = Callable[[NodeSpec, list[Behaviour], RunContext], Behaviour]


def _parallel(spec: NodeSpec, children: list[Behaviour], context: RunContext) -> Behaviour:
    policy_name, synchronise = spec.params["policy"], spec.params["synchronise"]
    if policy_name == "all":
        policy: py_trees.common.ParallelPolicy.Base = py_trees.common.ParallelPolicy.SuccessOnAll(
            synchronise=synchronise
        )
    elif policy_name == "one":
        policy = py_trees.common.ParallelPolicy.SuccessOnOne()
    else:
        chosen = [child for child in children if child.name in spec.params["selected"]]
        policy = py_trees.common.ParallelPolicy.SuccessOnSelected(children=chosen, synchronise=synchronise)
    return py_trees.composites.Parallel(spec.name, policy=policy, children=children)


def _oneshot(spec: NodeSpec, children: list[Behaviour], context: RunContext) -> Behaviour:
    policy = {
        "on_success": py_trees.common.OneShotPolicy.ON_SUCCESSFUL_COMPLETION,
        "on_completion": py_trees.common.OneShotPolicy.ON_COMPLETION,
    }[spec.params["policy"]]
    return py_trees.decorators.OneShot(spec.name, children[0], policy=policy)


def _guard(spec: NodeSpec, children: list[Behaviour], context: RunContext) -> Behaviour:
    key = py_trees.blackboard.Blackboard.absolute_name(spec.namespace, spec.params["key"])
    return BlackboardGuard(spec.name, children[0], key, spec.params["op"], spec.params["value"])


def _decorator(cls: type, **fixed: Any) -> Builder:
    """A builder for a py_trees decorator whose only arguments are name and child."""
    return lambda spec, children, context: cls(name=spec.name, child=children[0], **fixed)


BUILDERS: dict[str, Builder] = {
    "sequence": lambda spec, children, context: py_trees.composites.Sequence(
        spec.name, memory=spec.params["memory"], children=children
    ),
    "selector": lambda spec, children, context: py_trees.composites.Selector(
        spec.name, memory=spec.params["memory"], children=children
    ),
    "parallel": _parallel,
    "retry": lambda spec, children, context: py_trees.decorators.Retry(
        spec.name, children[0], num_failures=spec.params["attempts"]
    ),
    "timeout": lambda spec, children, context: ClockTimeout(
        spec.name, children[0], spec.params["seconds"], context.clock
    ),
    "inverter": _decorator(py_trees.decorators.Inverter),
    "repeat": lambda spec, children, context: py_trees.decorators.Repeat(
        spec.name, children[0], num_success=spec.params["times"]
    ),
    "force_success": _decorator(py_trees.decorators.FailureIsSuccess),
    "force_failure": _decorator(py_trees.decorators.SuccessIsFailure),
    "oneshot": _oneshot,
    "guard": _guard,
    "recover": lambda spec, children, context: Recover(
        spec.name, children[0], children[1], spec.params["retries"]
    ),
    "for_each": lambda spec, children, context: ForEach(
        spec.name, children, keep_going=spec.params["on_failure"] == "continue"
    ),
}
