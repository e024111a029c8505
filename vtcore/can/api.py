"""High-level calls used by the CLI and the scene task: log <-> FRAMES.npz."""

from __future__ import annotations


import numpy as np

from .._io import save_npz
from ..errors import FormatError, InputError
from ..inputs import check_input, clean, float_array, int_array
from .codecs import Codec, get_codec
from .icub_ids import SLOTS_PER_TRIANGLE, TAXELS_PER_BOARD, icub_board_ids, icub_taxel_id
from .decode import DecodeResult, collect, iter_decode
from .encode import encode
from .frames import Summary
from .logs import iter_batches, write_log


def layout_taxel_ids(layout, codec: str | Codec | None = None, boards=None) -> np.ndarray:
    """The wire taxel ids a decoder matches frames against, one per layout taxel (layout order).

    CySkin (cyskin16): ``layout.taxel_ids`` (``module_uid << 4 | sensor``) as they are.
    iCub: ``192 * board_address + 12 * triangle + slot``. A layout read from an iCub
    positions file has ``taxel_ids`` = row of the file, which is that only for board 0;
    which boards the rows belong to comes from, in this order:

    1. ``boards`` (CLI ``--boards``): board addresses, one per 192-row block of the file
       (``[3]``: the file is board 3; ``[14, 13]``: rows 0..191 board 14, 192..383 board 13);
    2. ``layout.meta["icub_boards"]``, the same list stored with the layout (a JSON layout
       can carry it);
    3. ``layout.can_ids`` (``board << 4 | triangle`` per taxel, -1 unknown): the slot is
       ``taxel_id % 12``;
    4. otherwise the ids are used as they are (rows 0..191 = board 0, 192..383 = board 1...).
    """
    name = codec if isinstance(codec, str) or codec is None else codec.name
    ids = np.asarray(layout.taxel_ids, np.int64)
    if name not in (None, "icub"):
        if boards is not None and len(boards):
            raise InputError("board addresses (--boards) apply to the icub codec only", key="boards")
        return ids
    if boards is None or not len(boards):
        boards = (layout.meta or {}).get("icub_boards")
    if boards is not None and len(boards):
        return icub_board_ids(ids, boards)
    can = getattr(layout, "can_ids", None)
    if name == "icub" and can is not None and np.any(can >= 0):
        if np.any(can > 0xFF):
            raise InputError(f"can_ids holds {int(can.max())}; iCub addresses are board << 4 | triangle "
                             "(0..255)", key="can_ids")
        return np.where(can >= 0, icub_taxel_id(can >> 4, can & 0xF, ids % SLOTS_PER_TRIANGLE), ids)
    return ids


