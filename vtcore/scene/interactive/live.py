"""Live touch: the skin's pressure, response and edges follow an indenter as it moves, without a bake.

:class:`LiveTouch` holds what stays fixed while the user drags the indenter (the layer, the checked
indenter mesh and its search structure, the skin's contact grid and edge filter, the last solution
for a warm start) and answers one pose per :meth:`LiveTouch.update`: the same numbers
:func:`vtcore.scene.interactive.simulate` gives at that pose (the warm start changes them only below
the solver's tolerance). The add-on calls it on a background thread and writes the last answer on
the main thread, so dragging never waits for a solve (docs/evaluate.md, "Live touch").

A pose where the indenter cannot reach the target force (it is beside the skin, or would bottom out
through the layer) is no error while dragging: the frame reads zero and says why in ``note``.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np

from ...contact.objects import SIZE_RANGE_M
from ...errors import InputError
from ...layout import Layout
from .common import as_trimesh
from .contact import Contact, SkinEdges, sensor_response, soft_layer


@dataclass
class LiveFrame:
    """One live update: ``contact`` (:class:`Contact`), ``pose`` (4, 4) it answers, ``seconds`` the solve
    took, ``note`` (empty, or why the frame reads zero)."""

    contact: Contact
    pose: np.ndarray
    seconds: float
    note: str = ""


class LiveTouch:
    """Press an indenter on a skin pose after pose (see the module docstring).

    layout, triangles : the skin (skin frame, metres) and its skin mesh (F, 3). indenter_vertices (V, 3)
    m and indenter_triangles (G, 3): the indenter in its own frame. thickness (m), material, model
    ("local", "halfspace", "finite_layer"), force (N, or None: the pose as it is), counts_per_pa,
    edge_fraction, geometry: as :func:`vtcore.scene.interactive.simulate`.
    """

    def __init__(self, layout: Layout, triangles, indenter_vertices, indenter_triangles, *, thickness: float,
                 material: str = "ecoflex_00_20", model: str = "finite_layer", force: float | None = 5.0,
                 counts_per_pa: float | None = None, edge_fraction: float = 0.3, geometry: str = "plane"):
        from ...contact import MODELS

        if len(layout) == 0:
            raise InputError("the skin has no taxels", key="layout")
        if model not in MODELS:
            raise InputError(f"must be one of {', '.join(MODELS)}, got {model!r}", key="model")
        self.layout = layout
        self.layer = soft_layer(thickness, material)
        self.mesh = as_trimesh(indenter_vertices, indenter_triangles, SIZE_RANGE_M)
        self.model, self.geometry = model, geometry
        self.force = force if force else None
        self.counts_per_pa = None if counts_per_pa is None else float(counts_per_pa)
        self.edge_fraction = float(edge_fraction)
        self.skin_edges = SkinEdges(layout, triangles)
        self._last = None
        self._lock = threading.Lock()  # one solve at a time: the warm start is state

    def zero(self, pose, note: str = "") -> LiveFrame:
        n = len(self.layout)
        z = np.zeros(n)
        return LiveFrame(Contact(z, z.copy(), z.copy(), np.zeros(n, bool), 0.0, 0.0, 0.0),
                         np.asarray(pose, float), 0.0, note)

    def update(self, pose) -> LiveFrame:
        """The skin's readings with the indenter at ``pose`` (4, 4), its pose in the skin frame."""
        from ...contact import press
        from ...errors import UnreachableTargetError

        pose = np.asarray(pose, float).reshape(4, 4)
        t0 = time.perf_counter()
        with self._lock:
            try:
                res = press(self.layout, self.mesh, pose, self.layer, force=self.force, geometry=self.geometry,
                            model=self.model, warm_start=self._last)
            except UnreachableTargetError as exc:
                self._last = None
                frame = self.zero(pose, str(exc))
                frame.seconds = time.perf_counter() - t0
                return frame
            self._last = res if res.force > 0 else None
        response = sensor_response(res.pressure, self.counts_per_pa)
        er, edge = self.skin_edges.edges(response, self.edge_fraction)
        c = Contact(res.pressure, response, er, edge, float(res.force), float(res.indentation), float(res.contact_area))
        return LiveFrame(c, pose, time.perf_counter() - t0)


class LiveWorker:
    """One background thread that solves the latest requested pose of a :class:`LiveTouch`.

    ``request(pose)`` never blocks: it replaces any pose still waiting (only the newest matters while
    dragging); ``take()`` returns the newest finished :class:`LiveFrame` (or None) for the main thread
    to show. ``close()`` stops the thread. numpy, scipy's FFTs and open3d release the GIL during the
    solve, so the interface stays responsive.
    """

    def __init__(self, live: LiveTouch):
        self.live = live
        self._cond = threading.Condition()
        self._pose = None
        self._done = None
        self._error = None
        self._stop = False
        self._thread = threading.Thread(target=self._run, name="vtskin live touch", daemon=True)
        self._thread.start()

    def request(self, pose) -> None:
        with self._cond:
            self._pose = np.asarray(pose, float).copy()
            self._cond.notify()

    def take(self):
        """The newest finished frame since the last call, or None; re-raises a solve's error."""
        with self._cond:
            frame, self._done = self._done, None
            err, self._error = self._error, None
        if err is not None:
            raise err
        return frame

    def busy(self) -> bool:
        with self._cond:
            return self._pose is not None

    def _run(self):
        while True:
            with self._cond:
                while self._pose is None and not self._stop:
                    self._cond.wait()
                if self._stop:
                    return
                pose, self._pose = self._pose, None
            try:
                frame = self.live.update(pose)
            except Exception as exc:  # handed to the main thread by take(), which shows it
                with self._cond:
                    self._error = exc
                continue
            with self._cond:
                self._done = frame

    def close(self) -> None:
        with self._cond:
            self._stop = True
            self._cond.notify()
        self._thread.join(timeout=5.0)
