"""Export a tick log to Groot2's `.btlog`: the file BehaviorTree.CPP 4.3+'s `FileLogger2` writes.

Layout, from `src/loggers/bt_file_logger_v2.cpp` (the header's comment still shows the 4.2 draft):
the 18 bytes `BTCPP4-FileLogger2`, a protocol byte (1), the XML length (int32, little-endian), the XML
(`WriteTreeToXML(tree, add_metadata=true, ...)` in `src/xml_parsing.cpp`: one `BehaviorTree` element per
tree and subtree instance with `_fullpath`, every node with `_uid`, a `TreeNodesModel`), the first
timestamp (int64 µs since the Unix epoch), then 9 bytes per status change: 6-byte µs since the first
timestamp, uint16 uid, uint8 status (0 idle, 1 running, 2 success, 3 failure).

`_uid`s are BT.CPP's: preorder from 1, a subtree's nodes right after its `SubTree` node (`Tree::getUID`
in `src/bt_factory.cpp`, `recursivelyCreateSubtree` in `src/xml_parsing.cpp`), which is the tick log's id
order plus one. Control nodes become BT.CPP's built-ins where one behaves the same; the others and every
leaf are declared in the `TreeNodesModel`. A `SubTree` also carries its instance's `name`, which BT.CPP's
parser reads. The status changes are put in the order BT.CPP's logger sees them (`BtcppStatuses`).
"""

from __future__ import annotations

import datetime
import json
import re
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

from pegbt.errors import PegbtError
from pegbt.executive.logfile import TickLog
from pegbt.executive.nodetypes import NODE_TYPES

MAGIC = b"BTCPP4-FileLogger2"
PROTOCOL = 1
IDLE, RUNNING, SUCCESS, FAILURE = 0, 1, 2, 3
_STATUS = {"INVALID": IDLE, "RUNNING": RUNNING, "SUCCESS": SUCCESS, "FAILURE": FAILURE}
_KIND = {
    "composite": "Control",
    "recover": "Control",
    "loop": "Control",
    "decorator": "Decorator",
    "subtree": "SubTree",
}
_SIMPLE = {"inverter": "Inverter", "force_success": "ForceSuccess", "force_failure": "ForceFailure"}
_REACTIVE = {"ReactiveSequence", "ReactiveFallback"}  # a running child halts its siblings
_XML_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.-]{0,199}")  # XML names, as far as BT.CPP's are ASCII
_NOT_XML_CHAR = re.compile("[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")  # XML 1.0's Char


@dataclass(frozen=True)
class BtcppNode:
    """How one tick-log node appears to BT.CPP: element name, Action/Control/Decorator/SubTree, ports."""

    tag: str
    kind: str
    ports: dict[str, str] = field(default_factory=dict)
    builtin: bool = False


def _port_value(value: Any) -> str:
    if isinstance(value, str):
        return "{" + value[1:] + "}" if value.startswith("$") and not value.startswith("$$") else value
    return json.dumps(value)


def btcpp_node(node: dict[str, Any]) -> BtcppNode:
    """BT.CPP's built-in for a pegbt control node when it behaves the same, else a user node of its type.

    py_trees' sequence with memory resumes at the running child and restarts after a failure, which is
    BT.CPP's `Sequence` (its `SequenceWithMemory` resumes even after a failure); without memory it is
    `ReactiveSequence`. A selector with memory is `Fallback`, without `ReactiveFallback`. A parallel is
    `Parallel` unless its policy is `selected` or it ticks succeeded children again (`synchronise: false`
    with `all`); a oneshot is `RunOnce` when it latches any result (`on_completion`).
    """
    kind, params = node["type"], node.get("params", {})
    shape = NODE_TYPES[kind].shape if kind in NODE_TYPES else "leaf"
    policy = params.get("policy")
    if kind == "sequence":
        tag = "Sequence" if params.get("memory", True) else "ReactiveSequence"
        return BtcppNode(tag, "Control", builtin=True)
    if kind == "selector":
        return BtcppNode("Fallback" if params.get("memory") else "ReactiveFallback", "Control", builtin=True)
    if kind == "parallel" and (policy == "one" or policy == "all" and params.get("synchronise", True)):
        ports = {"failure_count": "1", "success_count": "1" if policy == "one" else "-1"}
        return BtcppNode("Parallel", "Control", ports, builtin=True)
    if kind == "retry":
        return BtcppNode("RetryUntilSuccessful", "Decorator", {"num_attempts": str(params["attempts"])}, True)
    if kind == "repeat":
        return BtcppNode("Repeat", "Decorator", {"num_cycles": str(params["times"])}, True)
    if kind == "timeout":
        return BtcppNode("Timeout", "Decorator", {"msec": str(round(params["seconds"] * 1000))}, True)
    if kind == "oneshot" and policy == "on_completion":
        return BtcppNode("RunOnce", "Decorator", {"then_skip": "false"}, True)
    if kind in _SIMPLE:
        return BtcppNode(_SIMPLE[kind], "Decorator", builtin=True)
    if shape == "subtree":
        return BtcppNode("SubTree", "SubTree", {"ID": str(params["use"])}, True)
    ports = {name: _port_value(value) for name, value in params.items()}
    return BtcppNode(kind, _KIND.get(shape, "Action"), ports)


