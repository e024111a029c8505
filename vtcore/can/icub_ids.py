"""iCub skin taxel ids on the wire, in one place: ``192 * board + 12 * triangle + slot``.

An MTB board (4-bit CAN address) carries up to 16 triangles of 12 taxel slots, so
its taxels are one block of 192 ids. The codec, the summary of a decode and the
layout mapping use these functions and constants rather than the arithmetic.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

SLOTS_PER_TRIANGLE = 12
TRIANGLES_PER_BOARD = 16
TAXELS_PER_BOARD = SLOTS_PER_TRIANGLE * TRIANGLES_PER_BOARD  # 192


def icub_taxel_id(board, triangle, slot):
    """``192 * board + 12 * triangle + slot``: the row of an iCub positions file (per board block)."""
    return (TAXELS_PER_BOARD * np.asarray(board, np.int64) + SLOTS_PER_TRIANGLE * np.asarray(triangle, np.int64)
            + np.asarray(slot, np.int64))


def icub_board_ids(ids, boards) -> np.ndarray:
    """Wire taxel ids of the rows of an iCub positions file whose 192-row blocks are boards ``boards``.

    ids : (N,) int, rows of the positions file (a layout read from it has ``taxel_ids`` = row).
    boards : sequence of board addresses (0..15), one per 192-row block, in file order: ``[3]``
    for a file of board 3, ``[14, 13]`` for a file whose rows 0..191 are board 14 and rows
    192..383 board 13. Returns ``192 * boards[row // 192] + row % 192``.
    """
    ids = np.asarray(ids, np.int64).reshape(-1)
    b = np.asarray(boards, np.int64).reshape(-1)
    if len(b) == 0:
        raise InputError("boards lists no board address", key="boards")
    if b.min() < 0 or b.max() > 15:
        raise InputError(f"board addresses are 4 bits (0..15), got {b.tolist()}", key="boards")
    if len(np.unique(b)) != len(b):
        raise InputError(f"a board address is listed twice in {b.tolist()}", key="boards")
    if len(ids) == 0:
        return ids
    if ids.min() < 0:
        raise InputError(f"taxel id {int(ids.min())} is not a row of a positions file", key="taxel_ids")
    block = ids // TAXELS_PER_BOARD
    if block.max() >= len(b):
        top = int(block.max())
        raise InputError(f"taxel id {int(ids.max())} is in rows {192 * top}..{192 * top + 191} (block {top}) of "
                         f"the positions file, but boards lists {len(b)} board address(es) {b.tolist()}; "
                         "give one address per 192-row block", key="boards")
    return TAXELS_PER_BOARD * b[block] + ids % TAXELS_PER_BOARD


def describe_icub_ids(ids) -> str:
    """``board 3: triangles 0-5 (72 taxels)`` for a set of iCub wire taxel ids (reports)."""
    ids = np.unique(np.asarray(list(ids), np.int64))
    parts = []
    board_of = ids // TAXELS_PER_BOARD
    for board in np.unique(board_of):
        tri = np.unique((ids[board_of == board] % TAXELS_PER_BOARD) // SLOTS_PER_TRIANGLE)
        runs, start = [], tri[0]
        for a, b in zip(tri, np.r_[tri[1:], -1]):   # at most 16 triangles per board
            if b != a + 1:
                runs.append(f"{start}" if start == a else f"{start}-{a}")
                start = b
        parts.append(f"board {int(board)}: triangle{'s' if len(tri) > 1 else ''} {', '.join(runs)} "
                     f"({int((board_of == board).sum())} taxels)")
    return "; ".join(parts)
