"""The executive: YAML behaviour trees loaded, checked and built into py_trees, run, logged and analysed.

Flow: `source` (YAML with locations) -> `document` (files, includes, subtree definitions) -> `resolve`
(checked `NodeSpec`s; `keys` checks the blackboard) -> `build` (py_trees, using `nodetypes` and the
behaviour `registry`) -> `runner` (ticks on a `clock`, writes a `ticklog`) -> `logfile` / `analysis`
(`summary`, `why`, `replay`) and `btlog` (Groot2 export). `loader` is the front door.

Behaviours use `registry.behaviour`, `params.Param`, `leaf.Leaf` and `context.RunContext`.
"""
