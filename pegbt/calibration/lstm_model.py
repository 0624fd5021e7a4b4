"""The `lstm` model: the reference paper's learned forward model, as the baseline to beat.

An LSTM (256 hidden) and two 256-unit layers read a short window of recent wrist commands (q4–q6) and
predict the wrist's error q_phy − q_cmd. It learned from settled set-points 0.4–1.1 s apart, so its
history is a history of set-points: when commands stream at 10 ms, a command becomes a history entry
only once it is `history_spacing` (the median set-point step of its training data) from the last one.

For compensation the history is encoded once per issued command; each candidate then costs one LSTM
step and the dense layers.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

from pegbt.calibration import nets
from pegbt.calibration.base import WRIST, CalibrationModel
from pegbt.calibration.modelfile import decode_arrays, encode_arrays

CellState = tuple[torch.Tensor, torch.Tensor]
LstmState = tuple[NDArray[np.float64], CellState]  # (history rows, LSTM state after them)


def command_windows(q: NDArray[np.float64], window: int) -> NDArray[np.float64]:
    """(N, window, J): row n holds commands n−window+1..n, the first row repeated before the start."""
    padded = np.concatenate([np.repeat(q[:1], window - 1, axis=0), q])
    return np.ascontiguousarray(sliding_window_view(padded, window, axis=0).transpose(0, 2, 1))


class LstmModel(CalibrationModel):
    kind = "lstm"
    outputs = WRIST

    def __init__(
        self,
        arm: str,
        *,
        window: int = 5,
        hidden: int = 256,
        epochs: int = 60,
        batch_size: int = 64,
        learning_rate: float = 1e-3,
        seed: int = 0,
    ) -> None:
        super().__init__(arm)
        self.window, self.hidden = window, hidden
        self.training = nets.TrainingSettings(epochs, batch_size, learning_rate, seed=seed)
        self.net = nets.WindowLstm(len(WRIST), len(WRIST), hidden)
        self.cell = self.net.stepper()
        self.inputs = self.targets = nets.Scaling.identity(len(WRIST))

    def _fit(self, q_cmd: NDArray[np.float64], q_phy: NDArray[np.float64]) -> None:
        wrist = q_cmd[:, WRIST]
        self.inputs = nets.Scaling.of(wrist)
        self.targets = nets.Scaling.of(q_phy[:, WRIST] - wrist)
        nets.train(
            self.net,
            self.inputs.apply(command_windows(wrist, self.window)),
            self.targets.apply(q_phy[:, WRIST] - wrist),
            self.training,
        )
        self.history_spacing = float(np.median(np.abs(np.diff(wrist, axis=0)).max(axis=1)))

    def _predict(self, q_cmd: NDArray[np.float64]) -> NDArray[np.float64]:
        wrist = q_cmd[:, WRIST]
        error = nets.run(self.net, self.inputs.apply(command_windows(wrist, self.window)))
        return wrist + self.targets.undo(error)

    # ------------------------------------------------------------------ one command at a time
    def _encode(self, history: NDArray[np.float64]) -> CellState:
        nets.use_one_thread()
        rows = torch.from_numpy(self.inputs.apply(history))
        state = (torch.zeros(1, self.hidden), torch.zeros(1, self.hidden))
        with torch.inference_mode():
            for row in rows:
                state = self.cell(row[None], state)
        return state

    def initial_state(self, q: NDArray[np.float64]) -> LstmState:
        history = np.repeat(q[None, WRIST], self.window - 1, axis=0)
        return history, self._encode(history)

    def forward(self, q_c: NDArray[np.float64], state: LstmState) -> NDArray[np.float64]:
        with torch.inference_mode():
            hidden, _ = self.cell(torch.from_numpy(self.inputs.apply(q_c[None, WRIST])), state[1])
            error = self.net.head(hidden).numpy()[0]
        q_phy = q_c.copy()
        q_phy[list(WRIST)] += self.targets.undo(error)
        return q_phy

    def advance(self, state: LstmState, q_issued: NDArray[np.float64]) -> LstmState:
        history = np.concatenate([state[0][1:], q_issued[None, WRIST]])
        return history, self._encode(history)

    # ------------------------------------------------------------------ files
    def _body(self) -> dict[str, Any]:
        arrays = nets.weights_of(self.net, "net")
        arrays |= self.inputs.arrays("inputs") | self.targets.arrays("targets")
        settings = {
            "window": self.window,
            "hidden": self.hidden,
            "history_spacing": self.history_spacing,
            "epochs": self.training.epochs,
            "batch_size": self.training.batch_size,
            "learning_rate": self.training.learning_rate,
            "seed": self.training.seed,
        }
        return {"settings": settings, "arrays": encode_arrays(arrays)}

    def _restore(self, document: dict[str, Any], path: Path) -> None:
        settings = document["settings"]
        self.window, self.hidden = int(settings["window"]), int(settings["hidden"])
        self.history_spacing = float(settings["history_spacing"])
        arrays = decode_arrays(document["arrays"], path)
        self.net = nets.WindowLstm(len(WRIST), len(WRIST), self.hidden)
        nets.load_weights(self.net, arrays, "net")
        self.cell = self.net.stepper()
        self.inputs = nets.Scaling.from_arrays(arrays, "inputs")
        self.targets = nets.Scaling.from_arrays(arrays, "targets")
