"""Output folders and files (docs/inputs.md): checked before any work (:func:`check_output_dir`,
:func:`check_output_file`); OS errors as InputErrors naming the path (:func:`os_error`); no NaN or
infinity written to JSON (:func:`finite_json`).
"""

from __future__ import annotations

import errno
import math
import os
from pathlib import Path

import numpy as np

from ..errors import InputError
from .text import clean

def check_output_dir(path, key: str = "--out") -> Path:
    """Check, before any work, that ``path`` can be an output folder.

    It must be a folder or not exist yet; its nearest existing parent must be a folder we
    can write into (no regular file on the way, not read-only). Nothing is created.
    """
    path = Path(path)
    shown = clean(path, 300)
    if path.exists() and not path.is_dir():
        raise InputError("exists and is a file, not a folder; name a folder", file=shown, key=key)
    probe = path
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if probe.exists() and not probe.is_dir():
        raise InputError(f"cannot be made: {clean(probe, 300)} is a file, not a folder", file=shown, key=key)
    if probe.exists() and not os.access(probe, os.W_OK | os.X_OK):
        raise InputError(f"cannot write into {clean(probe, 300)} (permission denied)", file=shown, key=key)
    return path


def check_output_file(path, key: str = "--out") -> Path:
    """Check, before any work, that a file can be written at ``path`` (its folder may be made)."""
    path = Path(path)
    if path.is_dir():
        raise InputError("is a folder; name a file", file=clean(path, 300), key=key)
    check_output_dir(path.parent, key=key)
    return path


def os_error(exc: OSError, path, key: str | None = None) -> InputError:
    """An OSError of writing as an InputError naming the path (read-only folder, disk full...)."""
    reason = exc.strerror or str(exc)
    if exc.errno == errno.ENOTDIR:
        reason = "a part of the path is a file, not a folder"
    return InputError(f"cannot write: {reason}", file=clean(path, 300), key=key)


def finite_json(obj, where: str = ""):
    """Raise InputError if ``obj`` (JSON-ready: dicts, lists, numbers) holds NaN or infinity.

    Writers call it before writing: JSON has no NaN, and a text file with ``nan`` is
    not re-readable by the readers that refuse it.
    """
    if not where:
        import json

        try:  # the common case, at C speed: plain JSON types, all finite
            json.dumps(obj, allow_nan=False)
            return
        except (ValueError, TypeError, RecursionError):
            pass  # a non-finite number (found and named below) or numpy values the walk handles
    if isinstance(obj, float) or isinstance(obj, np.floating):
        if not math.isfinite(obj):
            raise InputError(f"is {obj}; refusing to write a non-finite number", key=where or None)
    elif isinstance(obj, dict):
        for k, v in obj.items():
            finite_json(v, f"{where}.{k}" if where else str(k))
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            finite_json(v, f"{where}[{i}]")
    elif isinstance(obj, np.ndarray) and obj.dtype.kind == "f" and not np.isfinite(obj).all():
        raise InputError("holds NaN or infinity; refusing to write a non-finite number", key=where or None)
