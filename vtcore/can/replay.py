"""Replaying a log onto a python-can bus in real or scaled time."""

from __future__ import annotations

import time

from ..errors import InputError
from .frames import Summary
from .logs import iter_batches


def open_bus(channel: str = "vtcore", interface: str | None = None):
    """A python-can bus. ``interface`` None: ``socketcan`` for channels named ``vcan*``/``can*``
    when the kernel has SocketCAN, the in-process ``virtual`` bus otherwise.

    Note: the ``virtual`` bus reaches listeners in the same process only; for other processes
    use ``socketcan`` (``ip link add dev vcan0 type vcan``) or python-can's ``udp_multicast``.
    """
    import can

    if interface is None:
        interface = "virtual"
        if channel.startswith(("vcan", "can")):
            import socket

            if hasattr(socket, "AF_CAN"):
                interface = "socketcan"
    try:
        return can.Bus(interface=interface, channel=channel, receive_own_messages=False)
    except (OSError, can.CanError, ValueError, ImportError) as exc:
        raise InputError(f"cannot open CAN bus {interface}:{channel}: {exc}", key="channel") from None


def replay(path, channel: str = "vtcore", speed: float = 1.0, interface: str | None = None, bus=None,
           chunk: int = 4096, summary: Summary | None = None, clock=time.perf_counter, sleep=time.sleep) -> dict:
    """Send every frame of the log at ``path`` onto a bus, keeping the log's timing scaled by ``speed``.

    speed : 1.0 real time, 2.0 twice as fast, 0 (or inf) as fast as possible. Frames whose
    timestamp goes backwards are sent at once. The log is streamed (one chunk in memory).
    bus : an open python-can bus to use (not closed here); otherwise one is opened with
    :func:`open_bus` and closed at the end. Returns ``{"frames_sent", "seconds", "lag_max_s",
    "log_seconds"}`` and fills ``summary`` with what could not be read.
    """
    if speed < 0:
        raise InputError(f"speed must be >= 0, got {speed}", key="speed")
    summary = summary if summary is not None else Summary()
    own = bus is None
    if own:
        bus = open_bus(channel, interface)
    sent, lag_max, t_first, t_last = 0, 0.0, None, None
    start = clock()
    try:
        for batch in iter_batches(path, chunk=chunk, summary=summary):
            for msg in batch.to_messages(channel=None):
                if t_first is None:
                    t_first = msg.timestamp
                t_last = msg.timestamp
                if speed and speed != float("inf"):
                    due = start + (msg.timestamp - t_first) / speed
                    wait = due - clock()
                    if wait > 0:
                        sleep(wait)
                    else:
                        lag_max = max(lag_max, -wait)
                bus.send(msg)
                sent += 1
    finally:
        if own:
            bus.shutdown()
    summary.frames_read += sent
    return {"frames_sent": sent, "seconds": clock() - start, "lag_max_s": lag_max,
            "log_seconds": 0.0 if t_first is None else t_last - t_first}
