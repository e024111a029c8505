"""Training and testing PointNet on the data sets of :mod:`vtcore.learn.datasets` (seed 000, Sect. 4.1).

The paper: 20 epochs, batches of 16, random rotations and Gaussian noise as training
augmentation. Here: Adam (lr 1e-3), rotation about the vertical axis (z, the objects'
axis, uniform angle), jitter of N(0, 0.01) clipped at 0.05 on the normalised x, y, z
(the values of the PointNet reference code; the colour is not jittered), and the epoch
with the best validation accuracy (ties: the lower validation loss) is the one tested.
A loss that is not finite stops training with :class:`TrainingDivergedError`.
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError, VtError
from .pointnet import build_pointnet, limit_threads, orthogonality_loss, require_torch


class TrainingDivergedError(VtError, ArithmeticError):
    """The training loss became NaN or inf."""


@dataclass
class TrainConfig:
    """Hyper-parameters. epochs, batch : the paper's 20 and 16. lr : Adam's step.
    jitter, jitter_clip : normalised units. threads : torch threads, at most the cores this
    process may use (None: all of them). recalibrate_bn : before each validation, recompute batch
    norm's statistics from the training clouds at the current weights. With few optimisation
    steps (quick runs, tests: tens of batches) the running averages lag the weights and the
    network in evaluation mode gives one class for every input; this costs one forward pass
    over the training set per epoch. device : a torch device name (``"cpu"``, ``"cuda"``; see
    :func:`vtcore.learn.pointnet.resolve_device`): the network and each batch live there; the
    shuffling and augmentation draws stay on the CPU generator, so the same seed draws the same
    batches and rotations on either device (the arithmetic's last bits may differ on a GPU)."""

    epochs: int = 20
    batch: int = 16
    lr: float = 1e-3
    jitter: float = 0.01
    jitter_clip: float = 0.05
    rotate: bool = True
    input_transform: bool = False
    feature_transform: bool = False
    seed: int = 0
    threads: int | None = None
    recalibrate_bn: bool = False
    device: str = "cpu"


@dataclass
class TrainResult:
    """A trained network and its history.

    curves : per epoch ``train_loss``, ``train_accuracy``, ``val_loss``, ``val_accuracy``
    (lists). best_epoch : 1-based epoch kept. seconds : wall time of training.
    """

    model: object
    curves: dict = field(default_factory=dict)
    best_epoch: int = 0
    seconds: float = 0.0
    cpu_seconds: float = 0.0
    threads: int = 1


def augment_batch(x, gen, cfg: TrainConfig):
    """Random rotation about z and clipped Gaussian jitter on x, y, z of a (B, P, C) CPU tensor."""
    torch = require_torch()
    x = x.clone()
    if cfg.rotate:
        a = torch.rand(len(x), generator=gen, dtype=x.dtype) * (2 * np.pi)
        c, s = torch.cos(a)[:, None], torch.sin(a)[:, None]
        px, py = x[:, :, 0].clone(), x[:, :, 1].clone()
        x[:, :, 0], x[:, :, 1] = c * px - s * py, s * px + c * py
    if cfg.jitter > 0:
        noise = torch.randn(x[:, :, :3].shape, generator=gen, dtype=x.dtype) * cfg.jitter
        x[:, :, :3] += noise.clamp(-cfg.jitter_clip, cfg.jitter_clip)
    return x


def _loss(torch, model, xb, yb, cfg):
    logits, mfeat = model(xb)
    loss = torch.nn.functional.cross_entropy(logits, yb)
    if mfeat is not None:
        loss = loss + 1e-3 * orthogonality_loss(mfeat)
    return loss, logits


def model_device(model):
    """The torch device a network's parameters live on."""
    return next(model.parameters()).device


def predict(model, x: np.ndarray, batch: int = 64) -> np.ndarray:
    """Class scores (M, k) float32 of clouds ``x`` (M, P, C) in evaluation mode, on the model's device."""
    torch = require_torch()
    model.eval()
    dev = model_device(model)
    out = []
    with torch.no_grad():
        for i in range(0, len(x), batch):
            xb = torch.from_numpy(np.ascontiguousarray(x[i:i + batch], dtype=np.float32)).to(dev)
            out.append(model(xb)[0].cpu().numpy())
    return np.concatenate(out) if out else np.zeros((0, 0), np.float32)


def _eval(torch, model, x, y, batch=64):
    if len(x) == 0:
        return float("nan"), float("nan")
    scores = predict(model, x, batch)
    t = torch.from_numpy(scores)
    loss = float(torch.nn.functional.cross_entropy(t, torch.from_numpy(y)))
    return loss, float(np.mean(scores.argmax(axis=1) == y))


def train(x_train: np.ndarray, y_train: np.ndarray, x_val: np.ndarray, y_val: np.ndarray, n_classes: int,
          cfg: TrainConfig | None = None, progress=None) -> TrainResult:
    """Train PointNet on clouds ``x_train`` (M, P, C) float32 with labels (M,) int; validate each epoch.

    progress : optional ``(epoch, epochs, row) -> None`` called after every epoch.
    Raises TrainingDivergedError naming the epoch and batch where the loss stopped being finite.
    """
    torch = require_torch()
    cfg = cfg or TrainConfig()
    if not (np.isfinite(cfg.lr) and 0 < cfg.lr <= 1e30):   # Adam's float32 step overflows past ~3e38
        raise InputError(f"must be > 0 and <= 1e30, got {cfg.lr}", key="learning_rate")
    if cfg.epochs < 1 or cfg.batch < 2:
        raise InputError(f"epochs must be >= 1 and batch >= 2 (batch norm), got {cfg.epochs} and {cfg.batch}",
                         key="epochs")
    threads = limit_threads(cfg.threads)
    torch.manual_seed(cfg.seed)                         # weight initialisation and dropout
    gen = torch.Generator().manual_seed(cfg.seed + 1)   # shuffling and augmentation
    x_train = np.ascontiguousarray(x_train, dtype=np.float32)
    if not np.all(np.isfinite(x_train)):
        raise TrainingDivergedError("the training clouds hold NaN or inf: nothing to learn from")
    xt, yt = torch.from_numpy(x_train), torch.from_numpy(np.asarray(y_train, dtype=np.int64))
    dev = torch.device(cfg.device)
    model = build_pointnet(x_train.shape[2], n_classes, input_transform=cfg.input_transform,
                           feature_transform=cfg.feature_transform).to(dev)
    opt = torch.optim.Adam(model.parameters(), lr=cfg.lr)
    y_val = np.asarray(y_val, dtype=np.int64)
    curves = {k: [] for k in ("train_loss", "train_accuracy", "val_loss", "val_accuracy")}
    best, best_key, best_epoch = None, None, 0
    t0, c0 = time.perf_counter(), time.process_time()
    for epoch in range(1, cfg.epochs + 1):
        model.train()
        order = torch.randperm(len(xt), generator=gen)
        tot, correct, seen = 0.0, 0, 0
        for b, i in enumerate(range(0, len(order), cfg.batch)):
            idx = order[i:i + cfg.batch]
            if len(idx) < 2:       # batch norm needs two samples; the one left over joins the next epoch
                continue
            xb, yb = augment_batch(xt[idx], gen, cfg).to(dev), yt[idx].to(dev)
            opt.zero_grad()
            loss, logits = _loss(torch, model, xb, yb, cfg)
            if not torch.isfinite(loss):
                raise TrainingDivergedError(
                    f"training diverged: the loss is {loss.item()} at epoch {epoch}, batch {b + 1} "
                    f"(learning rate {cfg.lr:g}); lower task.learning_rate or check the clouds' colours")
            loss.backward()
            opt.step()
            tot += loss.item() * len(idx)
            correct += int((logits.argmax(1) == yb).sum())
            seen += len(idx)
        if cfg.recalibrate_bn:
            # torch's own recalibration (cumulative averages over one pass, as for weight averaging)
            torch.optim.swa_utils.update_bn([xt[i:i + 64] for i in range(0, len(xt), 64)], model, device=dev)
        vloss, vacc = _eval(torch, model, x_val, y_val)
        row = {"train_loss": tot / max(seen, 1), "train_accuracy": correct / max(seen, 1), "val_loss": vloss,
               "val_accuracy": vacc}
        for k, v in row.items():
            curves[k].append(v)
        # the validation split chooses the epoch (best accuracy, then lowest loss); no validation: the last
        key = (vacc, -vloss) if np.isfinite(vacc) else (epoch, 0.0)
        if best_key is None or key > best_key:
            best_key, best_epoch, best = key, epoch, copy.deepcopy(model.state_dict())
        if progress is not None:
            progress(epoch, cfg.epochs, row)
    if best is not None:
        model.load_state_dict(best)
    return TrainResult(model, curves, best_epoch, time.perf_counter() - t0, time.process_time() - c0, threads)


def confusion(y_true: np.ndarray, y_pred: np.ndarray, n_classes: int) -> np.ndarray:
    """(k, k) int counts: row = true class, column = predicted."""
    m = np.zeros((n_classes, n_classes), dtype=np.int64)
    np.add.at(m, (np.asarray(y_true), np.asarray(y_pred)), 1)
    return m
