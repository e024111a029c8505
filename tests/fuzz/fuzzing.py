"""Mutation fuzzing of vtcore's readers through the CLI entry point, in-process (issue 13).

A reader is fuzzed by drawing a seed file (small, made by the tests or taken from the
repository's scenes/data), applying one to four mutations with hypothesis (bytes:
truncate, flip, insert, splice in binary; lines: duplicate, delete, swap; tokens: a
number replaced by NaN, inf, 1e308, -0, 1e-320, 2**70, a word; the whole file
re-encoded as UTF-16, Latin-1, with a BOM, CR-only or CRLF line ends; empty or
random binary files), and calling ``vtcore.cli.main`` on it. Every input must end in
one of two ways:

- exit 2 and one line on stderr starting ``vtcore: error:`` (scene errors: one such
  message, possibly listing several keys on following lines), no traceback;
- exit 0 with an output that its own reader reads back and that holds only finite numbers.

A RuntimeWarning (numpy overflow, invalid value) fails the example: warnings are errors here; so
does a library's deprecation shown to the user.
Each call runs under a wall-clock alarm, so a hang fails instead of blocking the suite.

Examples per reader: a few dozen by default (the whole fuzz suite < 2 min on 2 cores),
``--fuzz-long`` -> 10,000, or ``VTCORE_FUZZ_EXAMPLES=N``. ``VTCORE_FUZZ_REPORT=FILE``
appends the number of inputs each reader was given to FILE as JSON lines.
"""

from __future__ import annotations

import contextlib
import copy
import io
import json
import os
import re
import warnings
from collections import Counter, defaultdict
from pathlib import Path

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

from helpers import wall_clock_limit

DEFAULT_EXAMPLES = 25
LONG_EXAMPLES = 10_000
#: s of wall clock an input may take before it counts as a hang; ``VTCORE_FUZZ_HANG_SECONDS`` raises it for
#: long runs at a low priority on a shared machine (at a load of 20 under ``nice -n 15``, a 1.5 s
#: validate run took over 60 s of wall clock)
HANG_SECONDS = int(os.environ.get("VTCORE_FUZZ_HANG_SECONDS", "60"))

COUNTS: Counter = Counter()
OUTCOMES: defaultdict = defaultdict(Counter)  # reader -> outcome (exit 0, exit 2, traceback, hang) -> inputs

NASTY_NUMBERS = ["nan", "NaN", "inf", "-inf", "Infinity", "1e308", "-1e308", "1e400", "-0", "-0.0", "1e-320",
                 "4.9e-324", "18446744073709551616", "99999999999999999999999999", "-9223372036854775809",
                 "2147483648", "4294967296", "-1", "0", "0x10", "1_000", "abc", "", "true", "[]", "{}", '"x"',
                 "\x1b[31m", "1e", "--1", "٣"]
_NUMBER = re.compile(rb"-?\d+(\.\d+)?([eE][-+]?\d+)?")


def examples(config) -> int:
    env = os.environ.get("VTCORE_FUZZ_EXAMPLES")
    if env:
        return int(env)
    return LONG_EXAMPLES if config.getoption("--fuzz-long") else DEFAULT_EXAMPLES


def fuzz_settings(config):
    return settings(max_examples=examples(config), deadline=None, database=None, derandomize=False,
                    suppress_health_check=list(HealthCheck), print_blob=True)


# ----------------------------------------------------------------------------- mutations
def _lines(b: bytes) -> list[bytes]:
    return b.splitlines(keepends=True)