def btcpp_nodes(log: TickLog) -> list[BtcppNode]:
    """Every node as BT.CPP sees it; a `PegbtError` naming the node for one that cannot be written: a
    parameter its BT.CPP node needs missing or not a number, a type or parameter name that is not an XML
    name (BT.CPP's node IDs and ports are element and attribute names), or a name or parameter value holding
    a character no XML 1.0 document can carry (a control character, even escaped)."""
    converted = []
    for node in log.nodes:
        where = f"node {node.get('id')}"
        try:
            btcpp = btcpp_node(node)
        except (KeyError, TypeError, ValueError, OverflowError) as error:
            raise PegbtError(
                f"{where} ({str(node.get('type'))[:40]}) cannot be written for BT.CPP: {type(error).__name__} "
                f"{str(error)[:80]}",
                file=log.path,
                field=where,
            ) from None
        bad = next((name for name in (btcpp.tag, *btcpp.ports) if not _XML_NAME.fullmatch(name)), None)
        if bad is not None:
            raise PegbtError(
                f"{where}: {bad[:40]!r} is not an XML name, which BT.CPP's node IDs and ports must be",
                file=log.path,
                field=where,
            )
        for text in (node["name"], *btcpp.ports.values()):
            if (char := _NOT_XML_CHAR.search(text)) is not None:
                raise PegbtError(
                    f"{where}: {text[:40]!r} holds {char.group()!r}, a character XML cannot carry",
                    file=log.path,
                    field=where,
                )
        converted.append(btcpp)
    return converted


def _instance_paths(log: TickLog) -> dict[int, str]:
    """`_fullpath` of every subtree instance: the instance names from the outermost in, `/`-joined."""
    paths: dict[int, str] = {}
    for node in log.nodes:
        if node["type"] == "subtree":
            parent, outer = node["parent"], ""
            while parent is not None and not outer:
                outer = paths.get(parent, "")
                parent = log.nodes[parent]["parent"]
            paths[node["id"]] = f"{outer}/{node['name']}" if outer else node["name"]
    return paths


def _shape(tree: ElementTree.Element) -> str:
    """A subtree instance's definition as BT.CPP reads it: everything but the logger's metadata."""
    copy = ElementTree.fromstring(ElementTree.tostring(tree))
    for element in copy.iter():
        for name in ("_uid", "_fullpath", "ID") if element is copy else ("_uid", "_fullpath"):
            element.attrib.pop(name, None)
    return ElementTree.tostring(copy, encoding="unicode")


def _distinct_subtree_ids(instances: list[tuple[ElementTree.Element, ElementTree.Element]]) -> None:
    """Give instances of one subtree that pegbt expanded differently (other arguments, so other names and
    ports) IDs of their own (`place`, `place_2`, ...): BT.CPP keeps one definition per ID, so a reader
    that builds the tree from the XML would give every instance the last one's names. The deepest
    instances are named first, so an outer instance's definition names the IDs its inner ones end with;
    at one depth, in the order they appear (the first keeps the ID)."""
    taken = {tree.get("ID") for _, tree in instances}
    shapes: dict[str, dict[str, str]] = {}  # ID -> definition -> the ID it is written under
    deepest_first = sorted(instances, key=lambda pair: -str(pair[1].get("_fullpath")).count("/"))
    for subtree, tree in deepest_first:
        given = str(tree.get("ID"))
        known = shapes.setdefault(given, {})
        shape = _shape(tree)
        if shape not in known:
            if not known:
                known[shape] = given
            else:
                k = len(known) + 1
                while f"{given}_{k}" in taken:
                    k += 1
                known[shape] = f"{given}_{k}"
                taken.add(known[shape])
        subtree.set("ID", known[shape])
        tree.set("ID", known[shape])


def tree_xml(log: TickLog) -> str:
    """The tree as `FileLogger2` embeds it: `BehaviorTree` elements with `_fullpath`, nodes with `_uid`."""
    nodes = btcpp_nodes(log)
    paths = _instance_paths(log)
    root = ElementTree.Element("root", BTCPP_format="4", main_tree_to_execute="MainTree")
    main = ElementTree.SubElement(root, "BehaviorTree", ID="MainTree", _fullpath="")
    elements: dict[int, ElementTree.Element] = {}
    instances: list[tuple[ElementTree.Element, ElementTree.Element]] = []  # (SubTree, its BehaviorTree)
    for node, bt in zip(log.nodes, nodes):
        parent = main if node["parent"] is None else elements[node["parent"]]
        uid = str(node["id"] + 1)
        if bt.kind == "SubTree":
            path = paths[node["id"]]
            element = ElementTree.SubElement(parent, "SubTree", ID=bt.ports["ID"], name=node["name"])
            element.set("_fullpath", path)
            element.set("_uid", uid)
            elements[node["id"]] = ElementTree.SubElement(
                root, "BehaviorTree", ID=bt.ports["ID"], _fullpath=path
            )
            instances.append((element, elements[node["id"]]))
            continue
        elements[node["id"]] = ElementTree.SubElement(
            parent, bt.tag, {"name": node["name"], "_uid": uid, **bt.ports}
        )
    _distinct_subtree_ids(instances)
    declared: dict[str, ElementTree.Element] = {}
    for bt in nodes:
        if bt.builtin:
            continue
        model = declared.setdefault(bt.tag, ElementTree.Element(bt.kind, ID=bt.tag))
        known = {port.get("name") for port in model}
        for name in bt.ports:
            if name not in known:
                ElementTree.SubElement(model, "input_port", name=name, type="std::string")
    ElementTree.SubElement(root, "TreeNodesModel").extend(declared[tag] for tag in sorted(declared))
    ElementTree.indent(root, space="    ")
    return ElementTree.tostring(root, encoding="unicode")


