"""A long fill reports progress and can be stopped: keep_going, Job, and lay_patch(progress=...)
as the Blender Fill operator drives them (bpy-free)."""

import threading

import numpy as np
import pytest
import trimesh

from vtcore._progress import Job, keep_going
from vtcore.errors import Cancelled, VtError
from vtcore.scene.interactive import lay_patch


def test_keep_going():
    keep_going(None, 0.5)
    seen = []
    keep_going(lambda f: seen.append(f), 2.0)  # None is not a stop; the fraction is clipped to 0..1
    keep_going(lambda f: True, -1)
    assert seen == [1.0]
    with pytest.raises(Cancelled, match="the fill was cancelled") as err:
        keep_going(lambda f: False, 0.3, "the fill")
    assert isinstance(err.value, VtError)


def steps(n, progress=None, gate=None):
    for i in range(n):
        if gate is not None:
            gate.wait(5)
        keep_going(progress, (i + 1) / n)
    return n


def test_job_result_fraction_cancel_and_errors():
    job = Job(steps, 4)
    assert job.result() == 4 and job.done and job.fraction == 1.0
    gate = threading.Event()
    job = Job(steps, 1000, gate=gate)
    assert not job.done and job.fraction == 0.0
    job.cancel()
    gate.set()
    with pytest.raises(Cancelled):
        job.result()
    job = Job(steps, "x")  # a TypeError inside the worker reaches the caller's thread
    assert job.wait(5)
    with pytest.raises(TypeError):
        job.result()


@pytest.fixture(scope="module")
def block():
    mesh = trimesh.creation.box(extents=[0.06, 0.04, 0.02]).subdivide_to_size(0.005)
    return mesh, mesh.face_normals[:, 2] > 0.99  # the top


def fill_args(block):
    mesh, region = block
    return (np.asarray(mesh.vertices), np.asarray(mesh.faces), [0.0, 0.0, 0.01]), dict(fill_region=region)


def test_fill_reports_rising_fractions_and_the_same_result(block):
    args, kw = fill_args(block)
    seen = []
    edit = lay_patch(*args, **kw, progress=lambda f: seen.append(f) or True)
    ref = lay_patch(*args, **kw)
    np.testing.assert_array_equal(edit.layout.positions, ref.layout.positions)
    assert seen[0] == 0.0 and seen[-1] == 1.0 and len(seen) >= 3  # start, each chart, end
    assert np.all(np.diff(seen) >= 0) and max(seen[:-1]) < 1.0


def test_fill_stops_when_progress_says_so(block):
    args, kw = fill_args(block)
    calls = []
    with pytest.raises(Cancelled):
        lay_patch(*args, **kw, progress=lambda f: calls.append(f) or len(calls) < 2)
    assert len(calls) == 2 and calls[1] < 1.0  # the fill unwound at its first chart
    job = Job(lay_patch, *args, **kw)  # the Blender operator's Esc: cancel the job, get Cancelled
    job.cancel()
    with pytest.raises(Cancelled):
        job.result()
