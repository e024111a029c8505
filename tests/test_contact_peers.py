"""The contact solvers' side-by-side benchmark (vtcore.contact.peers), without the peers' venv."""

from __future__ import annotations


def test_side_by_side_benchmark_runs_the_vtcore_variants_and_writes_its_table(tmp_path):
    from vtcore.contact import peers

    rows = peers.run(tmp_path, ns=(32,), repeat=1)
    assert {r["solver"] for r in rows} == set(peers.VARIANTS)
    assert {r["model"] for r in rows} == {"halfspace", "finite_layer"}
    for r in rows:
        assert r["iterations"] > 0 and r["ms"] > 0 and r["conv_ms"] > 0
        assert r["diff_vs"] < 1e-5  # every variant agrees with the padded float64 solve
    hs = [r for r in rows if r["model"] == "halfspace"]
    assert all(r["error_vs_hertz"] < 0.1 for r in hs)  # 32 cells over 4 Hertz diameters: coarse
    assert (tmp_path / "peers.md").exists() and (tmp_path / "time_vs_n.png").stat().st_size > 0
    compile(peers.PEER_SCRIPT, "peer_script.py", "exec")  # the peers' script at least parses
