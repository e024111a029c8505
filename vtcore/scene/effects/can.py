"""Transport effect ``can``: the sensor counts travel over CAN and come back as a host reads them.

Listed as ``[effects.can]`` (stage ``transport``); a task that sends its frames through
``ctx.pipeline.apply("transport", frames, ctx)`` gets them encoded into real frames of
the chosen codec and decoded again (``vtcore.can.encode`` then the vectorised decoder),
so the wire's quantisation and clipping apply exactly: iCub 8-bit inverted values
(``240 - (v >> 2)``: steps of 4 counts, 0..960 counts above baseline) and cyskin16
16-bit counts (rounded, 0..65535).
"""

from __future__ import annotations

import numpy as np

from ...layout.uids import cyskin_uids
from ..registry import EffectSpec, register_effect
from ..schema import Field, Section


class CanTransport:
    def __init__(self, p, ctx):
        from ...can import get_codec

        self.codec = get_codec(p["codec"])
        self.period = p["period"]

    def _ids(self, n: int) -> np.ndarray:
        j = np.arange(n)
        if self.codec.name == "icub":
            if n > 16 * 192:
                raise ValueError(f"the iCub protocol addresses at most 3072 taxels (16 boards), got {n}")
            return j
        return cyskin_uids(j // 10, j % 10 + 1)      # 10-taxel modules with UIDs 1, 2, ...

    def apply(self, frames, ctx):
        from ...can import decode_batches, encode, icub_counts_to_wire, icub_wire_to_counts

        f = np.asarray(frames, np.float64)
        one = f.ndim == 1
        f2 = f.reshape(1, -1) if one else f
        ids = self._ids(f2.shape[1])
        wire = icub_counts_to_wire(f2) if self.codec.name == "icub" else np.clip(np.rint(f2), 0, 65535)
        ts = np.arange(len(f2)) * self.period
        res = decode_batches(encode(ts, wire, ids, self.codec), self.codec, taxel_ids=ids, period=self.period)
        out = res.frames.astype(np.float64)
        out = icub_wire_to_counts(out) if self.codec.name == "icub" else out
        return out.reshape(f.shape)


register_effect(EffectSpec("can", "transport", 10, CanTransport, Section({
    "codec": Field("str", default="cyskin16", choices=("icub", "cyskin16"), doc="wire protocol"),
    "period": Field("float", default=0.05, gt=0, unit="s", doc="sampling period on the bus"),
}), doc="encode and decode the counts like the CAN wire (quantisation, clipping)"))
