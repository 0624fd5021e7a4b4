"""The `hybrid` model: the physics model plus a small learned residual on the wrist.

The named effects carry the bulk (offsets, scale, coupling, hysteresis, backlash) and keep their exact
inverse. A small network learns what they leave from the physics' own view of the wrist: where it puts
each joint (y), which way the play is taken up (m − y, the backlash's target minus the played output),
and the direction memory of the path of y (`PlayBank` gaps): hysteresis loops of other shapes and widths
than the identified ones. Reading the
physics' output rather than the raw commands keeps the inverse well posed: compensation picks y, the
physics inverse gives the command, and the residual is a smooth function of the y it picked (read from
the commands, the residual let the inverse jump between two solutions from one 10 ms step to the next).
Everything is rate-independent, so the history advances on every issued command.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from pegbt.calibration import nets
from pegbt.calibration.base import WRIST, CalibrationModel
from pegbt.calibration.hysteresis import PlayBank
from pegbt.calibration.modelfile import decode_arrays, encode_arrays
from pegbt.calibration.physics_model import PhysicsModel, PhysicsState

HybridState = tuple[PhysicsState, NDArray[np.float64]]  # (physics state, play-bank outputs)
N_WRIST = len(WRIST)


class HybridModel(CalibrationModel):
    kind = "hybrid"
    outputs = PhysicsModel.outputs

    def __init__(
        self,
        arm: str,
        *,
        widths: tuple[float, ...] = (0.05, 0.1, 0.2),
        hidden: int = 64,
        epochs: int = 300,
        batch_size: int = 64,
        learning_rate: float = 2e-3,
        weight_decay: float = 1e-2,
        seed: int = 0,
    ) -> None:
        super().__init__(arm)
        self.physics = PhysicsModel(arm)
        self.bank = PlayBank(widths, N_WRIST)
        self.hidden = hidden
        self.training = nets.TrainingSettings(epochs, batch_size, learning_rate, weight_decay, seed)
        n_features = N_WRIST * (2 + len(widths))
        self.net = nets.residual_mlp(n_features, N_WRIST, hidden)
        self.features = nets.Scaling.identity(n_features)
        self.targets = nets.Scaling.identity(N_WRIST)

    def _fit(self, q_cmd: NDArray[np.float64], q_phy: NDArray[np.float64]) -> None:
        self.physics._fit(q_cmd, q_phy)
        physics = self.physics._predict(q_cmd)
        features = self._feature_rows(q_cmd, physics)
        residual = q_phy[:, WRIST] - physics[:, WRIST]
        self.features, self.targets = nets.Scaling.of(features), nets.Scaling.of(residual)
        nets.train(self.net, self.features.apply(features), self.targets.apply(residual), self.training)

    def _feature_rows(self, q_cmd: NDArray[np.float64], physics: NDArray[np.float64]) -> NDArray[np.float64]:
        y = physics[:, WRIST]
        taken_up = self.physics.settled.physics.settled_targets(q_cmd)[:, WRIST] - y
        return np.concatenate([y, taken_up, self.bank.gaps(y)], axis=1)

    def _predict(self, q_cmd: NDArray[np.float64]) -> NDArray[np.float64]:
        q_phy = self.physics._predict(q_cmd)
        features = self.features.apply(self._feature_rows(q_cmd, q_phy))
        q_phy[:, WRIST] += self.targets.undo(nets.run(self.net, features))
        return q_phy

    # ------------------------------------------------------------------ one command at a time
    def initial_state(self, q: NDArray[np.float64]) -> HybridState:
        nets.use_one_thread()
        physics_state = self.physics.initial_state(q)
        return physics_state, self.bank.settle(physics_state.played[list(WRIST)])

    def forward(self, q_c: NDArray[np.float64], state: HybridState) -> NDArray[np.float64]:
        after = self.physics.advance(state[0], q_c)
        q_phy = after.played.copy()
        y = q_phy[list(WRIST)]
        taken_up = after.target[list(WRIST)] - y
        gaps, _ = self.bank.step(state[1], y)
        features = self.features.apply(np.concatenate([y, taken_up, gaps])[None])
        with torch.inference_mode():
            residual = self.net(torch.from_numpy(features)).numpy()[0]
        q_phy[list(WRIST)] += self.targets.undo(residual)
        return q_phy

    def advance(self, state: HybridState, q_issued: NDArray[np.float64]) -> HybridState:
        physics_state = self.physics.advance(state[0], q_issued)
        _, outputs = self.bank.step(state[1], physics_state.played[list(WRIST)])
        return physics_state, outputs

    def command_for(self, target: NDArray[np.float64], state: HybridState) -> NDArray[np.float64]:
        return self.physics.command_for(target, state[0])

    # ------------------------------------------------------------------ files
    def _body(self) -> dict[str, Any]:
        arrays = (
            nets.weights_of(self.net, "net")
            | self.features.arrays("features")
            | self.targets.arrays("targets")
        )
        settings = {
            "widths": list(self.bank.widths),
            "hidden": self.hidden,
            "epochs": self.training.epochs,
            "batch_size": self.training.batch_size,
            "learning_rate": self.training.learning_rate,
            "weight_decay": self.training.weight_decay,
            "seed": self.training.seed,
        }
        return self.physics._body() | {"settings": settings, "arrays": encode_arrays(arrays)}

    def _restore(self, document: dict[str, Any], path: Path) -> None:
        self.physics._restore(document, path)
        settings = document["settings"]
        self.bank = PlayBank([float(w) for w in settings["widths"]], N_WRIST)
        self.hidden = int(settings["hidden"])
        arrays = decode_arrays(document["arrays"], path)
        self.net = nets.residual_mlp(N_WRIST * (2 + len(self.bank.widths)), N_WRIST, self.hidden)
        nets.load_weights(self.net, arrays, "net")
        self.features = nets.Scaling.from_arrays(arrays, "features")
        self.targets = nets.Scaling.from_arrays(arrays, "targets")
