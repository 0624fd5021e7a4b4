"""The torch networks of the learned models, one training loop, and their weights as plain arrays.

Training and inference run on one CPU thread: on a shared 2-core machine a second OpenMP thread makes
torch many times slower whenever anything else runs, and the per-step compensation must stay < 1 ms.
Inputs and targets are standardised with the training set's mean and spread, stored with the weights.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from numpy.typing import NDArray
from torch import nn


def use_one_thread() -> None:
    if torch.get_num_threads() != 1:
        torch.set_num_threads(1)


class WindowLstm(nn.Module):
    """The reference paper's forward model: an LSTM over a window of commands, then two dense layers."""

    def __init__(self, n_in: int, n_out: int, hidden: int = 256) -> None:
        super().__init__()
        self.lstm = nn.LSTM(n_in, hidden, batch_first=True)
        self.head = nn.Sequential(
            nn.Linear(hidden, hidden),
            nn.ReLU(),
            nn.Linear(hidden, hidden),
            nn.ReLU(),
            nn.Linear(hidden, n_out),
        )

    def forward(self, window: torch.Tensor) -> torch.Tensor:
        """(B, T, n_in) windows → (B, n_out) from the last step."""
        out, _ = self.lstm(window)
        return self.head(out[:, -1])

    def stepper(self) -> nn.LSTMCell:
        """An `LSTMCell` sharing this LSTM's weights: one step costs ~40 µs instead of ~190 µs through
        `nn.LSTM`'s per-call overhead, which matters for the M steps of every compensated command."""
        cell = nn.LSTMCell(self.lstm.input_size, self.lstm.hidden_size)
        weight = self.lstm.get_parameter
        cell.weight_ih, cell.weight_hh = weight("weight_ih_l0"), weight("weight_hh_l0")
        cell.bias_ih, cell.bias_hh = weight("bias_ih_l0"), weight("bias_hh_l0")
        return cell.eval()


def residual_mlp(n_in: int, n_out: int, hidden: int = 64) -> nn.Sequential:
    """The hybrid model's small residual network."""
    return nn.Sequential(
        nn.Linear(n_in, hidden), nn.Tanh(), nn.Linear(hidden, hidden), nn.Tanh(), nn.Linear(hidden, n_out)
    )


@dataclass(frozen=True)
class TrainingSettings:
    epochs: int
    batch_size: int = 64
    learning_rate: float = 1e-3
    weight_decay: float = 0.0
    seed: int = 0


@dataclass(frozen=True)
class Scaling:
    """Standardisation: (x − mean) / spread; the spread never vanishes."""

    mean: NDArray[np.float32]
    spread: NDArray[np.float32]

    @classmethod
    def identity(cls, n: int) -> Scaling:
        return cls(np.zeros(n, np.float32), np.ones(n, np.float32))

    @classmethod
    def of(cls, x: NDArray[np.float64]) -> Scaling:
        flat = x.reshape(-1, x.shape[-1])
        return cls(
            flat.mean(axis=0).astype(np.float32), np.maximum(flat.std(axis=0), 1e-6).astype(np.float32)
        )

    def apply(self, x: NDArray[np.float64]) -> NDArray[np.float32]:
        return ((x - self.mean) / self.spread).astype(np.float32)

    def undo(self, y: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(y, dtype=np.float64) * self.spread + self.mean

    def arrays(self, prefix: str) -> dict[str, NDArray[np.float32]]:
        return {f"{prefix}.mean": self.mean, f"{prefix}.spread": self.spread}

    @classmethod
    def from_arrays(cls, arrays: dict[str, NDArray[np.float32]], prefix: str) -> Scaling:
        return cls(arrays[f"{prefix}.mean"], arrays[f"{prefix}.spread"])


def train(
    net: nn.Module, inputs: NDArray[np.float32], targets: NDArray[np.float32], settings: TrainingSettings
) -> None:
    """Minimise the mean squared error of `net(inputs)` against `targets` with Adam, in minibatches."""
    use_one_thread()
    torch.manual_seed(settings.seed)
    generator = torch.Generator().manual_seed(settings.seed)
    x, y = torch.from_numpy(inputs), torch.from_numpy(targets)
    optimiser = torch.optim.Adam(
        net.parameters(), lr=settings.learning_rate, weight_decay=settings.weight_decay
    )
    loss_fn = nn.MSELoss()
    net.train()
    for _ in range(settings.epochs):
        order = torch.randperm(len(x), generator=generator)
        for start in range(0, len(x), settings.batch_size):
            batch = order[start : start + settings.batch_size]
            optimiser.zero_grad()
            loss = loss_fn(net(x[batch]), y[batch])
            loss.backward()
            optimiser.step()
    net.eval()


def run(net: nn.Module, inputs: NDArray[np.float32]) -> NDArray[np.float64]:
    """Inference over a batch, no autograd."""
    use_one_thread()
    with torch.inference_mode():
        return net(torch.from_numpy(inputs)).numpy().astype(float)


def weights_of(net: nn.Module, prefix: str) -> dict[str, NDArray[np.float32]]:
    return {f"{prefix}.{name}": value.detach().numpy() for name, value in net.state_dict().items()}


def load_weights(net: nn.Module, arrays: dict[str, NDArray[np.float32]], prefix: str) -> None:
    """Put stored arrays back into `net`; a missing or misshapen tensor is a `ValueError`."""
    state = {
        name[len(prefix) + 1 :]: torch.from_numpy(value)
        for name, value in arrays.items()
        if name.startswith(prefix + ".")
    }
    try:
        net.load_state_dict(state, strict=True)
    except RuntimeError as error:  # torch reports missing or misshapen tensors this way
        raise ValueError(str(error).splitlines()[0]) from None
    net.eval()
