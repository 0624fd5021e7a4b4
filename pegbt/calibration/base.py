"""One interface for every calibration model: fit, predict, save, load, and the per-step calls
compensation needs.

A model is a forward map f(q_cmd; history) → q_phy: given the command about to be issued and what was
issued before, the physical joints the arm will reach. Two ways to use it:

- over a whole recording, `predict(q_cmd)` (row n's history is rows 0..n-1);
- one command at a time, as compensation does: `state = initial_state(q0)`, then per issued command
  `forward(q_c, state)` (any number of candidates) and `advance(state, q_issued)` (commit one);
  `command_for(target, state)` inverts the model's explicit physics analytically where it has any.

`history_spacing` says what counts as a history entry: 0 means every issued command (rate-independent
physics such as backlash); a positive value (rad) means a set-point, a command at least that far from
the previous entry, because the model learned from settled set-points, not 10 ms steps.
"""

from __future__ import annotations

import importlib
from abc import ABC, abstractmethod
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.calibration.modelfile import ModelMetadata, read_document, write_document
from pegbt.errors import PegbtError
from pegbt.physics.recording import Recording
from pegbt.psm import JOINT_NAMES, N_JOINTS, known_arm

WRIST = (3, 4, 5)  # roll, wrist pitch, wrist yaw: the cable-driven joints whose error matters
MIN_TRAIN_SAMPLES = 100

# Model kinds and where they live; imported on demand so the physics model never loads torch.
MODEL_KINDS: dict[str, str] = {
    "lstm": "pegbt.calibration.lstm_model:LstmModel",
    "physics": "pegbt.calibration.physics_model:PhysicsModel",
    "hybrid": "pegbt.calibration.hybrid_model:HybridModel",
}


class CalibrationModel(ABC):
    """Forward model of one arm's cable effects; subclasses fill in the `_` methods."""

    kind: ClassVar[str]
    outputs: ClassVar[tuple[int, ...]] = WRIST  # joints it predicts; the rest pass through
    history_spacing: float = 0.0

    def __init__(self, arm: str) -> None:
        self.arm = known_arm(arm)
        self.metadata: ModelMetadata | None = None

    # ------------------------------------------------------------------ fit and predict
    def fit(self, recording: Recording) -> CalibrationModel:
        """Learn the arm's effects from a recording of commanded and physical joints."""
        check_arm(recording, self.arm, f"this {self.kind} model")
        check_trainable(recording, self.outputs, MIN_TRAIN_SAMPLES)
        self._fit(recording.q_cmd, recording.q_phy)
        self.metadata = ModelMetadata(
            kind=self.kind,
            arm=self.arm,
            outputs=tuple(JOINT_NAMES[j] for j in self.outputs),
            training={
                "recording": recording.path.name,  # its name, not where it sat on the machine that trained
                "samples": len(recording),
                "created": datetime.now(UTC).isoformat(timespec="seconds"),
            },
        )
        return self

    def predict(self, q_cmd: ArrayLike) -> NDArray[np.float64]:
        """Physical joints (N, 6) the arm reaches for commands (N, 6), each row after the rows before it."""
        q_cmd = as_commands(q_cmd)
        self._require_fitted()
        q_phy = q_cmd.copy()
        q_phy[:, self.outputs] = self._predict(q_cmd)
        return require_finite(q_phy, f"the {self.kind} model's prediction")

    # ------------------------------------------------------------------ one command at a time
    @abstractmethod
    def initial_state(self, q: NDArray[np.float64]) -> Any:
        """History of an arm that has settled at command `q`."""

    @abstractmethod
    def forward(self, q_c: NDArray[np.float64], state: Any) -> NDArray[np.float64]:
        """Physical joints (6,) if `q_c` (6,) were issued next; does not change `state`."""

    @abstractmethod
    def advance(self, state: Any, q_issued: NDArray[np.float64]) -> Any:
        """The history after `q_issued` was actually issued (a new state; the old one is untouched)."""

    def command_for(self, target: NDArray[np.float64], state: Any) -> NDArray[np.float64]:
        """The command that puts the model's explicit physics at `target` (analytic inverse); the
        identity for a model without explicit physics. Compensation iterates on this target."""
        return target.copy()

    # ------------------------------------------------------------------ files
    def save(self, path: str | Path) -> Path:
        """Write the model in the one calibration file format."""
        self._require_fitted()
        assert self.metadata is not None
        return write_document(path, self.metadata, self._body())

    @staticmethod
    def load(path: str | Path, arm: str | None = None) -> CalibrationModel:
        """Read any kind of model file; refuses one made for another arm (when `arm` is given)."""
        metadata, document = read_document(path, arm)
        cls = model_class(metadata.kind, Path(path))
        expected = tuple(JOINT_NAMES[j] for j in cls.outputs)
        if metadata.outputs != expected:
            raise PegbtError(
                f"a {metadata.kind} model predicts {list(expected)}, the file says {list(metadata.outputs)}",
                file=path,
                field="outputs",
            )
        model = cls(metadata.arm)
        try:
            model._restore(document, Path(path))
        except (KeyError, TypeError, ValueError) as error:
            raise PegbtError(f"malformed {metadata.kind} model: {error!r}", file=path) from None
        model.metadata = metadata
        return model

    # ------------------------------------------------------------------ for subclasses
    @abstractmethod
    def _fit(self, q_cmd: NDArray[np.float64], q_phy: NDArray[np.float64]) -> None: ...

    @abstractmethod
    def _predict(self, q_cmd: NDArray[np.float64]) -> NDArray[np.float64]:
        """Predicted physical values of `self.outputs`, (N, len(outputs))."""

    @abstractmethod
    def _body(self) -> dict[str, Any]:
        """The file body: `settings`, and `effects` and/or `arrays`."""

    @abstractmethod
    def _restore(self, document: dict[str, Any], path: Path) -> None: ...

    def _require_fitted(self) -> None:
        if self.metadata is None:
            raise PegbtError(f"the {self.kind} model has not been fitted or loaded")


