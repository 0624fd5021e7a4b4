"""The one file format of a trained calibration model: a JSON document with its metadata.

Every kind of model (lstm, physics, hybrid) is stored the same way, so a person can read what a file
is for before trusting it, and loading can refuse a file made for another arm or joint layout:

    {"format": "pegbt-calibration-model", "version": 1, "kind": "hybrid", "arm": "PSM1",
     "joints": ["q1", ..., "q6"], "outputs": ["q4", "q5", "q6"],
     "training": {"recording": "...", "samples": 913, "created": "2025-...Z"},
     "heldout": {"recording": "...", "samples": 392, "joint_rmse": {...}, ...} or null,
     "settings": {...}, "effects": [...], "arrays": {"name": {"shape": [...], "data": "<base64 float32>"}}}

`effects` uses the sim-to-real report form, so `ArmPhysics.load(FILE)` reads a physics model's effects
directly (the simulator can run with a calibration model's physics). Network weights and input scalings
are little-endian float32 arrays in base64: exact, compact, and no pickle to execute on load.
"""

from __future__ import annotations

import base64
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pegbt.errors import PegbtError
from pegbt.psm import JOINT_NAMES, known_arm

FORMAT = "pegbt-calibration-model"
VERSION = 1


@dataclass
class ModelMetadata:
    """What a model is for and what it was trained and scored on."""

    kind: str
    arm: str
    outputs: tuple[str, ...]
    joints: tuple[str, ...] = JOINT_NAMES
    training: dict[str, Any] = field(default_factory=dict)
    heldout: dict[str, Any] | None = None


def model_file_name(arm: str, kind: str) -> str:
    """The name a model of `kind` for `arm` has in a directory of models (`PSM1-hybrid.json`): how the
    skills find an arm's model among several."""
    return f"{arm}-{kind}.json"


def encode_arrays(arrays: dict[str, NDArray[Any]]) -> dict[str, dict[str, Any]]:
    """Arrays as JSON-safe float32 base64 blobs with their shapes."""
    encoded = {}
    for name, array in arrays.items():
        data = np.ascontiguousarray(array, dtype="<f4")
        encoded[name] = {"shape": list(data.shape), "data": base64.b64encode(data.tobytes()).decode("ascii")}
    return encoded


def decode_arrays(encoded: dict[str, Any], path: Path) -> dict[str, NDArray[np.float32]]:
    """Inverse of `encode_arrays`; refuses corrupt or non-finite arrays."""
    arrays = {}
    for name, entry in encoded.items():
        try:
            raw = base64.b64decode(entry["data"], validate=True)
            array = np.frombuffer(raw, dtype="<f4").reshape(entry["shape"]).copy()
        except (KeyError, TypeError, ValueError) as error:
            raise PegbtError(f"corrupt array: {error}", file=path, field=f"arrays.{name}") from None
        if not np.all(np.isfinite(array)):
            raise PegbtError("array holds NaN or inf", file=path, field=f"arrays.{name}")
        arrays[name] = array
    return arrays


def write_document(path: str | Path, metadata: ModelMetadata, body: dict[str, Any]) -> Path:
    """Write a model file: the metadata header, then the model's own `settings`/`effects`/`arrays`."""
    path = Path(path)
    document = {
        "format": FORMAT,
        "version": VERSION,
        "kind": metadata.kind,
        "arm": metadata.arm,
        "joints": list(metadata.joints),
        "outputs": list(metadata.outputs),
        "training": metadata.training,
        "heldout": metadata.heldout,
        **body,
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(document, indent=1) + "\n")
    return path


def read_document(path: str | Path, arm: str | None = None) -> tuple[ModelMetadata, dict[str, Any]]:
    """Read a model file's metadata and body; refuse another format, arm or joint layout."""
    path = Path(path)
    try:
        document = json.loads(path.read_text())
    except OSError as error:
        raise PegbtError(f"cannot read model file: {error.strerror}", file=path) from None
    except json.JSONDecodeError as error:
        raise PegbtError(
            f"not a model file: {error.msg}", file=path, line=error.lineno, column=error.colno
        ) from None
    if not isinstance(document, dict) or document.get("format") != FORMAT:
        raise PegbtError(
            f"not a calibration model file (format is not {FORMAT!r})", file=path, field="format"
        )
    if document.get("version") != VERSION:
        raise PegbtError(
            f"model file version {document.get('version')!r}; this pegbt reads {VERSION}",
            file=path,
            field="version",
        )
    joints = _names(document, "joints", path)
    if joints != JOINT_NAMES:
        raise PegbtError(
            f"the model's joint layout {list(joints)} is not this arm's {list(JOINT_NAMES)}",
            file=path,
            field="joints",
        )
    outputs = _names(document, "outputs", path)
    if not outputs or not set(outputs) <= set(JOINT_NAMES):
        raise PegbtError(
            f"the model's outputs {list(outputs)} are not joints of {list(JOINT_NAMES)}",
            file=path,
            field="outputs",
        )
    model_arm = known_arm(document.get("arm"), path)
    if arm is not None and model_arm != arm:
        raise PegbtError(f"the model is for {model_arm!r}, not {arm!r}", file=path, field="arm")
    for name in ("training", "heldout"):
        if document.get(name) is not None and not isinstance(document[name], dict):
            raise PegbtError(f"expected an object; got {document[name]!r}", file=path, field=name)
    metadata = ModelMetadata(
        kind=str(document.get("kind")),
        arm=model_arm,
        outputs=outputs,
        joints=joints,
        training=dict(document.get("training") or {}),
        heldout=document.get("heldout"),
    )
    return metadata, document


def _names(document: dict[str, Any], key: str, path: Path) -> tuple[str, ...]:
    """The list of joint names under `key` (empty if absent); a `PegbtError` naming the field if it is no such list."""
    value = document.get(key, [])
    if not isinstance(value, list) or not all(isinstance(name, str) for name in value):
        raise PegbtError(f"expected a list of joint names; got {value!r}", file=path, field=key)
    return tuple(value)