@st.composite
def mutation(draw, data: bytes) -> bytes:
    """One mutation of ``data``."""
    n = len(data)
    kind = draw(st.sampled_from(["truncate", "flip", "insert", "dup_line", "del_line", "swap_lines",
                                 "number", "number", "number", "encode", "binary_splice", "line_tokens"]))
    if kind == "truncate":
        return data[:draw(st.integers(0, max(n - 1, 0)))]
    if kind == "flip" and n:
        i = draw(st.integers(0, n - 1))
        return data[:i] + bytes([data[i] ^ draw(st.integers(1, 255))]) + data[i + 1:]
    if kind == "insert":
        i = draw(st.integers(0, n))
        return data[:i] + draw(st.binary(min_size=1, max_size=8)) + data[i:]
    if kind == "binary_splice":
        i = draw(st.integers(0, n))
        return data[:i] + draw(st.binary(min_size=1, max_size=64)) + data[draw(st.integers(i, n)):]
    lines = _lines(data)
    if kind in ("dup_line", "del_line", "swap_lines") and lines:
        i = draw(st.integers(0, len(lines) - 1))
        if kind == "dup_line":
            lines.insert(i, lines[i] * draw(st.integers(1, 3)))
        elif kind == "del_line":
            del lines[i]
        else:
            j = draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
        return b"".join(lines)
    if kind == "number":
        found = list(_NUMBER.finditer(data))
        if found:
            m = found[draw(st.integers(0, len(found) - 1))]
            new = draw(st.sampled_from(NASTY_NUMBERS)).encode()
            return data[:m.start()] + new + data[m.end():]
        return data
    if kind == "line_tokens" and lines:
        i = draw(st.integers(0, len(lines) - 1))
        toks = lines[i].split()
        if toks:
            j = draw(st.integers(0, len(toks) - 1))
            op = draw(st.sampled_from(["drop", "dup", "nasty"]))
            if op == "drop":
                del toks[j]
            elif op == "dup":
                toks.insert(j, toks[j])
            else:
                toks[j] = draw(st.sampled_from(NASTY_NUMBERS)).encode()
            lines[i] = b" ".join(toks) + b"\n"
        return b"".join(lines)
    if kind == "encode":
        how = draw(st.sampled_from(["utf16", "utf16le", "latin1", "bom", "cr", "crlf", "empty", "random"]))
        text = data.decode("utf-8", "replace")
        if how == "utf16":
            return text.encode("utf-16")
        if how == "utf16le":
            return text.encode("utf-16-le")
        if how == "latin1":
            i = draw(st.integers(0, len(text)))
            return (text[:i] + "é°µ" + text[i:]).encode("latin-1", "replace")
        if how == "bom":
            return b"\xef\xbb\xbf" + data
        if how == "cr":
            return data.replace(b"\r\n", b"\n").replace(b"\n", b"\r")
        if how == "crlf":
            return data.replace(b"\r\n", b"\n").replace(b"\n", b"\r\n")
        if how == "empty":
            return b""
        return draw(st.binary(max_size=300))
    return data


@st.composite
def mutated(draw, seeds: list[bytes]) -> bytes:
    data = draw(st.sampled_from(seeds))
    for _ in range(draw(st.integers(1, 4))):
        data = draw(mutation(data))
    return data


# ----------------------------------------------------------------------------- running
class Hang(Exception):
    pass


def run_cli(reader: str, argv: list[str]) -> tuple[int, str, str]:
    """``vtcore.cli.main(argv)`` in-process: (exit status, stdout, stderr). Counts the input."""
    from vtcore.cli import main

    COUNTS[reader] += 1
    out, err = io.StringIO(), io.StringIO()
    outcome = "traceback"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            with wall_clock_limit(HANG_SECONDS, Hang), contextlib.redirect_stdout(out), \
                    contextlib.redirect_stderr(err):
                rc = main([str(a) for a in argv])
        outcome = f"exit {rc}" if rc in (0, 2) else f"exit {rc} (unexpected)"
    except Hang:
        outcome = "hang"
        raise
    finally:
        OUTCOMES[reader][outcome] += 1
        _flush_progress()
    return rc, out.getvalue(), err.getvalue()


def _flush_progress(every: int = 25) -> None:
    """``VTCORE_FUZZ_PROGRESS=FILE``: rewrite FILE with the outcomes per reader every ``every`` inputs
    (a long run shows its counts while it runs, and keeps them if it is stopped)."""
    path = os.environ.get("VTCORE_FUZZ_PROGRESS")
    if not path or sum(COUNTS.values()) % every:
        return
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "w", encoding="utf-8") as fh:
        json.dump({r: {"inputs": COUNTS[r], **dict(OUTCOMES[r])} for r in sorted(COUNTS)}, fh, indent=1)
    os.replace(tmp, path)


