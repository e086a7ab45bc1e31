"""``vibroimpact bench --peers`` at equal accuracy (issue 20, item 3): the errors it measures
are right where the answer is known, the ladder search picks the loosest passing setting, our
reference agrees with SciPy's independent one, and a missing peer costs one line, not the run.
No timing is asserted."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from vibroimpact.benchmarks.command import main as bench_main
from vibroimpact.benchmarks.peers import equal_accuracy as eqacc
from vibroimpact.benchmarks.peers import opensees_peer, table
from vibroimpact.benchmarks.peers.problems import SdofProblem, paper_sdof

A, W, D = 6e-3, 2 * math.pi * 50.0, 5e-3  # amplitude (m), rad/s, clearance (m)


def _sine_problem() -> SdofProblem:
    return SdofProblem(key="sine", title="sine", mass=1.0, contact_stiffness=1.0, exponent=1.5,
                       restitution=None, clearance=D, sides=(1, -1), t_end=0.05, dt=1e-6)


def _sine_contacts(shift: float = 0.0) -> dict:
    """The contacts of x = A sin(W (t − shift)) between walls at ±D, from the formula: each
    half wave is a contact from asin(D/A)/W to (π − asin(D/A))/W after its zero crossing, with
    the peak A."""
    t0 = math.asin(D / A) / W
    impacts = [[k * math.pi / W + t0 + shift, (k + 1) * math.pi / W - t0 + shift]
               for k in range(5)]
    return {"impacts": impacts, "contact_peaks": [A] * 5}


def test_errors_of_a_shifted_sampled_copy_are_the_shift() -> None:
    """A fixed-step peer's history (a sine sampled every 0.1 µs), read as the tables read it
    (linearly interpolated crossings, largest step value in each contact), against the exact
    contacts: the errors are the sampling's (tiny); a copy delayed by 3 ns and scaled up by
    2e-8 m in its peaks has errors of exactly that much more."""
    t = np.linspace(0.0, 0.05, 500_001)
    exact = _sine_contacts()
    sampled = opensees_peer.sampled_contacts(t, A * np.sin(W * t), _sine_problem())
    peak, time, note = eqacc.contact_errors(sampled, exact)
    assert note == "" and len(sampled["impacts"]) == 5
    assert peak < 1e-10 and time < 1e-12
    tau, bump = 3e-9, 2e-8
    scale = (A + bump) / A
    shifted = opensees_peer.sampled_contacts(t, scale * A * np.sin(W * (t - tau)),
                                             _sine_problem())
    peak, time, _ = eqacc.contact_errors(shifted, exact)
    # the peaks rise by bump; the crossings of a taller sine move earlier by about
    # (scale − 1) tan(W t0)/W at the start (later at the end), on top of the delay
    t0 = math.asin(D / A) / W
    move = (scale - 1) * math.tan(W * t0) / W
    assert peak == pytest.approx(bump, rel=1e-3)
    assert time == pytest.approx(tau + move, rel=1e-3)
    assert eqacc.contact_errors(_sine_contacts(tau), exact)[:2] == pytest.approx((0.0, tau))
    one_off = _sine_contacts()  # the largest error is taken over the contacts
    one_off["impacts"][2][1] += 5e-9
    one_off["contact_peaks"][3] -= 4e-8
    assert eqacc.contact_errors(one_off, exact)[:2] == pytest.approx((4e-8, 5e-9), rel=1e-6)


def test_a_missing_or_extra_contact_does_not_meet_the_targets() -> None:
    exact = _sine_contacts()
    extra = {"impacts": [*exact["impacts"], [0.049, 0.0491]],
             "contact_peaks": [*exact["contact_peaks"], D]}
    peak, time, note = eqacc.contact_errors(extra, exact)
    assert "6 contacts vs 5" in note and peak < 1e-15 and time < 1e-15
    point = {"time_s": 1.0, "contacts": 6, "peak_error_m": peak, "impact_time_error_s": time}
    assert not eqacc.meets(point, 5) and eqacc.meets({**point, "contacts": 5}, 5)
    assert eqacc.contact_errors({"impacts": [], "contact_peaks": []}, exact)[0] == math.inf


def test_ladder_search_returns_the_loosest_passing_setting() -> None:
    """A second-order error curve (peak 0.3 m/s² · dt², times 0.1 s⁻¹ · dt²) on a halving dt
    ladder: the loosest dt meeting both targets is the largest dt ≤ √(1e-7/0.3) and
    ≤ √(1e-8/0.1) = 3.16e-4 s; a looser rung with the wrong number of contacts does not count;
    no rung passing gives None and the best is the one nearest to the targets."""
    ladder = [1e-3 / 2**k for k in range(8)]

    def point(dt: float, contacts: int = 9) -> dict:
        return {"time_s": 1 / dt, "contacts": contacts, "peak_error_m": 0.3 * dt**2,
                "impact_time_error_s": 0.1 * dt**2}

    pts = [point(dt) for dt in ladder]
    expected = max(dt for dt in ladder
                   if 0.3 * dt**2 <= 1e-7 and 0.1 * dt**2 <= 1e-8)
    i = eqacc.loosest_passing(pts, 9)
    assert ladder[i] == expected == 2.5e-4
    pts[i] = point(ladder[i], contacts=8)
    assert ladder[eqacc.loosest_passing(pts, 9)] == expected / 2
    failing = [{**p, "peak_error_m": 1.0 + k % 3} for k, p in enumerate(pts)]
    assert eqacc.loosest_passing(failing, 9) is None
    assert eqacc._best(failing) == 0  # peak 1 m at the loosest rung, nearest to the targets


def test_our_reference_agrees_with_scipy() -> None:
    """Our DOP853 at rtol 1e-13 on the paper's SDOF case against SciPy's DOP853 with events at
    rtol 1e-12 (independent of the engine): nine contacts, within 1e-9 m and 1e-10 s."""
    ref = eqacc.reference(paper_sdof())
    assert len(ref["impacts"]) == 9
    assert ref["check"][0] < 1e-9 and ref["check"][1] < 1e-10
    assert max(ref["contact_peaks"]) == pytest.approx(6.186246e-3, abs=1e-9)


def test_bench_peers_with_the_peers_missing_says_so_in_one_line(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        tmp_path: Path) -> None:
    """OpenSeesPy and Exudyn made unimportable: ``bench --peers --quick --write`` still runs
    (exit 0, no traceback), says in one line each which peer is not installed, lists their
    rows as not available, and writes the table and the Pareto PNG."""
    for name in ("openseespy", "openseespy.opensees", "openseespylinux", "exudyn"):
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.setattr(opensees_peer, "_OPS", None)
    monkeypatch.setattr(opensees_peer, "_ERROR", None)
    monkeypatch.setattr(table, "problem_list", lambda quick: [paper_sdof()])
    out = tmp_path / "results.md"
    assert bench_main(["--peers", "--quick", "--write", str(out)]) == 0
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err + captured.out
    for tool in ("OpenSeesPy", "Exudyn"):
        lines = [x for x in captured.err.splitlines() if f"{tool} is not installed" in x]
        assert len(lines) == 1, captured.err
    assert "Equal accuracy (issue 20)" in out.read_text(encoding="utf-8")
    text = out.read_text(encoding="utf-8")
    assert "| OpenSeesPy | Newmark | - | - |" in text and "not available" in text
    assert (tmp_path / table.FIGURE).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"]({table.FIGURE})" in text
    assert "same dt: OpenSeesPy Newmark / ours: - (target >= 50x): not measured" in text
