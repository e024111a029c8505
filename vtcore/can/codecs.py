"""Skin CAN codecs: the iCub (MTB) skin protocol and cyskin16, a CySkin-style 16-bit protocol.

A codec turns frames into *streams* and channels, vectorised over a whole
:class:`~vtcore.can.frames.FrameBatch`:

- a *stream* (key) is one kind of frame sent once per sampling period: an iCub
  triangle's 0x40 or 0xC0 frame, or one of the three frames of a CySkin module;
- each stream carries up to ``n_channels`` taxel values; ``channel_ids(keys)``
  gives their taxel UIDs (-1 where a channel is not a taxel);
- ``classify`` validates identifiers, DLC and headers and says why a frame is
  rejected, ``values`` reads the payload matrix in one ``view``/slice.

Both protocols are also described by DBC files shipped in this package
(``icub_skin.dbc``, ``cyskin16.dbc``); the vectorised layout of cyskin16 is read
from its DBC with cantools, and :meth:`Codec.reference_decode` decodes one
``can.Message`` through cantools: the per-message path that tests and the
benchmark compare the vectorised one against.

Wire values vs counts: ``frames`` arrays hold what travels on the wire (0..255
for iCub, 0..65535 for cyskin16); :func:`icub_wire_to_counts` and
:func:`icub_counts_to_wire` convert explicitly.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from ..errors import InputError
from .frames import REASONS, FrameBatch
from .icub_ids import icub_taxel_id

_HERE = Path(__file__).resolve().parent
R = {r: i for i, r in enumerate(REASONS)}  # reason -> code

# iCub skin constants (formats/icub_skin.md)
ICUB_NOLOAD = 240
ICUB_SHIFT = 2
ICUB_CLASSES = (4, 3)
ICUB_HEADERS = (0x40, 0xC0)
ICUB_ERRORS = {0: "ok", 1: "no_acknowledge", 2: "not_connected"}


def icub_counts_to_wire(counts, noload: int = ICUB_NOLOAD, shift: int = ICUB_SHIFT) -> np.ndarray:
    """What an MTB board sends for compensated counts ``v = raw16 - cap_offset - drift``.

    counts : array, sensor counts (>= 0 when pressed). Returns uint8 ``clip(noload - (v >> shift), 0, 255)``
    (``>>`` is an arithmetic shift: floor division by ``2**shift``, as on the board).
    """
    v = np.floor(np.asarray(counts, np.float64)).astype(np.int64)
    return np.clip(noload - (v >> shift), 0, 255).astype(np.uint8)


def icub_wire_to_counts(wire, noload: int = ICUB_NOLOAD, shift: int = ICUB_SHIFT) -> np.ndarray:
    """Inverse of :func:`icub_counts_to_wire` up to its quantisation (``2**shift`` counts).

    Returns float counts ``(noload - wire) * 2**shift``: the lower end of the bin,
    so ``counts - 2**shift < result <= counts`` wherever the wire value did not clip.
    """
    return (noload - np.asarray(wire, np.float64)) * float(1 << shift)


def icub_wire_to_response(wire) -> np.ndarray:
    """The host convention ``255 - wire`` (baseline not removed): grows with pressure."""
    return 255.0 - np.asarray(wire, np.float64)


class Codec:
    """Base of the codecs (see the module docstring for the model)."""

    name = ""
    n_channels = 0
    wire_max = 0
    wire_dtype = np.uint8
    rest_value = 0         # what an absent or masked channel is encoded as
    full_dlc = 8           # a frame this long carries every channel of its stream
    default_period = 0.05  # s, 20 Hz

    def classify(self, batch: FrameBatch) -> tuple[np.ndarray, np.ndarray]:
        """``keys (M,) int64`` (-1 if rejected) and ``reason (M,) int8`` (index into REASONS, -1 ok)."""
        raise NotImplementedError

    def channel_ids(self, keys: np.ndarray) -> np.ndarray:
        """``(K, n_channels) int64`` taxel UIDs of each stream's channels, -1 where none."""
        raise NotImplementedError

    def unit(self, keys: np.ndarray) -> np.ndarray:
        """``(K,)`` the triangle or module a stream belongs to (error masking)."""
        raise NotImplementedError

    def values(self, batch: FrameBatch) -> np.ndarray:
        """``(M, n_channels)`` wire values, read from the payload matrix without a Python loop."""
        raise NotImplementedError

    def present(self, batch: FrameBatch, keys: np.ndarray) -> np.ndarray:
        """``(M, n_channels) bool``: channels that the frame's DLC actually carries."""
        return self.present_dlc(batch.dlc, keys)

    def present_dlc(self, dlc: np.ndarray, keys: np.ndarray) -> np.ndarray:
        """``(M, n_channels) bool`` for frames of streams ``keys`` with ``dlc`` data bytes."""
        raise NotImplementedError

    def diagnostics(self, batch: FrameBatch, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``error (M,) int8`` (-1 when the frame has none) and ``outofrange (M,) uint16``."""
        m = len(batch)
        return np.full(m, -1, np.int8), np.zeros(m, np.uint16)

    def streams_for(self, taxel_ids) -> np.ndarray:
        """Sorted keys of the streams that carry any of ``taxel_ids`` (for encoding)."""
        raise NotImplementedError

    def frame_of(self, keys: np.ndarray, values: np.ndarray, extra=None) -> tuple:
        """``ids (K,), extended (K,), dlc (K,), data (K, 8)`` of one frame per stream."""
        raise NotImplementedError

    def reference_decode(self, msg) -> tuple[int, dict[int, int], int]:
        """One ``can.Message`` through cantools: ``(key, {taxel_id: wire}, error)``; key -1 if rejected."""
        raise NotImplementedError


class IcubCodec(Codec):
    """The iCub skin (MTB) protocol of ``formats/icub_skin.md``.

    Key of a stream: ``(board * 16 + triangle) * 2 + half`` with half 0 for the
    0x40 frame (slots 0..6) and 1 for the 0xC0 frame (slots 7..11 and diagnostics).
    Identifier classes 4 and 3 are both accepted (``classes``) and mean the same
    triangle. Encoding uses ``classes[0]``.
    """

    name = "icub"
    n_channels = 7
    wire_max = 255
    wire_dtype = np.uint8
    rest_value = ICUB_NOLOAD

    def __init__(self, classes=ICUB_CLASSES):
        self.classes = tuple(int(c) for c in classes)

    def classify(self, batch):
        ids = batch.ids.astype(np.int64)
        cls = ids >> 8
        reason = np.full(len(batch), -1, np.int8)
        ok_id = np.isin(cls, self.classes) & ~batch.extended & (ids < 0x800)
        reason[~ok_id] = R["unknown_id"]
        head = batch.data[:, 0]
        half = (head == 0xC0).astype(np.int64)
        dlc = batch.dlc
        todo = reason < 0
        reason[todo & (dlc == 0)] = R["short_dlc"]
        todo = reason < 0
        reason[todo & (head != 0x40) & (head != 0xC0)] = R["bad_header"]
        todo = reason < 0
        # frame 0x40 carries 7 taxels (8 bytes); 0xC0 carries 5 (6 bytes, 8 with diagnostics)
        need = np.where(half == 0, 8, 6)
        reason[todo & (dlc < need)] = R["short_dlc"]
        keys = np.where(reason < 0, (((ids >> 4) & 0xF) * 16 + (ids & 0xF)) * 2 + half, -1)
        return keys, reason

    def channel_ids(self, keys):
        keys = np.asarray(keys, np.int64)
        tri_global = keys >> 1
        half = keys & 1
        board, tri = tri_global >> 4, tri_global & 0xF
        slot = np.arange(7)[None, :] + 7 * half[:, None]
        ids = icub_taxel_id(board[:, None], tri[:, None], slot)
        return np.where(slot < 12, ids, -1)

    def unit(self, keys):
        return np.asarray(keys, np.int64) >> 1

    def values(self, batch):
        return batch.data[:, 1:8]

    def present_dlc(self, dlc, keys):
        half = np.asarray(keys) & 1
        n = np.minimum(np.where(half == 0, 7, 5), np.asarray(dlc, np.int64) - 1)
        return np.arange(7)[None, :] < n[:, None]

    def diagnostics(self, batch, keys):
        has = ((np.asarray(keys) & 1) == 1) & (batch.dlc >= 8) & (np.asarray(keys) >= 0)
        d6 = batch.data[:, 6].astype(np.uint16)
        d7 = batch.data[:, 7].astype(np.uint16)
        err = np.where(has, (d7 & 0x0F).astype(np.int8), np.int8(-1))  # numpy 2: -1 is no uint16
        oor = np.where(has, (d6 << 4) | (d7 >> 4), 0).astype(np.uint16)
        return err, oor

    def streams_for(self, taxel_ids):
        t = np.asarray(taxel_ids, np.int64)
        tri_global = t // 12
        slot = t % 12
        return np.unique(tri_global * 2 + (slot >= 7))

    def frame_of(self, keys, values, extra=None):
        """values : (K, 7) wire values of each stream's channels. extra: ``(error, outofrange)`` per key."""
        keys = np.asarray(keys, np.int64)
        k = len(keys)
        tri_global, half = keys >> 1, keys & 1
        ids = (self.classes[0] << 8) | ((tri_global >> 4) << 4) | (tri_global & 0xF)
        data = np.zeros((k, 8), np.uint8)
        data[:, 0] = np.where(half == 0, 0x40, 0xC0)
        data[:, 1:8] = np.asarray(values)[:, :7]
        err = np.zeros(k, np.int64) if extra is None else np.asarray(extra[0], np.int64)
        oor = np.zeros(k, np.int64) if extra is None else np.asarray(extra[1], np.int64)
        h1 = half == 1
        data[h1, 6] = (oor[h1] >> 4) & 0xFF
        data[h1, 7] = ((oor[h1] & 0x0F) << 4) | (err[h1] & 0x0F)
        return ids.astype(np.uint32), np.zeros(k, bool), np.full(k, 8, np.uint8), data

    @functools.cached_property
    def _db(self):
        import cantools

        return cantools.database.load_file(str(_HERE / "icub_skin.dbc"))

    def reference_decode(self, msg):
        cid = msg.arbitration_id
        if msg.is_extended_id or (cid >> 8) not in self.classes:
            return -1, {}, -1
        data = bytes(msg.data)
        if not data or data[0] not in ICUB_HEADERS:
            return -1, {}, -1
        half = int(data[0] == 0xC0)
        if len(data) < (8 if half == 0 else 6):
            return -1, {}, -1
        sig = self._db.decode_message(0x400, data, decode_choices=False, allow_truncated=True)
        board, tri = (cid >> 4) & 0xF, cid & 0xF
        out = {int(icub_taxel_id(board, tri, s)): int(sig[f"t{s:02d}"])
               for s in (range(7) if half == 0 else range(7, 12))}
        return (board * 16 + tri) * 2 + half, out, int(sig.get("error", -1))


class Cyskin16Codec(Codec):
    """cyskin16: 16-bit raw counts of CySkin modules, specified by ``cyskin16.dbc``.

    The DBC's three template messages (module 0) give the identifier of each
    frame, and which sensor each 16-bit little-endian channel carries; the
    module UID is added at ``CySkinModuleShift`` (4), so an identifier's low
    bits are the UID ``module << 4 | sensor`` of its first channel. Sensor 0 is
    the module's temperature and is not a taxel. Key of a stream: ``module * 3 + frame``.
    """

    name = "cyskin16"
    n_channels = 4
    wire_max = 65535
    wire_dtype = np.uint16
    rest_value = 0

    def __init__(self, dbc: str | Path | None = None):
        import cantools

        self.dbc_path = Path(dbc) if dbc else _HERE / "cyskin16.dbc"
        try:
            self._db = cantools.database.load_file(str(self.dbc_path))
        except Exception as exc:  # cantools raises several parser error types
            raise InputError(f"cannot read DBC: {exc}", file=self.dbc_path) from None
        attrs = self._db.dbc.attributes if self._db.dbc else {}
        self.base = int(attrs["CySkinIdBase"].value) if "CySkinIdBase" in attrs else 0x18000000
        self.shift = int(attrs["CySkinModuleShift"].value) if "CySkinModuleShift" in attrs else 4
        msgs = sorted(self._db.messages, key=lambda m: m.frame_id)
        self.templates = [m.frame_id for m in msgs]
        first = np.array([m.frame_id - self.base for m in msgs], np.int64)
        if len(msgs) == 0 or np.any(first < 0) or np.any(first >= (1 << self.shift)):
            raise InputError("template messages must have identifiers base + first_sensor", file=self.dbc_path)
        # sensor carried by each channel (16-bit slot) of each template, from the signals
        self.sensor = np.full((len(msgs), 4), -1, np.int64)
        for f, m in enumerate(msgs):
            for s in m.signals:
                if s.length != 16 or s.byte_order != "little_endian" or s.start % 16:
                    raise InputError(f"signal {s.name} of {m.name} is not a 16-bit little-endian channel",
                                     file=self.dbc_path)
                sensor = 0 if s.name == "temperature" else int(s.name.lstrip("s"))
                self.sensor[f, s.start // 16] = sensor
        self.n_frames = len(msgs)
        self._first_lut = np.full(1 << self.shift, -1, np.int64)
        self._first_lut[first] = np.arange(len(msgs))
        # minimum DLC per template: bytes up to the last channel that is always present
        # (the last template may stop after sensor 10: DLC 6 for a 10-taxel module).
        self.min_dlc = np.array([8] * (len(msgs) - 1) + [6], np.int64)
        self.temperature_sensor = 0

    def classify(self, batch):
        ids = batch.ids.astype(np.int64)
        rel = ids - self.base
        module = rel >> self.shift
        low = rel & ((1 << self.shift) - 1)
        frame = np.where(rel >= 0, self._first_lut[low], -1)
        ok = batch.extended & (rel >= 0) & (module < (1 << 20)) & (frame >= 0)
        reason = np.full(len(batch), -1, np.int8)
        reason[~ok] = R["unknown_id"]
        need = self.min_dlc[np.where(frame >= 0, frame, 0)]
        reason[(reason < 0) & (batch.dlc < need)] = R["short_dlc"]
        keys = np.where(reason < 0, module * self.n_frames + frame, -1)
        return keys, reason

    def channel_ids(self, keys):
        keys = np.asarray(keys, np.int64)
        module, frame = keys // self.n_frames, keys % self.n_frames
        sensor = self.sensor[frame]
        ok = (sensor > 0)
        return np.where(ok, (module[:, None] << self.shift) | sensor, -1)

    def unit(self, keys):
        return np.asarray(keys, np.int64) // self.n_frames

    def values(self, batch):
        # the payload matrix read as little-endian uint16: np.frombuffer-style view, no copy
        return batch.data.view("<u2")

    def present_dlc(self, dlc, keys):
        return np.arange(4)[None, :] * 2 + 2 <= np.asarray(dlc, np.int64)[:, None]

    def streams_for(self, taxel_ids):
        t = np.asarray(taxel_ids, np.int64)
        module, sensor = t >> self.shift, t & ((1 << self.shift) - 1)
        keys = []
        for f in range(self.n_frames):  # loop over the 3 templates, not over taxels
            hit = np.isin(sensor, self.sensor[f][self.sensor[f] > 0])
            keys.append(module[hit] * self.n_frames + f)
        return np.unique(np.concatenate(keys)) if keys else np.zeros(0, np.int64)

    def frame_of(self, keys, values, extra=None):
        """values : (K, 4) wire values; channels without a taxel UID (-1) are not sent at the end
        of the last frame (DLC 6 for a 10-taxel module), and sent as 0 elsewhere."""
        keys = np.asarray(keys, np.int64)
        module, frame = keys // self.n_frames, keys % self.n_frames
        ids = self.base + (module << self.shift) + (np.array(self.templates, np.int64)[frame] - self.base)
        vals = np.clip(np.asarray(values, np.int64), 0, 65535).astype("<u2")
        data = np.ascontiguousarray(vals).view(np.uint8).reshape(len(keys), 8)
        dlc = np.full(len(keys), 8, np.uint8)
        if extra is not None:  # extra: (K,) number of channels actually carried
            dlc = (2 * np.asarray(extra, np.int64)).astype(np.uint8)
        return ids.astype(np.uint32), np.ones(len(keys), bool), dlc, data

    def reference_decode(self, msg):
        cid = msg.arbitration_id
        rel = cid - self.base
        if not msg.is_extended_id or rel < 0 or (rel >> self.shift) >= (1 << 20):
            return -1, {}, -1
        frame = self._first_lut[rel & ((1 << self.shift) - 1)]
        if frame < 0 or len(msg.data) < self.min_dlc[frame]:
            return -1, {}, -1
        module = rel >> self.shift
        sig = self._db.decode_message(self.templates[frame], bytes(msg.data), decode_choices=False,
                                      allow_truncated=True)
        out = {}
        for name, v in sig.items():
            if name == "temperature":
                continue
            out[(module << self.shift) | int(name.lstrip("s"))] = int(v)
        return int(module * self.n_frames + frame), out, -1


def get_codec(name: str) -> Codec:
    """``"icub"`` or ``"cyskin16"``."""
    if name == "icub":
        return IcubCodec()
    if name == "cyskin16":
        return Cyskin16Codec()
    raise InputError(f"unknown codec {name!r}; valid codecs: icub, cyskin16", key="codec")