def assert_clean_exit(rc: int, out: str, err: str, *, lines: int | None = 1) -> None:
    """Exit 0, or exit 2 with ``vtcore: error:`` (``lines`` lines, None: any number), after any
    ``vtcore: warning:`` lines (the CLI's contract: warnings raised before the error, e.g. a
    placement's off-surface warning before its refusal, are lines of their own)."""
    assert rc in (0, 2), f"exit {rc}\n{err}"
    assert "Traceback" not in err and "Warning" not in err + out, err
    assert "deprecat" not in err.lower(), err  # a library's note to vtcore's programmers, not to users
    if rc == 2:
        got = err.rstrip("\n").split("\n")
        n_warn = next((i for i, line in enumerate(got) if not line.startswith("vtcore: warning: ")), len(got))
        got = got[n_warn:]
        assert got and got[0].startswith("vtcore: error: "), err
        if lines is not None:
            assert len(got) == lines, err
        assert not re.search(r"[\x00-\x08\x0b-\x1f\x7f]", err.replace("\n", "")), f"control bytes: {err!r}"


def fuzz(config, strategy, body) -> None:
    """Run ``body(example)`` on ``examples(config)`` draws of ``strategy`` (hypothesis shrinks a failure).

    ``VTCORE_FUZZ_KEEP_GOING=FILE``: a failing example does not stop the run; it is appended to FILE
    (JSON lines: the exception, where it was raised, the input's start) and the run goes on without
    shrinking, so a long run counts every failure; the test fails at the end if there was any. The input
    under way is kept in FILE.last (what a crash of the process left unrecorded).
    """
    from hypothesis import Phase, given

    keep = os.environ.get("VTCORE_FUZZ_KEEP_GOING")
    failures = []
    base = fuzz_settings(config)
    conf = settings(base, phases=[Phase.generate]) if keep else base

    @conf
    @given(strategy)
    def check(example):
        if not keep:
            body(example)
            return
        # the input under way, rewritten before each: a crash of the process itself (a segmentation
        # fault in a C library) leaves it in FILE.last, where nothing else would record it
        with open(f"{keep}.last", "w", encoding="utf-8") as fh:
            fh.write(repr(example)[:20000])
        try:
            body(example)
        except Exception as exc:  # noqa: BLE001  (recorded, then raised as one failure at the end)
            import traceback

            frames = traceback.extract_tb(exc.__traceback__)
            where = [f"{Path(f.filename).name}:{f.lineno} {f.name}" for f in frames[-4:]]
            failures.append(1)
            with open(keep, "a", encoding="utf-8") as fh:
                fh.write(json.dumps({"error": f"{type(exc).__name__}: {str(exc)[:600]}", "where": where,
                                     "input": repr(example)[:3000]}) + "\n")

    check()
    assert not failures, f"{len(failures)} failing inputs, listed in {keep}"


def record_counts() -> None:
    path = os.environ.get("VTCORE_FUZZ_REPORT")
    if path and COUNTS:
        with open(path, "a", encoding="utf-8") as fh:
            fh.write(json.dumps(dict(COUNTS)) + "\n")


# ----------------------------------------------------------------------------- structured (JSON / TOML) values
#: Values a field is set to: the extremes of issue 28 (0, negative, 1e-320, 1e308, NaN, strings) and
#: the wrong shapes a hand-edited file has (null, lists, objects, huge integers, control bytes).
EXTREME_VALUES = [0, 0.0, -1, -1.0, -1e308, 1e-320, 4.9e-324, 1e308, float("nan"), float("inf"), float("-inf"),
                  10 ** 9, 2 ** 63 - 1, -(2 ** 63), 10 ** 30, -(10 ** 30), 0.5, 1e-9, 1e9, True, False, None,
                  "", " ", "x", "1e308", "nan", "0x1F", "a,b", "a\nb", "\x1b[31m", "pressure", "thermal", "mm", "m",
                  [], [1], [[1]], [0, 1], [1e308, 0, 0], [0, 0, 0], [float("nan")] * 3, {}, {"a": 1}]


