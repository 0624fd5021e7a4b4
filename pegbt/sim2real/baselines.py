"""Black-box baselines that fit but name nothing: a linear model and the reference paper's LSTM, both
on a window of the most recent commands, predicting the physical joints; and nearest neighbours in the
commands, which estimate what a model's residual still holds that the commands could predict."""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

Array = NDArray[np.float64]

HISTORY = 5  # the paper's LSTM sees the last five commanded set-points


def command_windows(q_cmd: Array, history: int = HISTORY) -> Array:
    """(N, history, J): at each sample the last `history` commands, oldest first (the first sample repeated
    before the recording starts)."""
    padded = np.concatenate([np.repeat(q_cmd[:1], history - 1, axis=0), q_cmd])
    return np.stack([padded[k : k + len(q_cmd)] for k in range(history)], axis=1)


def linear_window(q_cmd: Array, q_phy: Array, train: int, history: int = HISTORY) -> Array:
    """Least-squares prediction of every physical joint from the last `history` commands, fitted on the
    first `train` samples; returns predictions for all samples."""
    windows = command_windows(q_cmd, history).reshape(len(q_cmd), -1)
    design = np.column_stack([np.ones(len(q_cmd)), windows])
    beta, *_ = np.linalg.lstsq(design[:train], q_phy[:train], rcond=None)
    return design @ beta


def lstm_window(
    q_cmd: Array,
    q_phy: Array,
    train: int,
    seconds: float = 15.0,
    seed: int = 0,
    history: int = HISTORY,
    hidden: int = 64,
) -> Array:
    """The paper's model: an LSTM over the last `history` commands predicting the physical joints' error
    (q_phy − q_cmd), trained with Adam on the first `train` samples (the last 15 % of them kept for early
    stopping) for at most `seconds`; returns predictions of q_phy for all samples. One CPU thread."""
    import torch

    torch.set_num_threads(1)
    torch.manual_seed(seed)
    windows = command_windows(q_cmd, history)
    error = q_phy - q_cmd
    mean_x, std_x = q_cmd[:train].mean(0), q_cmd[:train].std(0) + 1e-9
    mean_y, std_y = error[:train].mean(0), error[:train].std(0) + 1e-9
    x = torch.tensor((windows - mean_x) / std_x, dtype=torch.float32)
    y = torch.tensor((error - mean_y) / std_y, dtype=torch.float32)
    fit_rows = int(0.85 * train)

    class Model(torch.nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.lstm = torch.nn.LSTM(q_cmd.shape[1], hidden, batch_first=True)
            self.head = torch.nn.Linear(hidden, q_cmd.shape[1])

        def forward(self, batch: torch.Tensor) -> torch.Tensor:
            out, _ = self.lstm(batch)
            return self.head(out[:, -1])

    model = Model()
    optimiser = torch.optim.Adam(model.parameters(), lr=3e-3)
    generator = torch.Generator().manual_seed(seed)
    best, best_state, start = float("inf"), None, time.perf_counter()
    for _ in range(400):
        model.train()
        for batch in torch.randperm(fit_rows, generator=generator).split(64):
            optimiser.zero_grad()
            loss = torch.nn.functional.mse_loss(model(x[batch]), y[batch])
            loss.backward()
            optimiser.step()
        model.eval()
        with torch.no_grad():
            validation = torch.nn.functional.mse_loss(model(x[fit_rows:train]), y[fit_rows:train]).item()
        if validation < best:
            best, best_state = validation, {k: v.clone() for k, v in model.state_dict().items()}
        if time.perf_counter() - start > seconds:
            break
    assert best_state is not None  # the first validation loss is below infinity
    model.load_state_dict(best_state)
    with torch.no_grad():
        predicted = model(x).numpy().astype(float)
    return q_cmd + predicted * std_y + mean_y


def last_moves(q_cmd: Array) -> Array:
    """(N, J): the sign of each joint's last change of command up to each sample (0 before its first), the
    state a play's memory keeps."""
    steps = np.sign(np.diff(q_cmd, axis=0, prepend=q_cmd[:1]))
    moves = np.zeros_like(steps)
    current = np.zeros(q_cmd.shape[1])
    for i, step in enumerate(steps):
        current = np.where(step != 0, step, current)
        moves[i] = current
    return moves


def neighbours_of_commands(residual: Array, q_cmd: Array, folds: list[tuple[int, int]], k: int = 20) -> Array:
    """Held-out prediction of `residual` (N, J) by the mean of its `k` nearest set-points in the other
    folds, in the commands (each joint scaled to unit spread) and the direction each last moved: an
    estimate, with no model assumed, of what a model's residual still holds that the current command and
    its play state predict."""
    features = np.column_stack([q_cmd / np.maximum(q_cmd.std(0), 1e-12), last_moves(q_cmd)])
    predicted = np.empty_like(residual)
    for a, b in folds:
        train = np.ones(len(residual), dtype=bool)
        train[a:b] = False
        _, nearest = cKDTree(features[train]).query(features[a:b], k=k)
        predicted[a:b] = residual[train][nearest].mean(axis=1)
    return predicted
