"""File output that is never half-written, and byte-reproducible array archives."""

from __future__ import annotations

import contextlib
import io
import os
import shutil
import signal
import tempfile
import threading
import zipfile

import numpy as np

class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C so temporary files and staging folders are removed on the way out."""


_TERMINATED = threading.Event()
_HELD = threading.Event()


@contextlib.contextmanager
def sigterm_raises():
    """While active (main thread only), SIGTERM raises :class:`Terminated` and is remembered.

    Remembered because a C extension that checks for signals may swallow the exception
    (seen: a run that ignored SIGTERM about 1 time in 3), and because during an import the
    exception is deferred; :func:`check_terminated` raises it at the next progress step and
    before a run commits its files.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        _TERMINATED.set()
        if _HELD.is_set():
            return  # inside sigterm_held(): the steps finish, the next check_terminated() raises
        f = frame
        while f is not None:
            # an exception raised inside the import of a C extension (open3d, ...) can crash the
            # interpreter: defer to the next check_terminated() (progress loops, the run's commit)
            if f.f_code.co_filename.startswith("<frozen importlib"):
                return
            f = f.f_back
        raise Terminated()

    _TERMINATED.clear()
    old = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)
        _TERMINATED.clear()


@contextlib.contextmanager
def sigterm_held():
    """Steps that must not be cut in half (making a staging folder, moving a run's files in):
    a SIGTERM that arrives meanwhile is only remembered, and :func:`check_terminated` raises it later.

    A flag the handler reads rather than ``pthread_sigmask``: the mask is per thread, and a
    signal delivered to a BLAS or pool thread still runs the Python handler in the main thread.
    """
    _HELD.set()
    try:
        yield
    finally:
        _HELD.clear()


def check_terminated() -> None:
    """Raise :class:`Terminated` if SIGTERM arrived under :func:`sigterm_raises`."""
    if _TERMINATED.is_set():
        raise Terminated()


@contextlib.contextmanager
def staged_into(final: str | os.PathLike, prefix: str = ".vtcore-", key: str = "--out"):
    """Write several files as one set: yield a new staging folder inside the folder ``final``; when
    the block ends without an exception, move every entry of it (files and folders) into ``final``,
    replacing what is there; on any exception (bad input, Ctrl-C, SIGTERM) remove it, and ``final``
    too if this call made it and nothing landed there. A refusal leaves nothing behind.

    The move is all or nothing with respect to SIGTERM (:func:`sigterm_held`): one that arrives
    before it stops it, one that arrives during it is raised once every entry is in.
    """
    from pathlib import Path

    from .inputs import check_output_dir, os_error

    final = check_output_dir(final, key=key)
    made = not final.exists()
    try:
        final.mkdir(parents=True, exist_ok=True)
        with sigterm_held():  # a SIGTERM between mkdtemp's mkdir and its return would orphan the folder
            stage = Path(tempfile.mkdtemp(prefix=prefix, dir=final))
    except OSError as exc:
        raise os_error(exc, final, key=key) from None
    try:
        yield stage
        with sigterm_held():
            check_terminated()
            try:
                for f in sorted(stage.iterdir()):
                    _move_in(f, final / f.name, stage)
            except OSError as exc:
                raise os_error(exc, final, key=key) from None
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        if made:
            with contextlib.suppress(OSError):
                final.rmdir()  # only if empty: a folder this call made and nothing landed in
        raise
    shutil.rmtree(stage, ignore_errors=True)


def _move_in(src, dst, stage) -> None:
    """Rename ``src`` onto ``dst``; a folder already at ``dst`` is first moved aside into ``stage``
    (``os.replace`` cannot replace a folder that holds files) and removed with it."""
    if src.is_dir() and dst.is_dir() and not dst.is_symlink():
        os.replace(dst, stage / f".old-{dst.name}")
    os.replace(src, dst)


# A fixed timestamp inside .npz members so that the same arrays give the same bytes.
_ZIP_EPOCH = (1980, 1, 1, 0, 0, 0)


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike, mode: str = "w", **kwargs):
    """Open ``path`` for writing through a temporary file renamed on success.

    On an exception the temporary file is removed and ``path`` keeps its old
    content (or stays absent).
    """
    from .inputs import check_output_file, os_error

    path = check_output_file(path, key="output")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:  # read-only folder, a file on the way, disk full: the path is named
        raise os_error(exc, path, key="output") from None
    os.close(fd)
    try:
        with open(tmp, mode, **kwargs) as fh:
            yield fh
        # mkstemp makes the file private (0600); give it the mode a plain open() would.
        os.chmod(tmp, 0o666 & ~_umask())
        try:
            os.replace(tmp, path)
        except OSError as exc:
            raise os_error(exc, path, key="output") from None
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def save_npz(path: str | os.PathLike, arrays: dict[str, np.ndarray], compress: bool = True) -> None:
    """Write ``arrays`` as an ``.npz`` that ``np.load`` reads, byte-identical for equal input.

    ``np.savez`` stamps each member with the current time; this writer uses a
    fixed timestamp and sorted names, so two runs with the same seed give the
    same file.
    """
    comp = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    with atomic_write(path, "wb") as fh:
        with zipfile.ZipFile(fh, "w", compression=comp) as zf:
            for name in sorted(arrays):
                buf = io.BytesIO()
                np.lib.format.write_array(buf, np.asanyarray(arrays[name]), allow_pickle=False)
                info = zipfile.ZipInfo(f"{name}.npy", date_time=_ZIP_EPOCH)
                info.compress_type = comp
                info.external_attr = 0o644 << 16
                zf.writestr(info, buf.getvalue())


def write_json(path: str | os.PathLike, obj, indent: int | None = 2) -> None:
    """Write ``obj`` as JSON atomically, refusing NaN and infinity (JSON has neither; Python's
    ``json`` would write the non-standard ``NaN`` token). Undefined numbers must be ``None``."""
    import json

    from .inputs import finite_json

    finite_json(obj)
    text = json.dumps(obj, indent=indent, allow_nan=False)
    with atomic_write(path, "w", encoding="utf-8") as fh:
        fh.write(text + "\n")


def write_xml(tree, path: str | os.PathLike, declaration: str = "") -> None:
    """Write the ElementTree ``tree`` as UTF-8 text (``declaration`` first, LF line ends, a final
    newline) atomically: the one serialiser of the URDF and MJCF files vtcore writes, fragments and
    robots alike, so the same tree is the same bytes whichever writes it."""
    with atomic_write(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(declaration)
        tree.write(fh, encoding="unicode", xml_declaration=False)
        fh.write("\n")
