"""The two lanes' locks (requirements.lock: Python 3.11; requirements-py313.lock: 3.13) pin the
same packages at the same versions except where the Blender generation decides, so a
dependency added to one lane is not silently missing from the other."""

from __future__ import annotations

import re

#: pinned per generation: the Blender wheel and the numpy it is built against; cattrs is
#: a dependency of bpy 5.2 only.
PER_GENERATION = {"numpy", "bpy", "cattrs"}
#: in the Python 3.11 lane only: torch (the optional extra vtcore[learn]) and what only it pulls in.
#: This machine's local index has a CPU build for 3.11 only; under 3.13 pip would download multi-GB
#: CUDA wheels, so that lane skips the PointNet tests (pytest.importorskip) instead.
PY311_ONLY = {"torch", "filelock", "mpmath", "sympy"}


def pins(path):
    out = {}
    for n, line in enumerate(path.read_text().splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        m = re.fullmatch(r"([A-Za-z0-9_.\-]+)==(\S+)", line)
        assert m, f"{path.name}:{n}: not an exact pin: {line!r}"
        out[re.sub(r"[-_.]+", "-", m[1]).lower()] = m[2]
    return out


def test_locks_agree_except_the_generation_pins(root):
    a, b = pins(root / "requirements.lock"), pins(root / "requirements-py313.lock")
    assert PY311_ONLY <= a.keys() and not PY311_ONLY & b.keys(), "run scripts/lock_py313.sh"
    shared = (a.keys() | b.keys()) - PER_GENERATION - PY311_ONLY
    # After editing requirements.lock run scripts/lock_py313.sh (a package with no wheel for
    # one of the Pythons goes into PER_GENERATION and that script, saying why).
    assert {k for k in shared if a.get(k) != b.get(k)} == set(), \
        {k: (a.get(k), b.get(k)) for k in shared if a.get(k) != b.get(k)}
    assert a["numpy"].startswith("1.") and b["numpy"].startswith("2.")
    assert a["bpy"].startswith("4.5.") and b["bpy"].startswith("5.2.")
