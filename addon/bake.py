"""Baked contacts and loaded recordings: per-frame values stored with the .blend and played back.

The cache of a taxel object is a separate mesh datablock (``Object.vtskin.cache``,
fake user so it is saved) with one vertex per taxel and one point attribute per
baked frame and quantity: ``pressure_00012``, ``response_00012``, ``edge_00012``
(a contact bake); ``response``, ``response_compensated``, ``edge`` and ``held`` (a
recording, see ``ops.VTSKIN_OT_load_recording``).
Playback copies one frame's attributes to the taxel object with two
``foreach_get``/``foreach_set`` calls per quantity: nothing is recomputed.
"""

from __future__ import annotations

import bpy
import numpy as np

from . import bridge

QUANTITIES = ("pressure", "response", "response_compensated", "edge", "held")


def _key(name: str, frame: int) -> str:
    return f"{name}_{frame:05d}"


#: ID property of a cache whose frames share stored values: the frame whose attributes each
#: frame shows (one int per frame from ``bake_start``)
SHOWS = "vtskin_shows"


def store(ob, frames, rows=None, **series):
    """Store a bake on taxel object ``ob``.

    frames : (T,) int consecutive scene frames. series : name -> (T, N) array for the names
    in QUANTITIES (``edge``, ``held`` bool). rows : optional (T,) int, the recorded row each
    frame shows: frames that show the same row as an earlier frame store nothing and point
    at it (a recording slower than the scene's frame rate is kept once, not once per frame).
    Replaces any previous cache of ``ob``.
    """
    n = len(ob.data.vertices)
    frames = np.asarray(frames, dtype=np.int64)
    keep = np.arange(len(frames))
    shows = None
    if rows is not None:
        rows = np.asarray(rows, dtype=np.int64)
        _, keep, inverse = np.unique(rows, return_index=True, return_inverse=True)
        shows = frames[keep][inverse.reshape(-1)]
    old = ob.vtskin.cache
    cache = bpy.data.meshes.new(f"{ob.name} bake")
    cache.vertices.add(n)
    cache.use_fake_user = True
    for name, values in series.items():
        values = np.asarray(values)
        if values.shape != (len(frames), n):
            raise ValueError(f"bake {name}: shape {values.shape}, expected {(len(frames), n)}")
        kind = "BOOLEAN" if values.dtype == bool else "FLOAT"
        for i in keep:
            bridge.set_attribute(cache, _key(name, int(frames[i])), values[i], kind)
    if shows is not None and len(keep) < len(frames):
        cache[SHOWS] = [int(f) for f in shows]
    ob.vtskin.cache = cache
    ob.vtskin.bake_start = int(frames.min()) if len(frames) else 0
    ob.vtskin.bake_end = int(frames.max()) if len(frames) else -1
    if old is not None:
        old.use_fake_user = False
        if old.users == 0:
            bpy.data.meshes.remove(old)


def clear(ob):
    cache = ob.vtskin.cache
    ob.vtskin.cache = None
    ob.vtskin.bake_end = ob.vtskin.bake_start - 1
    if cache is not None:
        cache.use_fake_user = False
        if cache.users == 0:
            bpy.data.meshes.remove(cache)


def remap(ob, kept):
    """Keep the bake of taxel object ``ob`` across a layout edit: the new taxel i shows what old
    taxel ``kept[i]`` showed (-1: a new or moved taxel, whose baked values no longer hold: zero,
    False). Every cached attribute is rewritten for the new taxel count."""
    old = ob.vtskin.cache
    kept = np.asarray(kept, np.int64)
    if old is None:
        return
    n_old = len(old.vertices)
    if (kept >= n_old).any():
        clear(ob)
        return
    cache = bpy.data.meshes.new(old.name)
    cache.vertices.add(len(kept))
    cache.use_fake_user = True
    ok = kept >= 0
    for attr in list(old.attributes):
        if attr.domain != "POINT" or attr.name == "position" or attr.name.startswith("."):
            continue
        values = bridge.get_attribute(old, attr.name)
        out = np.zeros((len(kept),) + values.shape[1:], values.dtype)
        out[ok] = values[kept[ok]]
        bridge.set_attribute(cache, attr.name, out, attr.data_type)
    if SHOWS in old:
        cache[SHOWS] = list(old[SHOWS])
    ob.vtskin.cache = cache
    old.use_fake_user = False
    if old.users == 0:
        bpy.data.meshes.remove(old)


def frame_values(ob, frame: int) -> dict:
    """The cached arrays of ``frame`` (clamped to the baked range): name -> (N,)."""
    s = ob.vtskin
    f = min(max(int(frame), s.bake_start), s.bake_end)
    shows = s.cache.get(SHOWS)
    if shows is not None:
        f = int(shows[f - s.bake_start])
    out = {}
    for name in QUANTITIES:
        key = _key(name, f)
        if key in s.cache.attributes:
            out[name] = bridge.get_attribute(s.cache, key)
    return out


def apply(ob, frame: int):
    """Show the cached values of ``frame`` on taxel object ``ob``."""
    me = ob.data
    for name, values in frame_values(ob, frame).items():
        attr = me.attributes.get(name)
        if attr is None or len(attr.data) != len(values):
            continue
        key = "value"
        attr.data.foreach_set(key, values)
    me.update()


def apply_all(scene):
    for ob in scene.objects:
        s = getattr(ob, "vtskin", None)
        if s is None or s.role != "TAXELS" or s.cache is None or s.bake_end < s.bake_start:
            continue
        apply(ob, scene.frame_current)
