"""``vibroimpact bench --peers --quick`` (issue 9): the run completes, every row has a number
or says ``not available: reason``, and a missing peer does not fail it. No timing assertions."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest
from vibroimpact.benchmarks.peers import scipy_peer, table
from vibroimpact.benchmarks.peers.reference import impact_time_error


def test_bench_peers_quick_completes(tmp_path: Path) -> None:
    out = tmp_path / "results.md"
    readme = tmp_path / "README.md"
    readme.write_text(f"# x\n{table.README_START}\nold\n{table.README_END}\n", encoding="utf-8")
    p = subprocess.run(
        [sys.executable, "-m", "vibroimpact", "bench", "--peers", "--quick", "--json",
         "--write", str(out), "--readme", str(readme)],
        capture_output=True, text=True, timeout=600,
    )
    assert p.returncode == 0, p.stderr[-2000:]
    # OpenSees prints "Process 0 Terminating" at exit: the JSON is the first line
    data = json.loads(p.stdout.strip().splitlines()[0])
    rows = data["rows"]
    assert {r["problem"] for r in rows} == {"paper-sdof", "forced-sdof", "hollow-shaft"}
    for r in rows:
        has_number = isinstance(r["time_s"], float) and math.isfinite(r["time_s"])
        assert has_number or r["note"].startswith(("not available: ", "cannot express: ")), r
        if has_number:  # every problem has contacts within the quick run, so both errors exist
            assert r["repeats"] >= 1
            assert math.isfinite(r["peak_error"]) and math.isfinite(r["impact_time_error_s"]), r
    ours = [r for r in rows if r["tool"] == "vibroimpact" and r["problem"] == "paper-sdof"]
    assert ours[0]["method"] == "Newmark"
    assert all(r["peak_error"] is not None and r["peak_error"] < 1e-4 for r in ours)
    eq = data["equal_accuracy"]  # issue 20: ours first, the base of the ratios, meeting it
    assert eq["rows"][0]["tool"] == "vibroimpact" and eq["rows"][0]["ratio"] == 1.0
    assert eq["rows"][0]["meets"] and len(data["issue20_targets"]) == 8
    text = out.read_text(encoding="utf-8")
    assert "## Machine" in text and "| cpu |" in text and "## Results" in text
    assert "ONE run per peer" in text  # --quick says what it changed
    block = readme.read_text(encoding="utf-8")
    assert "| hollow-shaft |" in block and "old" not in block


def test_missing_peer_gives_a_not_available_row() -> None:
    def never() -> dict:
        raise AssertionError("a missing peer must not run")

    rows = table.peer_rows("paper-sdof", "Peer", "no such module (pip install it)",
                           [("Newmark", "dt 1e-06 s", never)], {"impacts": [], "peak": 1.0}, 5,
                           "", never)
    assert len(rows) == 1 and rows[0]["time_s"] is None
    assert rows[0]["note"] == "not available: no such module (pip install it)"


def test_median_counts_a_long_first_run_and_skips_a_short_warm_up(monkeypatch) -> None:
    """Medians of ``repeats`` runs: a warm-up shorter than LONG_RUN_S is not counted, a
    longer one is the first of the runs (no extra run); ours (``base``) is timed once beside
    each counted run, after an untimed call of its own (warm)."""
    calls: list[str] = []
    f, b = (lambda: calls.append("f")), (lambda: calls.append("b"))
    # warm-up 0.1 s; then base 0.05, run 0.2, base 0.07, run 0.3
    clock = iter([0.0, 0.1, 1.0, 1.05, 2.0, 2.2, 3.0, 3.07, 4.0, 4.3])
    monkeypatch.setattr(table.time, "perf_counter", lambda: next(clock))
    secs, _, base = table._timed(f, 2, b)
    assert calls == ["f", "b", "b", "f", "b", "b", "f"]
    assert math.isclose(secs, 0.25) and math.isclose(base, 0.06)
    # a first run of 5 s counts: runs 5, 7, 6 s; base 0.1, 0.3, 0.2 s
    clock = iter([0.0, 5.0, 10.0, 10.1, 11.0, 11.3, 12.0, 19.0, 20.0, 20.2, 21.0, 27.0])
    monkeypatch.setattr(table.time, "perf_counter", lambda: next(clock))
    calls.clear()
    secs, _, base = table._timed(f, 3, b)
    assert calls == ["f", "b", "b", "b", "b", "f", "b", "b", "f"]
    assert secs == 6.0 and math.isclose(base, 0.2)
    clock = iter([0.0, 0.5])  # one run, nothing beside it
    monkeypatch.setattr(table.time, "perf_counter", lambda: next(clock))
    assert table._timed(f, 1)[0::2] == (0.5, None)


def test_matching_tolerance_is_the_loosest_within_our_errors() -> None:
    ref = {"peak": 1.0, "impacts": [[0.1, 0.2]]}
    runs = {1e-3: (1.01, [[0.1, 0.2]]),          # peak error 1e-2: too large
            1e-4: (1.0001, [[0.1, 0.2], [0.3, 0.31]]),  # one contact too many
            1e-5: (1.0001, [[0.1, 0.2 + 1e-7]]),   # within both
            1e-6: (1.00001, [[0.1, 0.2]])}
    run = lambda r: {"peak": runs[r][0], "impacts": runs[r][1]}  # noqa: E731
    assert scipy_peer.matching_tolerance(run, ref, 1e-3, 1e-6, 0, tuple(runs)) == (1e-5, True)
    assert scipy_peer.matching_tolerance(run, ref, 1e-3, 1e-6, 1, tuple(runs)) == (1e-4, True)
    assert scipy_peer.matching_tolerance(run, ref, 1e-9, 1e-9, 0, tuple(runs)) == (1e-6, False)


def test_readme_block_is_replaced_between_the_markers() -> None:
    rows = [table._row("p", "vibroimpact", "Newmark", "dt 1e-06 s", time_s=0.004, ratio=1.0),
            table._row("p", "SciPy", "Radau", "rtol 1e-05", time_s=0.4, ratio=100.0),
            table._row("p", "SciPy", "DOP853", "rtol 1e-08", time_s=0.04, ratio=10.0),
            table._unavailable("p", "SciPy", "LSODA", "", "failed: x")]
    info = {"date": "d", "cpu": "c", "cores": "2", "load average (1/5/15 min) when written": "l"}
    block = table.format_readme(rows, info, quick=False)
    assert "| p | 4 ms | 100× (rtol 1e-05) |" in block
    assert "SciPy DOP853 (10×, short by 3× of ≥ 30×)" in block
    assert "SciPy LSODA (not measured of ≥ 100×)" in block
    text = f"intro\n{table.README_START}\nold\n{table.README_END}\noutro\n"
    new = table.replace_readme_block(text, block)
    assert new.startswith("intro\n" + table.README_START) and new.endswith(
        table.README_END + "\noutro\n") and "old" not in new
    with pytest.raises(ValueError, match="README: expected the markers"):
        table.replace_readme_block("no markers", block)


def test_impact_time_error_matches_nearest_contacts() -> None:
    ref = [[0.1, 0.2], [0.5, 0.6]]
    assert impact_time_error([[0.1, 0.2 + 1e-9], [0.5, 0.6]], ref)[0] < 2e-9
    err, note = impact_time_error([[0.1, 0.2], [0.3, 0.30001], [0.5, 0.6]], ref)
    assert err < 1e-12 and "3 contacts vs 2" in note


def test_load_note_says_when_the_machine_was_loaded() -> None:
    info = {"cores": "2", "load average (1/5/15 min) at the start": "0.50 / 0.40 / 0.30",
            "load average (1/5/15 min) when written": "3.10 / 2.00 / 1.00"}
    assert "load average up to 3.1 on 2 cores" in table.load_note(info)
    quiet = {**info, "load average (1/5/15 min) when written": "1.90 / 1.00 / 1.00"}
    assert table.load_note(quiet) == ""


def test_results_md_writes_issue_20s_per_step_section_from_the_run() -> None:
    """``--write`` writes issue 20's per-step section itself (the file wholly generated): the
    bare loop in CPU and wall time, the integrators and the fixed-step sweep's throughput,
    from the run's own measurements (here made-up numbers)."""
    floor = {"steps": 20000, "ours_s": 2.0e-3, "floor_s": 1.0e-3, "ratio": 2.0,
             "ours_cpu_s": 1.5e-3, "floor_cpu_s": 1.0e-3, "cpu_ratio": 1.5,
             "max_displacement_difference_m": 4e-11, "target_ratio": 1.7}
    sweep = {"points": 16, "periods": 300, "cpu_s": 0.125, "wall_s": 0.13, "steps": 2663100,
             "ns_per_step": 46.9, "baseline_cpu_s": 0.265, "ratio": 0.265 / 0.125,
             "target_ratio": 2.0}
    issue20 = table.issue20_targets([], None, floor, sweep)
    assert issue20[-1]["key"] == "sweep_throughput" and issue20[-1]["met"]
    text = table.format_markdown([], {"cpu": "x"}, False, None, issue20, None, floor)
    section = text.split("## Issue 20, item 1: the per-step path")[1].split("## How")[0]
    assert "1.50x in CPU time (1.500 / 1.000 ms), 2.00x in wall time" in section
    assert "target <= 1.7x: met (CPU time)" in section
    assert "fixed-step sweep throughput per core: 2.12x, met (target >= 2x)" in section
    assert "0.125 s CPU (2,663,100 steps, 47 ns a step) against 0.265 s" in section
    assert "generalized-α / Newmark: not measured" in section
    without = table.format_markdown([], {"cpu": "x"}, False, None, issue20, None)
    assert "per-step path" not in without
