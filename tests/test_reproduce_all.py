"""``vibroimpact reproduce all -o DIR`` (issue 7): every listed figure and table is written, the
report is self-contained, and the numbers it states are those the API computes directly."""

from __future__ import annotations

import io
import json
import re
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
import vibroimpact as vi
from vibroimpact.integrators import FORCE_METHODS as METHODS  # rigid-gap methods: test_rigid.py
from vibroimpact.paper import cases
from vibroimpact.paper.report import Progress, _fmt

SHAFT = callable(getattr(cases, "hollow_shaft_model", None))

FIGURES = [
    "fig03_force_indentation", "fig04_velocity_indentation",
    "fig06_displacement_integrators", "fig07_velocity_integrators",
    "fig08_displacement_ce9", "fig09_velocity_ce9", "fig10_acceleration_ce9",
    "fig11_displacement_ce5", "fig12_velocity_ce5", "fig13_acceleration_ce5",
    *(["fig17_hollow_shaft", "table4_mode_shapes"] if SHAFT else []),
]
TABLES = ["table3_integrators.csv", "table_two_spheres.csv", "table_sdof_peaks.csv",
          *(["table4_frequencies.csv"] if SHAFT else [])]


@pytest.fixture(scope="module")
def out(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, float, Any]:
    folder = tmp_path_factory.mktemp("paper") / "figures"  # created by the command
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "vibroimpact", "reproduce", "all", "-o",
                           str(folder), "--quiet"], capture_output=True, text=True, timeout=300)
    return folder, time.perf_counter() - start, proc


@pytest.fixture(scope="module")
def numbers(out: tuple[Path, float, Any]) -> dict:
    return json.loads((out[0] / "report.json").read_text())


def test_every_listed_figure_and_table_is_written(out: tuple) -> None:
    folder, elapsed, proc = out
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == "" and proc.stderr == ""  # --quiet (and not a terminal anyway)
    names = {p.name for p in folder.iterdir()}
    for stem in FIGURES:
        assert f"{stem}.png" in names
        assert (folder / f"{stem}.png").read_bytes()[:4] == b"\x89PNG"
    for name in [*TABLES, "report.md", "report.html", "report.json"]:
        assert name in names
    assert not [n for n in names if n.startswith(".")]  # no temporary files left
    assert elapsed < 60


def test_html_report_is_self_contained(out: tuple) -> None:
    folder = out[0]
    text = (folder / "report.html").read_text()
    sources = re.findall(r'src="([^"]*)"', text)
    assert len(sources) == len(FIGURES)
    assert all(s.startswith("data:image/png;base64,") for s in sources)
    assert "href=" not in text and "<script" not in text
    md = (folder / "report.md").read_text()
    for stem in FIGURES:
        assert f"]({stem}.png)" in md


def test_two_sphere_numbers_are_the_apis(out: tuple, numbers: dict) -> None:
    md = (out[0] / "report.md").read_text()
    table = pd.read_csv(out[0] / "table_two_spheres.csv").set_index("law")
    for law in cases.PAPER_LAWS:
        direct = cases.two_spheres(law, 0.5)
        row = numbers["two_spheres"][law]
        assert row["v_out_m_s"] == pytest.approx(direct["v_out"], rel=1e-12)
        assert row["restitution_effective"] == pytest.approx(direct["restitution_effective"],
                                                             rel=1e-12)
        assert row["paper_v_out_m_s"] == cases.TWO_SPHERES_PAPER_V_OUT[law]
        assert table.loc[law, "v_out_m_s"] == pytest.approx(direct["v_out"], rel=1e-12)
        line = next(ln for ln in md.splitlines() if ln.startswith(f"| {law} | "))
        assert f"| {_fmt(direct['v_out'])} |" in line
        assert f"| {_fmt(cases.TWO_SPHERES_PAPER_V_OUT[law])} |" in line


