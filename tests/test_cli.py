"""The command line: subprocess runs of the installed entry point."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
import reference


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "vibroimpact", *args],
                          capture_output=True, text=True, timeout=300)


def test_impact_hertz_json_matches_closed_form() -> None:
    p = _cli("impact", "--law", "hertz", "--stiffness", "1e9", "--mass", "0.5",
             "--velocity", "1.2", "--json")
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert set(out) >= {"delta_max", "force_max", "duration", "v_out", "restitution_effective"}
    ref = reference.hertz_closed_form(0.5, 1.2, 1e9)
    assert out["delta_max"] == pytest.approx(ref["delta_max"], rel=1e-10)
    assert out["duration"] == pytest.approx(ref["duration"], rel=1e-10)
    assert out["v_out"] == pytest.approx(1.2, rel=1e-10)


def test_impact_with_a_dissipative_law() -> None:
    p = _cli("impact", "--law", "flores", "--stiffness", "1e9", "--restitution", "0.6",
             "--mass", "0.5", "--velocity", "1.2", "--json")
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    ref = reference.single_impact("flores", 0.5, 1.2, stiffness=1e9, restitution=0.6)
    assert out["restitution_effective"] == pytest.approx(ref["restitution_effective"], abs=1e-9)


@pytest.mark.parametrize(
    ("args", "field"),
    [
        (["--law", "lankarani-nikravesh", "--stiffness", "1e9"], "law.restitution"),
        (["--law", "hertz", "--stiffness=-1e9"], "law.stiffness"),
        (["--law", "flores", "--stiffness", "1e9", "--restitution", "1.5"], "law.restitution"),
    ],
)
def test_impact_bad_parameters_exit_2_with_one_line(args: list[str], field: str) -> None:
    p = _cli("impact", *args, "--mass", "1", "--velocity", "1")
    assert p.returncode == 2
    assert "Traceback" not in p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and field in lines[0]


def test_impact_bad_mass_exit_2() -> None:
    p = _cli("impact", "--law", "hertz", "--stiffness", "1e9", "--mass", "-1", "--velocity", "1")
    assert p.returncode == 2 and "mass" in p.stderr and "Traceback" not in p.stderr


def test_reproduce_sdof_json() -> None:
    p = _cli("reproduce", "sdof", "--json")
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert list(out) == ["hertz", "hunt-crossley", "lankarani-nikravesh", "gonthier", "flores"]
    for law, summary in out.items():
        assert {"max_abs_displacement", "impacts", "steps", "newton_iterations", "wall_time_s",
                "energy_balance_error"} <= set(summary), law
        assert summary["steps"] == 20000
    assert out["hertz"]["max_abs_displacement"][0] == pytest.approx(6.2296e-3, rel=1e-4)
    # dissipative laws penetrate less than Hertz (paper Figs. 8-10)
    for law in ("hunt-crossley", "lankarani-nikravesh", "gonthier", "flores"):
        assert out[law]["max_abs_displacement"][0] < out["hertz"]["max_abs_displacement"][0]


def test_reproduce_two_spheres_json() -> None:
    p = _cli("reproduce", "two-spheres", "--json")
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert out["hertz"]["v_out"] == pytest.approx(0.3, rel=1e-6)
    assert out["flores"]["v_out"] == pytest.approx(0.141, abs=2e-3)
    assert set(out["gonthier"]) >= {"delta_max", "force_max", "duration", "v_out",
                                    "restitution_effective"}


def test_bench_quick_completes() -> None:
    p = _cli("bench", "--quick", "--json")
    assert p.returncode == 0, p.stderr
    rows = json.loads(p.stdout)
    assert {r["law"] for r in rows} == {"hertz", "lankarani-nikravesh"}
    for r in rows:
        assert r["steps"] == 20000 and r["median_s"] > 0 and r["scipy_dop853_s"] > 0
        assert r["peak_displacement_m"] == pytest.approx(r["scipy_peak_displacement_m"], rel=1e-3)


def test_every_subcommand_has_help() -> None:
    for sub in ("run", "impact", "reproduce", "bench"):
        p = _cli(sub, "--help")
        assert p.returncode == 0 and "usage" in p.stdout