class BtcppStatuses:
    """The tick log's status changes as BT.CPP's `StatusChangeLogger` reports them for the same run.

    BT.CPP sets a control node RUNNING before ticking its children (`setStatus(RUNNING)` at the top of
    each `tick()`); a control node resets its children to IDLE when it completes, before its own status
    (`ControlNode::resetChildren`); a decorator resets its child as soon as the child completes
    (`DecoratorNode::resetChild`); a reactive node halts the other children when one runs; halting a
    running node resets its descendants, then itself; `Tree::tickRoot` resets a completed root. The tick
    log (py_trees) has parents after children and keeps completed statuses until the next start, so its
    changes to INVALID count only as halts of running nodes. A node completing again with the status it
    last had is one change in the tick log, so one in the export.
    """

    def __init__(self, log: TickLog) -> None:
        self.nodes = btcpp_nodes(log)
        self.parent = [node["parent"] for node in log.nodes]
        self.children: list[list[int]] = [[] for _ in log.nodes]
        for node in log.nodes:
            if node["parent"] is not None:
                self.children[node["parent"]].append(node["id"])
        self.status = [IDLE] * len(log.nodes)
        self.events: list[tuple[float, int, int]] = []  # (seconds since the start, uid, status)
        for change in log.transitions:
            self._change(change.t, change.node, _STATUS[change.after])

    def _emit(self, t: float, node: int, status: int) -> None:
        if self.status[node] != status:
            self.status[node] = status
            self.events.append((t, node + 1, status))

    def _reset(self, t: float, node: int) -> None:
        if self.status[node] == RUNNING:
            for child in self.children[node]:
                self._reset(t, child)
        self._emit(t, node, IDLE)

    def _start_ancestors(self, t: float, node: int | None) -> None:
        chain = []
        while node is not None:
            chain.append(node)
            node = self.parent[node]
        for ancestor in reversed(chain):
            self._emit(t, ancestor, RUNNING)

    def _change(self, t: float, node: int, status: int) -> None:
        if status == IDLE:
            if self.status[node] == RUNNING:
                self._reset(t, node)
            return
        parent = self.parent[node]
        self._start_ancestors(t, parent)
        if self.nodes[node].kind != "Action":
            self._emit(t, node, RUNNING)
            if status != RUNNING:
                for child in self.children[node]:
                    self._reset(t, child)
        self._emit(t, node, status)
        if status == RUNNING and parent is not None and self.nodes[parent].tag in _REACTIVE:
            for sibling in self.children[parent]:
                if sibling != node:
                    self._reset(t, sibling)
        if status != RUNNING and (parent is None or self.nodes[parent].kind in ("Decorator", "SubTree")):
            self._reset(t, node)


def export_btlog(log: TickLog, path: Path) -> int:
    """Write `log` as a `.btlog` file at `path`; returns the number of status changes written.

    The name must end `.btlog`, as BT.CPP's `FileLogger2` requires (its constructor throws otherwise) and
    as Groot2 looks for."""
    if path.suffix != ".btlog":
        raise PegbtError(
            "a Groot2 log's name must end .btlog (BT.CPP's FileLogger2 rule)", file=path, field="OUT"
        )
    if len(log.nodes) >= 2**16:
        raise PegbtError(
            f"{len(log.nodes)} nodes: a .btlog holds at most 65535", file=log.path, field="nodes"
        )
    if "start_time" not in log.header:
        raise PegbtError("the log's header has no start time", file=log.path, line=1, field="start_time")
    start = datetime.datetime.fromisoformat(log.header["start_time"])
    xml = tree_xml(log).encode("utf-8")
    records = bytearray()
    for t, uid, status in BtcppStatuses(log).events:
        records += max(0, round(t * 1e6)).to_bytes(6, "little") + struct.pack("<HB", uid, status)
    try:
        with path.open("wb") as out:
            out.write(MAGIC + bytes([PROTOCOL]) + struct.pack("<i", len(xml)) + xml)
            out.write(struct.pack("<q", int(start.timestamp() * 1e6)) + records)
    except OSError as error:
        raise PegbtError(f"cannot write: {error.strerror}", file=path) from None
    return len(records) // 9
