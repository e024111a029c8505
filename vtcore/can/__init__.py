"""CAN transport of skin data: codecs, python-can logs, streaming decode, replay, recordings.

python-can and cantools are imported inside the functions that need them.

Main entry points:

- :func:`decode_log` (log file -> :class:`DecodeResult` with ``timestamps (T,)``, ``frames (T, N)``
  wire values, ``mask (T, N)``, ``taxel_ids (N,)`` and a :class:`Summary` counting by reason);
- :func:`iter_batches` / :class:`StreamDecoder` / :func:`iter_decode` for logs larger than memory;
- :func:`encode` + :func:`write_log` (taxel time series -> frames -> log file);
- :func:`replay` (a log onto a python-can bus in real or scaled time);
- :func:`read_cyskin_txt` (CySkin text recordings joined to a layout by UID).
"""

from .codecs import (ICUB_NOLOAD, ICUB_SHIFT, Codec, Cyskin16Codec, IcubCodec, get_codec, icub_counts_to_wire,
                     icub_wire_to_counts, icub_wire_to_response)
from .icub_ids import describe_icub_ids, icub_board_ids, icub_taxel_id
from .decode import Block, DecodeResult, StreamDecoder, collect, decode_batches, estimate_period, iter_decode
from .encode import encode
from .frames import REASONS, FrameBatch, Summary
from .logs import FORMATS, iter_batches, read_log, write_log
from .api import decode_log, encode_to_log, layout_taxel_ids, load_frames_npz, save_frames_npz
from .recording import read_cyskin_txt
from .replay import replay

__all__ = [
    "Codec", "IcubCodec", "Cyskin16Codec", "get_codec", "ICUB_NOLOAD", "ICUB_SHIFT", "icub_taxel_id",
    "icub_counts_to_wire", "icub_board_ids", "describe_icub_ids", "icub_wire_to_counts", "icub_wire_to_response", "FrameBatch", "Summary", "REASONS",
    "Block", "DecodeResult", "StreamDecoder", "iter_decode", "collect", "decode_batches", "estimate_period",
    "encode", "FORMATS", "iter_batches", "read_log", "write_log", "decode_log", "encode_to_log",
    "layout_taxel_ids", "save_frames_npz", "load_frames_npz", "read_cyskin_txt", "replay",
]
