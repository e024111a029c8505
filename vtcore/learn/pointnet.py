"""PointNet (Qi et al. 2017) for seed 000's classification (Sect. 4.1), in PyTorch, on CPU or a CUDA GPU.

torch is an optional extra (``pip install vtcore[learn]``, pinned ``torch==2.13.0``): it is
imported by :func:`require_torch` inside the functions here, never at ``import vtcore``, so
the rest of vtcore (and the Blender extension, which does not bundle torch) works without it.

Architecture (the paper's "simple PointNet", the classification network of Qi et al.):
a shared per-point MLP 64-64-64-128-1024 (batch norm and ReLU after each layer),
a max pool over the points, a 512-256-k head with batch norm, ReLU and dropout 0.3.
The input T-net (a 3x3 transform of x, y, z) and the feature T-net (64x64, with the
orthogonality regulariser of the original paper, weight 0.001) are optional
(``input_transform``, ``feature_transform``); the run reports which were used.
"""

from __future__ import annotations

import os

from ..errors import InputError

#: the pinned version of the optional extra (requirements.lock, pyproject ``learn``)
TORCH_PIN = "torch==2.13.0"


class MissingTorchError(InputError):
    """torch is not installed: the learning tasks need the optional extra ``vtcore[learn]``."""


def require_torch():
    """Import and return torch, or raise :class:`MissingTorchError` naming how to install it."""
    try:
        import torch
    except ImportError:
        raise MissingTorchError(f"PointNet training needs PyTorch: pip install 'vtcore[learn]' "
                                f"(pins {TORCH_PIN}, a CPU build)") from None
    return torch


#: the values of ``task.device``
DEVICES = ("cpu", "cuda", "auto")


def resolve_device(device: str = "cpu") -> str:
    """The torch device to train on: ``"cpu"``, ``"cuda"`` or ``"auto"`` -> ``"cpu"`` or ``"cuda"``.

    ``auto`` takes CUDA when torch sees a usable GPU, else the CPU. ``cuda`` without one is an
    InputError that says what torch reports (a CPU-only build, no driver, no device), never a
    silent fall-back: a user who asked for the GPU must know the run did not use it.
    """
    torch = require_torch()
    if device not in DEVICES:
        raise InputError(f"unknown device {device!r}; valid: {', '.join(DEVICES)}", key="device")
    if device == "cpu":
        return "cpu"
    available = bool(torch.cuda.is_available())
    if device == "auto":
        return "cuda" if available else "cpu"
    if not available:
        build = "a CPU-only torch build" if torch.version.cuda is None else \
            f"torch built for CUDA {torch.version.cuda}, but no usable GPU or driver"
        raise InputError(f"cuda was asked for but torch cannot use a GPU here ({build}); use cpu or auto",
                         key="device")
    return "cuda"


def machine_cores() -> int:
    """Cores this process may use (its CPU affinity; the count of the machine elsewhere)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - macOS, Windows
        return max(1, os.cpu_count() or 1)


def limit_threads(threads: int | None = None) -> int:
    """Limit torch's intra-op threads to ``threads`` (default: the cores this process may use).

    torch starts one thread per *hardware* thread it sees, which on a shared or
    containerised machine oversubscribes the cores the process is allowed.
    """
    torch = require_torch()
    n = machine_cores() if threads is None else max(1, min(int(threads), machine_cores()))
    torch.set_num_threads(n)
    return n


def build_pointnet(in_channels: int, n_classes: int, *, input_transform: bool = False,
                   feature_transform: bool = False, dropout: float = 0.3):
    """A PointNet classifier: ``forward(x (B, P, C)) -> (logits (B, k), feature_matrix (B, 64, 64) or None)``.

    in_channels : C, 3 for (x, y, z) or 4 for (x, y, z, c). The input T-net
    transforms the first three channels only (a colour is not a direction).
    The shared MLP is written as linear layers over the (B * P, C) points, the same
    operation as the reference's 1x1 convolutions, measured 25 % faster on this CPU
    (one matrix product per layer instead of a convolution over a length-1 kernel).
    """
    torch = require_torch()
    nn = torch.nn

    def layer(i, o):
        return nn.Sequential(nn.Linear(i, o), nn.BatchNorm1d(o), nn.ReLU())

    def shared(x, mlp):
        """The per-point MLP on (B, P, C): every point through the same layers."""
        b, p, c = x.shape
        y = mlp(x.reshape(b * p, c))
        return y.reshape(b, p, -1)

    class TNet(nn.Module):
        """Predicts a (k, k) transform of the points' k channels; starts at the identity."""

        def __init__(self, k):
            super().__init__()
            self.k = k
            self.feat = nn.Sequential(layer(k, 64), layer(64, 128), layer(128, 1024))
            self.head = nn.Sequential(layer(1024, 512), layer(512, 256), nn.Linear(256, k * k))
            nn.init.zeros_(self.head[-1].weight)
            nn.init.zeros_(self.head[-1].bias)

        def forward(self, x):
            m = self.head(shared(x, self.feat).max(dim=1).values).view(-1, self.k, self.k)
            return m + torch.eye(self.k, dtype=x.dtype, device=x.device)

    class PointNet(nn.Module):
        def __init__(self):
            super().__init__()
            self.in_channels = in_channels
            self.tnet_in = TNet(3) if input_transform else None
            self.mlp1 = nn.Sequential(layer(in_channels, 64), layer(64, 64))
            self.tnet_feat = TNet(64) if feature_transform else None
            self.mlp2 = nn.Sequential(layer(64, 64), layer(64, 128), layer(128, 1024))
            self.head = nn.Sequential(layer(1024, 512), nn.Dropout(dropout), layer(512, 256), nn.Dropout(dropout),
                                      nn.Linear(256, n_classes))

        def forward(self, x):
            if self.tnet_in is not None:
                t = self.tnet_in(x[:, :, :3])
                x = torch.cat([torch.bmm(x[:, :, :3], t), x[:, :, 3:]], dim=2)
            x = shared(x, self.mlp1)
            mfeat = None
            if self.tnet_feat is not None:
                mfeat = self.tnet_feat(x)
                x = torch.bmm(x, mfeat)
            x = shared(x, self.mlp2).max(dim=1).values
            return self.head(x), mfeat

    return PointNet()


def orthogonality_loss(m):
    """||I - M M^T||_F^2 averaged over the batch: keeps the feature transform near a rotation."""
    torch = require_torch()
    eye = torch.eye(m.shape[1], dtype=m.dtype, device=m.device)
    return ((eye - torch.bmm(m, m.transpose(1, 2))) ** 2).sum(dim=(1, 2)).mean()