def _paths(obj, prefix=(), depth=0, out=None, rng=None):
    """Every (path, value) of a nested dict/list document, long lists sampled (first, last, a few)."""
    out = [] if out is None else out
    out.append((prefix, obj))
    if depth > 6:
        return out
    if isinstance(obj, dict):
        for k, v in obj.items():
            _paths(v, prefix + (k,), depth + 1, out)
    elif isinstance(obj, list) and obj:
        idx = sorted({0, len(obj) - 1, len(obj) // 2, min(2, len(obj) - 1)})
        for i in idx:
            _paths(obj[i], prefix + (i,), depth + 1, out)
    return out


def _set(doc, path, value):
    node = doc
    for p in path[:-1]:
        node = node[p]
    node[path[-1]] = value


@st.composite
def doc_mutation(draw, doc, names=()):
    """One structural edit of the decoded document ``doc`` (edited in place): a value replaced by an
    extreme, scaled, copied from elsewhere in the file, deleted or duplicated, or a known key
    (``names``: dotted paths such as ``meta.pitch_m``) added with an extreme value."""
    paths = [p for p in _paths(doc) if p[0]]
    kind = draw(st.sampled_from(["extreme", "extreme", "extreme", "scale", "copy", "delete", "dup", "add"]))
    if kind == "add" and names:
        name = draw(st.sampled_from(sorted(names))).split(".")
        node = doc
        for p in name[:-1]:
            if not isinstance(node.get(p), dict):
                node[p] = {}
            node = node[p]
        node[name[-1]] = copy.deepcopy(draw(st.sampled_from(EXTREME_VALUES)))  # never the shared list itself
        return
    if not paths:
        return
    path, value = paths[draw(st.integers(0, len(paths) - 1))]
    if kind == "extreme" or kind == "add":
        _set(doc, path, copy.deepcopy(draw(st.sampled_from(EXTREME_VALUES))))
    elif kind == "scale" and isinstance(value, (int, float)) and not isinstance(value, bool):
        _set(doc, path, value * draw(st.sampled_from([1e3, 1e-3, -1, 1e12, 1e-12, 0.5])))
    elif kind == "copy":
        _set(doc, path, copy.deepcopy(paths[draw(st.integers(0, len(paths) - 1))][1]))
    elif kind == "delete":
        parent = doc
        for p in path[:-1]:
            parent = parent[p]
        del parent[path[-1]]
    elif kind == "dup" and isinstance(value, list) and value:
        value.append(value[draw(st.integers(0, len(value) - 1))])


@st.composite
def mutated_doc(draw, seeds: list[dict], names=()) -> dict:
    """A deep copy of one of ``seeds`` after one to three :func:`doc_mutation` edits."""
    doc = json.loads(json.dumps(draw(st.sampled_from(seeds))))
    for _ in range(draw(st.integers(1, 3))):
        draw(doc_mutation(doc, names))
    return doc


# ----------------------------------------------------------------------------- robot XML (URDF, MJCF)
#: element and attribute names of URDF and MJCF, for renames and additions
XML_TAGS = ["robot", "link", "joint", "visual", "collision", "geometry", "mesh", "box", "cylinder", "sphere", "capsule",
            "origin", "parent", "child", "axis", "limit", "mimic", "inertial", "mass", "inertia", "mujoco",
            "worldbody", "body", "geom", "site", "asset", "default", "compiler", "include", "freejoint", "x"]
XML_ATTRS = ["name", "type", "pos", "size", "quat", "euler", "axisangle", "zaxis", "fromto", "range", "axis", "xyz",
             "rpy", "filename", "scale", "file", "mesh", "class", "childclass", "link", "joint", "multiplier",
             "offset", "lower", "upper", "radius", "length", "mass", "value", "contype", "conaffinity", "meshdir",
             "angle", "limited", "ixx", "x"]
XML_ENCODINGS = ["utf-nan", "latin-1", "ISO-8859-1", "utf-16", "ascii", "UTF-8", "cp1252", "x", ""]


def _xml_value(draw, value: str) -> str:
    """An attribute value edited: one token a nasty number, a token added or dropped, or all replaced."""
    toks = value.split()
    how = draw(st.sampled_from(["token", "token", "all", "add", "drop", "scale"]))
    if how == "token" and toks:
        toks[draw(st.integers(0, len(toks) - 1))] = draw(st.sampled_from(NASTY_NUMBERS))
    elif how == "add":
        toks.insert(draw(st.integers(0, len(toks))), draw(st.sampled_from(NASTY_NUMBERS)))
    elif how == "drop" and toks:
        del toks[draw(st.integers(0, len(toks) - 1))]
    elif how == "scale" and toks:
        mult = draw(st.sampled_from([1e3, 1e-3, -1.0, 1e6, 0.0]))
        toks = [repr(float(t) * mult) if re.fullmatch(r"-?\d+(\.\d*)?([eE][-+]?\d+)?", t) else t for t in toks]
    else:
        return draw(st.sampled_from(NASTY_NUMBERS + ["0 0 0", "1 0 0 0", "", "a b c", "x\x01y", "1 2 3 4 5 6 7"]))
    return " ".join(toks)


def _edit_tree(draw, root) -> None:
    """One structural edit of the element tree ``root`` (in place)."""
    elements = list(root.iter())
    parents = {c: p for p in elements for c in p}
    el = elements[draw(st.integers(0, len(elements) - 1))]
    kind = draw(st.sampled_from(["attr", "attr", "attr", "attr", "delete", "dup", "rename", "attr_name", "add_attr"]))
    if kind == "attr" and el.attrib:
        k = draw(st.sampled_from(sorted(el.attrib)))
        el.set(k, _xml_value(draw, el.get(k)))
    elif kind in ("delete", "dup") and el in parents:
        parent = parents[el]
        if kind == "delete":
            parent.remove(el)
        else:
            import copy as _copy

            parent.insert(list(parent).index(el) + 1, _copy.deepcopy(el))
    elif kind == "rename":
        el.tag = draw(st.sampled_from(XML_TAGS))
    elif kind == "attr_name" and el.attrib:
        k = draw(st.sampled_from(sorted(el.attrib)))
        v = el.attrib.pop(k)
        new = draw(st.sampled_from(XML_ATTRS + [None]))
        if new is not None:
            el.set(new, v)
    elif kind == "add_attr":
        el.set(draw(st.sampled_from(XML_ATTRS)), draw(st.sampled_from(NASTY_NUMBERS + ["0 0 0", "1 1 1"])))


_DECL = re.compile(rb"^(\xef\xbb\xbf)?<\?xml[^>]*\?>\s*")


@st.composite
def xml_mutation(draw, data: bytes) -> bytes:
    """One mutation of a robot file: an attribute value (a token made NaN, inf, 1e308, a word...), an
    element deleted, duplicated or renamed, an attribute renamed, removed or added; a declared
    encoding (unknown, Latin-1, UTF-16...), a name holding bytes that are not UTF-8; or a byte-level
    mutation of :func:`mutation`."""
    import xml.etree.ElementTree as ET

    kind = draw(st.sampled_from(["tree", "tree", "tree", "tree", "encoding", "bytes"]))
    if kind == "bytes":
        return draw(mutation(data))
    if kind == "encoding":
        how = draw(st.sampled_from(["declare", "name_bytes", "utf16", "bom"]))
        body = _DECL.sub(b"", data)
        if how == "declare":
            enc = draw(st.sampled_from(XML_ENCODINGS)).encode()
            return b'<?xml version="1.0" encoding="' + enc + b'"?>\n' + body
        if how == "name_bytes":
            at = [m.end() for m in re.finditer(rb'name="', data)]
            if not at:
                return data
            i = at[draw(st.integers(0, len(at) - 1))]
            return data[:i] + draw(st.sampled_from([b"\xe9", b"\xff\xfe", b"\xc3", b"\x80abc", b"\xed\xa0\x80"])) + data[i:]
        if how == "utf16":
            return body.decode("utf-8", "replace").encode("utf-16")
        return b"\xef\xbb\xbf" + data
    try:
        root = ET.fromstring(data)
    except (ET.ParseError, LookupError, ValueError):  # already broken (or an unknown declared encoding)
        return draw(mutation(data))
    _edit_tree(draw, root)
    return ET.tostring(root, encoding="utf-8", xml_declaration=draw(st.booleans()))


@st.composite
def mutated_xml(draw, seeds: list[bytes]) -> tuple[int, bytes]:
    """(which seed, the seed after one to three :func:`xml_mutation`)."""
    i = draw(st.integers(0, len(seeds) - 1))
    data = seeds[i]
    for _ in range(draw(st.integers(1, 3))):
        data = draw(xml_mutation(data))
    return i, data


# ----------------------------------------------------------------------------- TOML documents
def toml_text(doc: dict) -> str:
    """TOML of a decoded document edited by :func:`doc_mutation` (None values left out, as TOML has no
    null; NaN and infinity as TOML's nan and inf; a table edited into a list of tables written inline)."""
    import math

    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, int):
            return str(v)
        if isinstance(v, float):
            return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v if x is not None) + "]"
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{json.dumps(k)} = {value(x)}" for k, x in v.items() if x is not None) + " }"
        raise TypeError(type(v))

    top, tables = [], []
    for k, v in doc.items():
        if isinstance(v, dict):
            tables.append(f"[{json.dumps(k)}]")
            tables += [f"{json.dumps(kk)} = {value(x)}" for kk, x in v.items() if x is not None]
            tables.append("")
        elif v is not None:
            top.append(f"{json.dumps(k)} = {value(v)}")
    return "\n".join(top + [""] + tables) + "\n"