def decode_log(path, codec: str | Codec = "icub", layout=None, taxel_ids=None, period: float | None = None,
               window: int = 8, chunk: int = 65536, boards=None) -> DecodeResult:
    """Decode a log file (any of :data:`~vtcore.can.logs.FORMATS`) to taxel time series.

    codec : "icub", "cyskin16" or a :class:`Codec`. layout : a Layout whose taxel order the
    columns follow (taxels the log lacks stay masked; decoded taxels the layout lacks are
    counted in ``summary.unmapped_*`` and reported). boards : iCub board addresses of the
    layout's 192-row blocks (see :func:`layout_taxel_ids`). Without a layout or ``taxel_ids``,
    one column per decoded taxel, sorted by UID. period : s, estimated from the log when None.
    The log is read in chunks of ``chunk`` frames.

    With a layout, ``taxel_ids`` of the result are the wire ids (what ``encode`` needs) and,
    when they differ from the layout's own ids, ``extra["layout_taxel_ids"]`` holds those.
    """
    codec = get_codec(codec) if isinstance(codec, str) else codec
    if layout is not None:
        taxel_ids = layout_taxel_ids(layout, codec, boards)
    elif boards is not None and len(boards):
        raise InputError("board addresses (--boards) need a layout (--layout) to apply to", key="boards")
    summary = Summary()
    from .._progress import progress

    batches = progress(iter_batches(path, chunk=chunk, summary=summary), desc=f"decoding {path}",
                       unit=f"x{chunk} frames")
    blocks = iter_decode(batches, codec, taxel_ids, period, window, summary)
    try:
        res = collect(blocks, codec, summary, taxel_ids)
    except InputError as exc:
        if exc.file is not None:
            raise
        raise InputError(exc.reason, file=path, key=exc.key, line=exc.line) from None
    if summary.frames_read == 0:
        summary.notes.append("the log holds no frames")
    if layout is not None:
        res.extra.update({"positions": layout.positions, "normals": layout.normals})
        if not np.array_equal(taxel_ids, layout.taxel_ids):
            res.extra["layout_taxel_ids"] = np.asarray(layout.taxel_ids, np.int64)
        if codec.name == "icub" and summary.unmapped_taxel_ids:
            seen = sorted({int(i) // TAXELS_PER_BOARD for i in summary.unmapped_taxel_ids})
            mapped = sorted({int(i) // TAXELS_PER_BOARD for i in np.asarray(taxel_ids)})
            other = [b for b in seen if b not in mapped]
            if other:
                summary.notes.append(f"the log has iCub board(s) {other} that the layout does not cover (it maps "
                                     f"board(s) {mapped}); for a positions file of another board pass its "
                                     "address (--boards, or meta icub_boards)")
    return res


def save_frames_npz(path, result: DecodeResult) -> None:
    """FRAMES.npz: ``timestamps (T,)``, ``frames (T, N)`` wire values, ``mask (T, N)``,
    ``taxel_ids (N,)``, ``unit_errors (E, 3)`` (row, triangle/module, code), ``codec`` (str)."""
    arrays = result.arrays()
    arrays["codec"] = np.array(result.codec)
    save_npz(path, arrays)


def load_frames_npz(path) -> dict:
    """Read a FRAMES.npz; checks the contract names, dtypes and shapes.

    ``timestamps`` finite seconds, ``frames`` numbers (NaN allowed where ``mask`` is False),
    ``taxel_ids`` integers in 0..2**32-1, ``mask`` booleans; FormatError naming the array otherwise.
    """
    path = check_input(path, "frames file")
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except Exception as exc:  # zipfile, numpy format and pickle errors all mean "not our file"
        raise FormatError(f"not a readable .npz: {clean(exc)}", file=path) from None
    for key in ("timestamps", "frames", "taxel_ids"):
        if key not in data:
            raise FormatError(f"missing array {key!r} (FRAMES.npz needs timestamps, frames, taxel_ids)",
                              file=path, key=key)
    try:
        data["timestamps"] = float_array(data["timestamps"], shape=(None,), file=path, key="timestamps")
        data["taxel_ids"] = int_array(data["taxel_ids"], dtype=np.uint32, file=path,
                                      key="taxel_ids").astype(np.int64).reshape(-1)
        data["frames"] = float_array(data["frames"], finite=False, file=path, key="frames")
        if "mask" in data and data["mask"].dtype != bool:
            raise FormatError(f"must be booleans, got dtype {data['mask'].dtype}", file=path, key="mask")
    except InputError as exc:
        raise FormatError(exc.reason, file=path, key=exc.key) from None
    t, f, ids = data["timestamps"], data["frames"], data["taxel_ids"]
    if f.ndim != 2 or f.shape != (len(t), len(ids)):
        raise FormatError(f"frames has shape {f.shape}, expected ({len(t)}, {len(ids)})", file=path, key="frames")
    if "mask" in data and data["mask"].shape != f.shape:
        raise FormatError(f"mask has shape {data['mask'].shape}, expected {f.shape}", file=path, key="mask")
    if np.isinf(f).any():
        raise FormatError("holds infinite values", file=path, key="frames")
    nan = np.isnan(f)
    if nan.any() and ("mask" not in data or (nan & data["mask"]).any()):
        raise FormatError("holds NaN where the mask says a sample was recorded", file=path, key="frames")
    return data


def encode_to_log(frames_npz_or_dict, codec: str | Codec, out, channel: str = "vcan0") -> int:
    """FRAMES.npz (or its dict) -> frames of ``codec`` -> log file ``out``. Returns frames written.

    iCub triangles that ``unit_errors`` marks as erroring are sent with that error code.
    """
    codec = get_codec(codec) if isinstance(codec, str) else codec
    data = load_frames_npz(frames_npz_or_dict) if not isinstance(frames_npz_or_dict, dict) else frames_npz_or_dict
    f = np.asarray(data["frames"])
    if np.nanmax(f, initial=0) > codec.wire_max or np.nanmin(f, initial=0) < 0:
        raise InputError(f"frames hold values outside the {codec.name} wire range 0..{codec.wire_max}; "
                         "convert counts to wire values first", key="frames")
    errs = None
    ue = data.get("unit_errors")
    if ue is not None and len(ue) and codec.name == "icub":
        errs = {(int(r), int(u)): int(c) for r, u, c in np.asarray(ue).reshape(-1, 3)}
    batch = encode(data["timestamps"], f, data["taxel_ids"], codec, mask=data.get("mask"), errors=errs)
    return write_log(out, batch, channel=channel)
