"""Issue 28: the warnings a command shows are the ones meant for its user.

Found in the py313 lane (numpy 2.5): ``vtcore layout place`` on a mutated mesh printed
``vtcore: warning: Setting the shape on a NumPy array has been deprecated in NumPy 2.5 ...`` (pycollada,
reading a DAE through trimesh; layout.meshinput.read_trimesh now silences that one), and in
the py311 lane (numpy 1.26) a text STL with a stray character printed numpy's DeprecationWarning
"string or file could not be read to its end ...; this will raise a ValueError in the future" before
placing on what was read of it (numpy 2.5 raises there: the two lanes disagreed on the same file).
A library's deprecation is for vtcore's programmers (the fix is in vtcore, never in the user's
input); a user sees vtcore's own warnings and the numerical ones, as ``vtcore: warning:`` lines.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from test_inputs_extremes import LAYOUTS, one_error, run

SHAPE = "Setting the shape on a NumPy array has been deprecated in NumPy 2.5"


def test_meant_for_users_is_decided_by_category():
    from vtcore.contact.materials import LargeDeformationWarning
    from vtcore.errors import for_users, meant_for_users
    from vtcore.layout.mesh import LayoutWarning

    class OwnDeprecation(DeprecationWarning):  # a deprecation vtcore itself raises (a scene key going away)
        pass

    OwnDeprecation.__module__ = "vtcore.scene.schema"
    for cat in (LayoutWarning, LargeDeformationWarning, RuntimeWarning, UserWarning, OwnDeprecation):
        assert meant_for_users(cat), cat
    for cat in (DeprecationWarning, PendingDeprecationWarning, FutureWarning, ResourceWarning, ImportWarning):
        assert not meant_for_users(cat), cat
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.warn("a", DeprecationWarning)
        warnings.warn("b", LayoutWarning)
        warnings.warn("c", FutureWarning)
        warnings.warn("d", RuntimeWarning)
    assert [str(w.message) for w in for_users(caught)] == ["b", "d"]


@pytest.fixture
def box_stl(tmp_path):
    import trimesh

    path = tmp_path / "box.stl"
    trimesh.creation.box((60.0, 60.0, 20.0)).export(path, file_type="stl_ascii")  # millimetres
    return path


def _place(mesh, out):
    return run("layout", "place", mesh, "--scale", "0.001", "--at", "0", "0", "0.01", "--patch", "triangle",
               "--out", out)


def test_a_library_deprecation_while_placing_is_not_shown(box_stl, tmp_path, monkeypatch):
    """The mesh reader (trimesh) warns as numpy 2.5 does when a library sets ``.shape`` (the real
    assignment as well, which warns under numpy >= 2.5), and raises a numerical warning: the user
    sees only the numerical one, as a ``vtcore: warning:`` line; the placement is written."""
    import trimesh

    real = trimesh.load

    def load(*a, **k):
        view = np.zeros(6).view()
        view.shape = (2, 3)  # the deprecated assignment itself (numpy >= 2.5 warns)
        warnings.warn(SHAPE, DeprecationWarning, stacklevel=2)
        warnings.warn("pending", PendingDeprecationWarning, stacklevel=2)
        warnings.warn("overflow encountered in multiply", RuntimeWarning, stacklevel=2)
        return real(*a, **k)

    monkeypatch.setattr(trimesh, "load", load)
    rc, out, err = _place(box_stl, tmp_path / "o.json")
    assert rc == 0, err
    assert (tmp_path / "o.json").exists()
    assert "NumPy" not in err and "deprecat" not in err.lower() and "pending" not in err, err
    assert err.splitlines() == ["vtcore: warning: overflow encountered in multiply"], err


def test_a_warning_no_command_collects_is_one_line_or_none(tmp_path, monkeypatch):
    """A warning raised outside a command's own collection (here in ``layout info``'s summary) goes
    through the CLI's display: a user's warning is one ``vtcore: warning:`` line without Python's
    source line, a library's deprecation nothing."""
    import vtcore.cli.layout as cli_layout

    real = cli_layout.layout_info

    def info(layout):
        warnings.warn(SHAPE, DeprecationWarning)
        warnings.warn("invalid value encountered in divide\nsecond line", RuntimeWarning)
        return real(layout)

    monkeypatch.setattr(cli_layout, "layout_info", info)
    rc, out, err = run("layout", "info", LAYOUTS / "icub_two_triangles.txt")
    assert rc == 0, err
    assert err.splitlines() == ["vtcore: warning: invalid value encountered in divide / second line"], err
    assert "taxels" in out


def test_a_text_stl_with_a_stray_character_is_unreadable_in_every_numpy(box_stl, tmp_path):
    """numpy 1.26 read the file up to the stray character with a DeprecationWarning, numpy 2.5
    raises: both lanes now give the same one error line, and nothing is written."""
    text = box_stl.read_text().splitlines(keepends=True)
    i = next(i for i, ln in enumerate(text) if ln.strip().startswith("vertex"))
    text[i] = text[i].replace("vertex ", "vertex!", 1)  # the mutation the fuzz suite found
    bad = tmp_path / "bad.stl"
    bad.write_text("".join(text))
    rc, _, err = _place(bad, tmp_path / "o.json")
    one_error(rc, err, f"{bad}: cannot read mesh: string or file could not be read to its end")
    assert "future" not in err
    assert not (tmp_path / "o.json").exists()