@st.composite
def mutated_toml(draw, seeds: list[dict], names=()) -> bytes:
    """A TOML file from one of ``seeds`` (decoded documents): edited field by field
    (:func:`mutated_doc`), or its text then mutated byte by byte (:func:`mutation`)."""
    doc = draw(mutated_doc(seeds, names))
    data = toml_text(doc).encode("utf-8")
    if draw(st.integers(0, 3)) == 0:
        data = draw(mutation(data))
    return data


# ----------------------------------------------------------------------------- output at the C level
@contextlib.contextmanager
def fd_output():
    """Collect what is written to file descriptors 1 and 2 in the block (a C library's printf, which
    ``redirect_stdout`` does not see: MuJoCo's "WARNING: XML contains a 'NaN'"); yields a list that
    holds the text once the block ends."""
    import sys
    import tempfile

    got: list[str] = []
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 1)
        os.dup2(tmp.fileno(), 2)
        try:
            yield got
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
            tmp.seek(0)
            got.append(tmp.read().decode("utf-8", "replace"))


def run_cli_fd(reader: str, argv: list[str]) -> tuple[int, str, str]:
    """:func:`run_cli`, and nothing written past Python to the terminal (file descriptors 1 and 2)."""
    with fd_output() as raw:
        rc, out, err = run_cli(reader, argv)
    assert not raw[0].strip(), f"printed at the C level, past vtcore's messages: {raw[0][:500]!r}"
    return rc, out, err


def warm_up(argv: list) -> None:
    """Run ``vtcore ARGV`` once, uncounted and with no alarm: the first call imports open3d, MuJoCo,
    geometry-central..., which on a loaded machine can take most of the 60 s a fuzz input is given."""
    from vtcore.cli import main

    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        rc = main([str(a) for a in argv])
    # the unmutated seed must pass: a seed the command refuses makes every mutant a refusal at the
    # same first check, and the driver would count inputs that never reach the reader under test
    assert rc == 0, f"the driver's seed is refused: {err.getvalue()}"


def finite_json_text(text: str):
    """``json.loads`` that refuses NaN and Infinity (Python's own reader accepts them)."""
    def bad(token):
        raise AssertionError(f"non-finite number {token} in JSON output")

    return json.loads(text, parse_constant=bad)


def listing(folder: Path) -> list[str]:
    """Every path under ``folder`` (hidden ones too), sorted; [] when it does not exist."""
    folder = Path(folder)
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*")) if folder.exists() else []
