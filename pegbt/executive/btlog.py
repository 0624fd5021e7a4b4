"""Export a tick log to Groot2's `.btlog` format (BehaviorTree.CPP's `FileLogger2`), so a run can be replayed there.

The format, as BehaviorTree.CPP documents it in `bt_file_logger_v2.h`:

- 4 bytes: length N of the XML text (little-endian int32), then the N bytes of XML: the tree in
  BehaviorTree.CPP 4 format, every node carrying a `_uid` attribute, and a `TreeNodesModel`;
- 8 bytes: the first timestamp, microseconds since the Unix epoch (int64);
- then one 8-byte little-endian word per status transition: bits 0-44 microseconds since the first
  timestamp, bits 45-60 the node's `_uid`, bits 61-63 the status (0 idle, 1 running, 2 success, 3 failure).

Every pegbt node is written as a custom node (its type as the element name, declared in
`TreeNodesModel` as Control, Decorator or Action with its parameters as input ports), because
py_trees' composites do not match BehaviorTree.CPP's built-ins exactly. py_trees' INVALID is idle.
"""

from __future__ import annotations

import datetime
import struct
import xml.etree.ElementTree as ElementTree
from pathlib import Path

from pegbt.errors import PegbtError
from pegbt.executive.logfile import TickLog
from pegbt.executive.nodetypes import NODE_TYPES

STATUS_CODES = {"INVALID": 0, "RUNNING": 1, "SUCCESS": 2, "FAILURE": 3}
_KINDS = {"composite": "Control", "recover": "Control", "decorator": "Decorator", "subtree": "Decorator"}


def _kind(node_type: str) -> str:
    return _KINDS[NODE_TYPES[node_type].shape] if node_type in NODE_TYPES else "Action"


def tree_xml(log: TickLog) -> str:
    """The tree as BehaviorTree.CPP 4 XML with `_uid` (node id + 1) on every node, and its node models."""
    root = ElementTree.Element("root", BTCPP_format="4", main_tree_to_execute="MainTree")
    tree = ElementTree.SubElement(root, "BehaviorTree", ID="MainTree", _fullpath="")
    elements: dict[int, ElementTree.Element] = {}
    models: dict[str, set[str]] = {}
    for node in log.nodes:
        parent = tree if node["parent"] is None else elements[node["parent"]]
        params = {name: "" if value is None else str(value) for name, value in node.get("params", {}).items()}
        element = ElementTree.SubElement(
            parent, node["type"], name=node["name"], _uid=str(node["id"] + 1), **params
        )
        elements[node["id"]] = element
        models.setdefault(node["type"], set()).update(params)
    model_root = ElementTree.SubElement(root, "TreeNodesModel")
    for node_type, ports in sorted(models.items()):
        model = ElementTree.SubElement(model_root, _kind(node_type), ID=node_type)
        for port in sorted(ports):
            ElementTree.SubElement(model, "input_port", name=port, type="std::string")
    return ElementTree.tostring(root, encoding="unicode")


def export_btlog(log: TickLog, path: Path) -> int:
    """Write `log` as a `.btlog` file at `path`; returns the number of transitions written."""
    if len(log.nodes) >= 2**16 - 1:
        raise PegbtError(
            f"{len(log.nodes)} nodes: a .btlog holds at most 65534", file=log.path, field="nodes"
        )
    if "start_time" not in log.header:
        raise PegbtError("the log's header has no start time", file=log.path, line=1, field="start_time")
    start = datetime.datetime.fromisoformat(log.header["start_time"])
    first_us = int(start.timestamp() * 1e6)
    xml = tree_xml(log).encode("utf-8")
    words = []
    for change in log.transitions:
        offset = max(0, round(change.t * 1e6)) & (2**45 - 1)
        words.append(offset | (change.node + 1) << 45 | STATUS_CODES[change.after] << 61)
    try:
        with path.open("wb") as out:
            out.write(struct.pack("<i", len(xml)))
            out.write(xml)
            out.write(struct.pack("<q", first_us))
            out.write(struct.pack(f"<{len(words)}Q", *words))
    except OSError as error:
        raise PegbtError(f"cannot write: {error.strerror}", file=path) from None
    return len(words)


def read_btlog(path: Path) -> tuple[str, int, list[tuple[int, int, int]]]:
    """(XML, first timestamp µs, [(µs offset, uid, status)]): the inverse of `export_btlog`, for checking files."""
    data = path.read_bytes()
    (size,) = struct.unpack_from("<i", data, 0)
    xml = data[4 : 4 + size].decode("utf-8")
    (first_us,) = struct.unpack_from("<q", data, 4 + size)
    body = data[12 + size :]
    if len(body) % 8:
        raise PegbtError("truncated .btlog: transitions are 8 bytes each", file=path)
    words = struct.unpack(f"<{len(body) // 8}Q", body)
    return xml, first_us, [(word & (2**45 - 1), word >> 45 & 0xFFFF, word >> 61) for word in words]
