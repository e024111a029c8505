"""From taxel time series to the frames a skin would put on the bus."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..inputs import float_array, int_array, need_memory
from .codecs import Codec
from .frames import MAX_TIMESTAMP_S, FrameBatch

#: Largest taxel id each codec can address: iCub 16 boards x 16 triangles x 12 taxels (11-bit ids);
#: cyskin16 2**20 modules x 16 sensors (29-bit ids, the classify() limit).
MAX_TAXEL_ID = {"icub": 16 * 192 - 1, "cyskin16": (1 << 24) - 1}


def encode(timestamps, frames, taxel_ids, codec: Codec, mask=None, frame_gap: float = 1e-4,
           errors=None) -> FrameBatch:
    """Frames of a skin that sampled ``frames`` at ``timestamps``.

    timestamps : (T,) s. frames : (T, N) wire values (0..255 iCub, 0..65535 cyskin16; rounded
    and clipped). taxel_ids : (N,) the UID of each column. mask : (T, N) bool or None; a frame
    whose channels are all masked is not sent (a missing frame), masked channels of a sent
    frame carry the codec's rest value. Channels of a stream that no column provides (iCub
    thermal pads, taxels outside ``taxel_ids``) carry the rest value too; a cyskin16 module
    without sensor 11 sends its last frame with DLC 6.
    frame_gap : s between consecutive frames of one period (one 8-byte frame at 1 Mbit/s
    takes about 0.11 ms). errors : optional dict ``{(row, unit): code}`` (iCub diagnostics).
    Returns a :class:`FrameBatch` in time order.
    """
    ts = float_array(timestamps, key="timestamps").reshape(-1)  # a NaN time would be written as "(nan)"
    if len(ts) and np.abs(ts).max() > MAX_TIMESTAMP_S:
        raise InputError(f"must be within +-{MAX_TIMESTAMP_S:g} s, got {np.abs(ts).max():g}", key="timestamps")
    f = float_array(frames, finite=False, key="frames")
    if f.ndim != 2 or f.shape[0] != len(ts):
        raise InputError(f"frames must be (T, N) with T = {len(ts)}, got {f.shape}", key="frames")
    # ids past the codec's address space would wrap onto the identifiers of real taxels
    ids = int_array(taxel_ids, lo=0, hi=MAX_TAXEL_ID.get(codec.name, (1 << 32) - 1), key="taxel_ids").reshape(-1)
    if len(ids) != f.shape[1]:
        raise InputError(f"taxel_ids has {len(ids)} entries, frames has {f.shape[1]} columns", key="taxel_ids")
    # (T, K, C) values and masks of every stream: refuse before allocating what cannot fit
    need_memory(8.0 * 3 * len(ts) * f.shape[1] * 2, key="frames", what=f"encoding {len(ts)} x {f.shape[1]} frames")
    if not np.all(np.isfinite(f)) and mask is None:
        raise InputError("frames has non-finite values and no mask", key="frames")
    m = np.ones(f.shape, bool) if mask is None else np.asarray(mask, bool).reshape(f.shape)
    wire = np.clip(np.rint(np.where(m, np.nan_to_num(f.astype(np.float64)), codec.rest_value)), 0, codec.wire_max)
    wire = wire.astype(np.int64)
    keys = codec.streams_for(ids)
    k, c, t_n = len(keys), codec.n_channels, len(ts)
    if k == 0 or t_n == 0:
        return FrameBatch.empty()
    ch = codec.channel_ids(keys)                         # (K, C) taxel ids
    order = np.argsort(ids, kind="stable")
    pos = np.clip(np.searchsorted(ids[order], ch), 0, max(len(ids) - 1, 0))
    col = np.where((ids[order][pos] == ch) & (ch >= 0), order[pos], -1)   # (K, C)
    vals = np.where(col[None] >= 0, wire[:, np.maximum(col, 0)], codec.rest_value)  # (T, K, C)
    got = np.where(col[None] >= 0, m[:, np.maximum(col, 0)], False)             # (T, K, C)
    vals = np.where(got | (col[None] < 0), vals, codec.rest_value)
    sent = got.any(axis=2)                                                      # (T, K)
    extra = None
    if codec.name == "cyskin16":
        # the last frame of a 10-taxel module stops after its last taxel channel
        last = np.where(col >= 0, np.arange(c)[None, :] + 1, 0).max(axis=1)
        base = np.where(keys % codec.n_frames == codec.n_frames - 1, np.maximum(last, 3), c)
        extra = base
    err_arr = None
    if codec.name == "icub":
        err_arr = (np.zeros((t_n, k), np.int64), np.zeros((t_n, k), np.int64))
        if errors:
            unit = codec.unit(keys)
            for (row, u), code in errors.items():  # a handful of injected diagnostics
                err_arr[0][row, unit == u] = code
    if err_arr is not None:
        # a triangle reporting an error still sends its frames (its samples are what the host masks)
        sent = sent | (err_arr[0] != 0)
    rr, kk = np.nonzero(sent)
    vv = vals[rr, kk]
    if codec.name == "icub":
        fid, fext, fdlc, fdata = codec.frame_of(keys[kk], vv, (err_arr[0][rr, kk], err_arr[1][rr, kk]))
    else:
        fid, fext, fdlc, fdata = codec.frame_of(keys[kk], vv, extra[kk])
    # frames of one period go out back to back, in stream order
    slot = kk  # stream index within the period
    if t_n > 1:  # keep a period's burst well inside the period, however many streams
        frame_gap = min(frame_gap, 0.25 * float(np.median(np.diff(ts))) / k)
    t = ts[rr] + slot * frame_gap
    o = np.lexsort((slot, rr))
    return FrameBatch(t[o], fid[o], fext[o], fdlc[o], fdata[o])