def test_sdof_numbers_are_the_apis(out: tuple, numbers: dict) -> None:
    md = (out[0] / "report.md").read_text()
    for ce in (0.9, 0.5):
        for law in cases.PAPER_LAWS:
            r = vi.simulate(cases.sdof_model(law, ce), t_end=cases.SDOF_T_END, dt=cases.SDOF_DT)
            row = numbers["sdof"][f"{ce}/{law}"]
            assert row["peak_displacement_m"] == pytest.approx(r.max_abs_displacement[0],
                                                               rel=1e-12)
            assert row["impacts"] == len(r.impacts)
            assert _fmt(r.max_abs_displacement[0]) in md
    ln = numbers["sdof"]["0.9/lankarani-nikravesh"]["peak_displacement_m"]
    assert ln == pytest.approx(6.186e-3, rel=1e-3)  # the paper: "about 6 mm"


def test_integrator_table_lists_every_method(out: tuple, numbers: dict) -> None:
    table = pd.read_csv(out[0] / "table3_integrators.csv")
    assert list(table["method"]) == list(METHODS)
    assert list(numbers["integrators"]) == list(METHODS)
    model = cases.sdof_model("lankarani-nikravesh", 0.9)
    for name, cls in METHODS.items():
        r = vi.simulate(model, t_end=cases.SDOF_T_END, dt=cases.SDOF_DT, method=cls())
        row = numbers["integrators"][name]
        assert row["peak_displacement_m"] == pytest.approx(r.max_abs_displacement[0], rel=1e-12)
        assert 0 < row["wall_time_s"] < 1.0
    # the paper's three rows of Table 3, each with its MATLAB time beside our measured one
    md = (out[0] / "report.md").read_text()
    for name, paper_name, seconds in (("newmark", "Newmark-β + Newton–Raphson", 1.3),
                                      ("generalized-alpha", "generalized α", 2.1),
                                      ("precise", "precise integration", 25.0)):
        row = numbers["integrators"][name]
        assert row["paper_matlab_s"] == seconds
        assert f"| {name} ({paper_name}) | {_fmt(seconds)} | {_fmt(row['wall_time_s'], 3)} |" in md


@pytest.mark.skipif(not SHAFT, reason="no hollow-shaft case in this build")
def test_hollow_shaft_numbers_are_the_apis(out: tuple, numbers: dict) -> None:
    from vibroimpact.fe import modes

    md = (out[0] / "report.md").read_text()
    freqs = modes(cases.hollow_shaft_beam("timoshenko"), 3).elastic_frequencies_hz[:3]
    for row, f in zip(numbers["table4"], freqs, strict=True):
        assert row["ours_timoshenko_hz"] == pytest.approx(f, rel=1e-9)
        assert f"| {_fmt(f)} |" in md
    assert [r["paper_reference_hz"] for r in numbers["table4"]] == [477, 1035, 1614]
    hs = numbers["hollow_shaft"]
    assert hs["sliders"] == ["start", "middle", "end"]
    assert all(0.003 < x < 0.004 for x in hs["peak_displacement_m"])  # past the 3 mm walls


def test_progress_lines_only_on_a_terminal() -> None:
    class Tty(io.StringIO):
        def isatty(self) -> bool:
            return True

    tty, pipe = Tty(), io.StringIO()
    for stream in (tty, pipe):
        p = Progress(2, stream=stream)
        with p.item("first") as update:
            update(0.5)
            update(1.0)
        with p.item("second"):
            pass
    assert pipe.getvalue() == ""
    lines = tty.getvalue().split("\n")
    assert lines[0].endswith(tuple(f"[1/2] first done in {x}" for x in ("0.0 s", "0.1 s")))
    assert "100.0%" in lines[0]
    assert "[2/2] second done in" in lines[1]
    quiet = Tty()
    with Progress(1, quiet=True, stream=quiet).item("x"):
        pass
    assert quiet.getvalue() == ""