def model_class(kind: str, path: Path | None = None) -> type[CalibrationModel]:
    """The class of model kind `kind` (lstm, physics, hybrid)."""
    if kind not in MODEL_KINDS:
        raise PegbtError(
            f"unknown model kind {kind!r}; expected one of {', '.join(MODEL_KINDS)}", file=path, field="kind"
        )
    module_name, class_name = MODEL_KINDS[kind].split(":")
    return getattr(importlib.import_module(module_name), class_name)


def new_model(kind: str, arm: str, **settings: Any) -> CalibrationModel:
    """An unfitted model of kind `kind` for `arm`."""
    return model_class(kind)(arm, **settings)


def check_trainable(recording: Recording, joints: tuple[int, ...], min_samples: int) -> None:
    """Refuse a recording a model cannot learn from: too few samples, or a learned joint that never moves."""
    if len(recording) < min_samples:
        raise PegbtError(
            f"too few samples to train on: {len(recording)}, need at least {min_samples}", file=recording.path
        )
    for j in joints:
        span = float(np.ptp(recording.q_cmd[:, j]))
        if span < 1e-3:
            raise PegbtError(
                f"{JOINT_NAMES[j]} never moves in the commands (range {span:.2g}): its cable effects cannot be learned",
                file=recording.path,
                field=JOINT_NAMES[j],
            )


def check_arm(recording: Recording, arm: str, what: str) -> None:
    """Refuse to mix arms: a recording of PSM2 says nothing about PSM1's cables."""
    if recording.arm is not None and recording.arm != arm:
        raise PegbtError(
            f"the recording is of {recording.arm}, but {what} is for {arm}", file=recording.path, field="arm"
        )


def as_commands(q_cmd: ArrayLike) -> NDArray[np.float64]:
    """Commands as an (N, 6) float array, or a `PegbtError` saying what shape they had."""
    q_cmd = np.asarray(q_cmd, dtype=float)
    if q_cmd.ndim != 2 or q_cmd.shape[1] != N_JOINTS:
        raise PegbtError(
            f"commands must be N×{N_JOINTS} ({', '.join(JOINT_NAMES)}), got shape {q_cmd.shape}",
            field="q_cmd",
        )
    return q_cmd


def require_finite(values: NDArray[np.float64], what: str) -> NDArray[np.float64]:
    """`values` unchanged, or a `PegbtError` if a model produced NaN or inf (never pass those on)."""
    if not np.isfinite(values).all():
        raise PegbtError(f"{what} is not finite (NaN or inf): the model is broken or was fed bad input")
    return values
