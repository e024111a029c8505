"""``vtcore bench``: discovery, and the one report that ``make bench`` documents (timings never asserted)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
AREAS = {"augment", "can", "categorize", "contact", "control", "filters", "layout"}  # at least these


def _vtcore(*args, cwd):
    env = {"PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin"}
    return subprocess.run([sys.executable, "-m", "vtcore", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=900)


def test_available_lists_the_areas_and_not_the_command_itself():
    from vtcore.cli.bench import available

    import importlib

    names = available()
    # vtcore.cli.bench is the command; listing it as a benchmark "cli" crashed `make bench`.
    assert "cli" not in names and AREAS <= set(names)
    assert names["layout"] == "vtcore.layout.bench"
    assert all(callable(importlib.import_module(m).run) for m in names.values())


def test_one_benchmark_and_an_outside_folder_make_one_report(tmp_path):
    from vtcore._bench import write_table

    # A folder as benchmarks/bench_blender.py writes it (table + plot), outside the output.
    other = tmp_path / "elsewhere" / "blender"
    write_table(other, [{"case": "frame write", "seconds": 0.5}], title="Blender add-on",
                notes=["Goal (issue 7): <= 20 ms."])
    (other / "accuracy_vs_time.png").write_bytes(b"\x89PNG")
    out = tmp_path / "out"
    r = _vtcore("bench", "can", "--quick", "--out", str(out), "--with", str(other), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    report = (out / "README.md").read_text()
    assert report.index("## can") < report.index("## blender")
    assert "### CAN decoding" in report and "### Blender add-on" in report
    assert "Goal (issue 7): <= 20 ms." in report
    assert "](can/accuracy_vs_time.png)" in report
    assert "](../elsewhere/blender/accuracy_vs_time.png)" in report
    assert (out / "can" / "accuracy_vs_time.png").is_file()
    # the closing note: what the area's error is measured against (its module's REFERENCE)
    from vtcore.can.bench import REFERENCE

    assert report.index("## blender") < report.index("## What each area's error is measured against")
    assert f"- **can**: {REFERENCE}" in report


def test_every_area_names_its_reference():
    import importlib

    from vtcore.cli.bench import available

    for name, module in available().items():
        ref = getattr(importlib.import_module(module), "REFERENCE", None)
        assert isinstance(ref, str) and ref, name


def test_bad_names_are_one_clear_message(tmp_path):
    r = _vtcore("bench", "nosuch", "--out", str(tmp_path / "o"), cwd=tmp_path)
    assert r.returncode == 2 and "unknown benchmark 'nosuch'" in r.stderr and "Traceback" not in r.stderr
    r = _vtcore("bench", "can", "--out", str(tmp_path / "o"), "--with", str(tmp_path), cwd=tmp_path)
    assert r.returncode == 2 and "no table.md" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_vtcore_bench_quick_end_to_end(tmp_path):
    """The README's command, as a user runs it: every area, one report with every table and plot."""
    out = tmp_path / "bench"
    r = _vtcore("bench", "--quick", "--out", str(out), cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "Traceback" not in r.stderr
    report = (out / "README.md").read_text()
    from vtcore.cli.bench import available

    for area in sorted(available()):
        assert f"## {area}\n" in report
        assert f"]({area}/accuracy_vs_time.png)" in report
        assert (out / area / "table.md").is_file() and (out / area / "table.csv").is_file()
        assert (out / area / "accuracy_vs_time.png").stat().st_size > 1000
        # the area's table (with its paper anchors) is on the page, not only linked
        title = (out / area / "table.md").read_text().splitlines()[0]
        assert "#" + title in report


def test_cases_run_only_the_matching_rows(tmp_path):
    """``--cases``: the layout benchmark runs only the groups of rows whose case matches (the issue 36
    rows alone take minutes; the whole benchmark an hour)."""
    out = tmp_path / "out"
    r = _vtcore("bench", "layout", "--quick", "--cases", "exp_sphere", "--out", str(out), cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    cases = {line.split(",")[0] for line in (out / "layout" / "table.csv").read_text().splitlines()[1:]}
    assert cases == {"exp_sphere"}
    assert (out / "layout" / "accuracy_vs_time.png").is_file()


def test_jobs_run_areas_in_their_own_processes_into_one_report(tmp_path):
    """``--jobs 2``: the areas run two at a time, each in its own process, and make the same one
    report (each area's folder, its log, the note that the wall times overlap)."""
    out = tmp_path / "out"
    r = _vtcore("bench", "can", "control", "--quick", "--jobs", "2", "--out", str(out), cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    report = (out / "README.md").read_text()
    assert report.index("## can") < report.index("## control")
    assert "(`--jobs 2`)" in report and "Ran in " in report
    for area in ("can", "control"):
        assert (out / area / "table.csv").is_file() and (out / area / "accuracy_vs_time.png").is_file()
        assert (out / area / "bench.log").is_file()
    assert not (out / ".areas").exists()


def test_jobs_report_an_area_that_failed_and_exit_nonzero(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / ".areas").write_text("not a folder")  # the area's process cannot write its output
    r = _vtcore("bench", "can", "--quick", "--jobs", "2", "--out", str(out), cwd=tmp_path)
    assert r.returncode == 1
    assert "benchmark can failed" in r.stderr and "bench.log" in r.stderr
    assert "No `table.md`" in (out / "README.md").read_text()


def test_jobs_interrupted_take_their_area_processes_with_them(tmp_path):
    """SIGTERM to ``vtcore bench --jobs``: the areas' processes stop with it (none left running in the
    background, writing into the output)."""
    import os
    import signal
    import time

    out = tmp_path / "out"
    env = {"PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin"}
    proc = subprocess.Popen([sys.executable, "-m", "vtcore", "bench", "layout", "robot", "--jobs", "2",
                             "--out", str(out)], cwd=tmp_path, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while not ((out / "layout" / "bench.log").exists() and (out / "robot" / "bench.log").exists()):
        assert time.monotonic() < deadline and proc.poll() is None
        time.sleep(0.2)
    time.sleep(1.0)
    proc.send_signal(signal.SIGTERM)
    proc.wait(timeout=120)

    def still_running():
        found = []
        for d in Path("/proc").iterdir():
            try:
                cmd = (d / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            except OSError:
                continue
            if str(out) in cmd and d.name != str(os.getpid()):
                found.append(cmd)
        return found

    assert still_running() == []
    assert not (out / ".areas").exists()
