"""Plots (issue 7): every kind renders on every paper case with the Agg backend, with the axis
labels (units included) and the number of lines it should have; the data drawn are the
result's; figures save as PNG, SVG and PDF; ``vibroimpact plot`` on a saved result."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import matplotlib
import numpy as np
import pytest
import scipy.linalg
import vibroimpact as vi
from matplotlib.backends.backend_agg import FigureCanvasAgg
from vibroimpact import plotting
from vibroimpact.cli import main as cli_main
from vibroimpact.errors import ModelError
from vibroimpact.impact import single_impact_result
from vibroimpact.io import load_model
from vibroimpact.paper import cases

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[1]

#: (x label, y label) each kind must show; written out here, not taken from the code.
LABELS = {
    "displacement": ("time [s]", "displacement [m]"),
    "velocity": ("time [s]", "velocity [m/s]"),
    "acceleration": ("time [s]", "acceleration [m/s²]"),
    "contact-force": ("time [s]", "contact force [N]"),
    "penetration": ("time [s]", "penetration δ [m] (< 0: open)"),
    "force-indentation": ("penetration δ [m]", "contact force [N]"),
    "velocity-indentation": ("penetration δ [m]", "penetration rate dδ/dt [m/s]"),
    "phase": ("displacement [m]", "velocity [m/s]"),
    "energy": ("time [s]", "energy [J]"),
    "impact-map": ("contact start time [s]", "approach speed v_in [m/s]"),
    "spectrum": ("frequency [Hz]", "displacement amplitude [m]"),
    "mode-shapes": ("DOF index [-]", "mode shape, largest component 1 [-]"),
}
PER_DOF = {"displacement", "velocity", "acceleration", "phase", "spectrum"}
PER_GAP = {"contact-force", "penetration", "force-indentation", "velocity-indentation",
           "impact-map"}


def _paper_cases() -> dict[str, vi.Result]:
    out = {
        "two-spheres": single_impact_result(cases.paper_law("flores", 0.5), mass=0.04,
                                            velocity=0.3),
        "sdof": vi.simulate(cases.sdof_model("lankarani-nikravesh", 0.9),
                            t_end=cases.SDOF_T_END, dt=cases.SDOF_DT),
        "two-dof": load_model(ROOT / "examples" / "models" / "two_dof_matrices.toml").simulate(),
    }
    if callable(getattr(cases, "hollow_shaft_model", None)):
        model = cases.hollow_shaft_model()
        sliders = [d for g in model.gaps for d in g.dofs]
        out["hollow-shaft"] = vi.simulate(model, t_end=0.1, dt=1e-5, dofs=sliders)
    return out


CASES = _paper_cases()


def test_the_kinds_are_those_issue_7_asks_for() -> None:
    # (and a rotor's orbit, which needs two DOFs: tests/test_rotor_speed.py)
    assert set(LABELS) | {"orbit"} == set(plotting.KINDS)


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("kind", list(LABELS))
def test_each_kind_renders_on_each_case(case: str, kind: str) -> None:
    result = CASES[case]
    fig = result.plot(kind)
    (ax,) = fig.axes
    assert (ax.get_xlabel(), ax.get_ylabel()) == LABELS[kind]
    lines = ax.get_lines()
    n_dofs, n_gaps = len(result.dofs), result.gap_force.shape[1]
    expected = n_dofs if kind in PER_DOF else n_gaps if kind in PER_GAP else 8
    if kind == "mode-shapes":  # elastic modes (ω² > 0), at most 4
        mass, stiffness, _ = result.model.structure.dense_matrices()
        lam = scipy.linalg.eigh(stiffness, mass, eigvals_only=True)
        expected = min(4, int(np.count_nonzero(lam > 1e-9 * max(1.0, lam.max()))))
    assert len(lines) == expected
    if expected > 1:
        assert len(ax.get_legend().get_texts()) == expected
    FigureCanvasAgg(fig).draw()  # renders with Agg


def test_time_histories_draw_the_result_arrays() -> None:
    r = CASES["two-dof"]
    ax = r.plot("velocity", dofs=[1]).axes[0]
    (line,) = ax.get_lines()
    assert np.array_equal(line.get_xdata(), r.time)
    assert np.array_equal(line.get_ydata(), r.velocity[:, 1])
    ax = r.plot("contact-force", t_min=0.2, t_max=0.4).axes[0]
    x = ax.get_lines()[0].get_xdata()
    assert x.min() >= 0.2 and x.max() <= 0.4


def test_indentation_curves_span_the_contact() -> None:
    r = CASES["two-spheres"]
    imp = r.impacts
    loop = r.plot("force-indentation").axes[0].get_lines()[0]
    delta, force = loop.get_xdata(), loop.get_ydata()
    # the curves join the step ends (about 200 a contact: 5e-6 short of the peaks here); the
    # table has the motion's peaks
    assert np.nanmax(delta) == pytest.approx(imp.delta_max[0], rel=1e-4)
    assert np.nanmax(force) == pytest.approx(imp.force_max[0], rel=1e-4)
    assert np.nanmax(delta) <= imp.delta_max[0] and np.nanmax(force) <= imp.force_max[0]
    rate = r.plot("velocity-indentation").axes[0].get_lines()[0].get_ydata()
    rate = rate[np.isfinite(rate)]
    # starts at the approach speed, ends at minus the separation speed (one step's change)
    assert rate[0] == pytest.approx(0.3, rel=1e-3)
    assert rate[-1] == pytest.approx(-imp.v_out[0], rel=1e-3)


def test_impact_map_one_marker_per_contact_and_phase() -> None:
    r = CASES["two-dof"]
    line = r.plot("impact-map").axes[0].get_lines()[0]
    assert np.array_equal(line.get_xdata(), r.impacts.t_start)
    assert np.array_equal(line.get_ydata(), r.impacts.v_in)
    ax = r.plot("impact-map", x="phase").axes[0]  # period from the 5 Hz harmonic load
    phase = ax.get_lines()[0].get_xdata()
    assert np.allclose(phase, np.mod(r.impacts.t_start, 0.2) / 0.2)
    assert ax.get_xlabel() == "forcing phase (t mod T)/T [-]"
    with pytest.raises(ModelError, match="--period"):
        CASES["sdof"].plot("impact-map", x="phase")


def test_amplitude_spectrum_of_a_sine_peaks_at_its_frequency_and_amplitude() -> None:
    t = np.arange(0, 2.0, 1e-4)
    y = 0.003 * np.sin(2 * math.pi * 50.0 * t) + 0.001 * np.sin(2 * math.pi * 120.0 * t)
    f, a = plotting.amplitude_spectrum(t, y)
    for freq, amp in ((50.0, 0.003), (120.0, 0.001)):
        i = int(np.argmin(np.abs(f - freq)))
        assert a[i] == pytest.approx(amp, rel=0.02)
    # unevenly spaced samples (adaptive steps) are resampled first
    tu = np.sort(np.concatenate([t, t[:-1] + 3e-5]))
    fu, au = plotting.amplitude_spectrum(tu, 0.003 * np.sin(2 * math.pi * 50.0 * tu))
    assert fu[np.argmax(au)] == pytest.approx(50.0, abs=0.6)


def test_compare_overlays_one_line_per_source() -> None:
    runs = {"a": CASES["sdof"], "b": CASES["sdof"]}
    ax = plotting.compare(runs, "displacement").axes[0]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["a", "b"]


def test_bad_options_are_one_line_errors() -> None:
    r = CASES["sdof"]
    with pytest.raises(ModelError, match=r"^--kind: 'nope' is not valid"):
        r.plot("nope")
    with pytest.raises(ModelError, match=r"^--dof: 3 is not valid"):
        r.plot("displacement", dofs=[3])
    with pytest.raises(ModelError, match=r"^quantity: not an option of plot kind 'energy'"):
        r.plot("energy", quantity="velocity")


@pytest.mark.parametrize("suffix", [".png", ".svg", ".pdf"])
def test_figures_save_in_each_format(tmp_path: Path, suffix: str) -> None:
    path = tmp_path / f"fig{suffix}"
    CASES["two-spheres"].plot("force-indentation", path=path)
    head = path.read_bytes()[:5]
    assert head in (b"\x89PNG\r", b"<?xml", b"%PDF-")
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]


def _cli(*args: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "vibroimpact", *map(str, args)],
                          capture_output=True, text=True, timeout=120)


def test_plot_command_on_saved_results(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    r = CASES["two-dof"]
    r.save(tmp_path / "r.nc")
    r.save(tmp_path / "r.csv")
    p = _cli("plot", tmp_path / "r.nc", "--kind", "spectrum", "--quantity", "velocity",
             "--dof", "1", "--f-max", "50", "-o", tmp_path / "s.svg")
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "s.svg").read_text().count("<svg") == 1
    assert cli_main(["plot", str(tmp_path / "r.csv"), "--kind", "energy", "-o",
                     str(tmp_path / "e.png")]) == 0
    assert (tmp_path / "e.png").read_bytes()[:4] == b"\x89PNG"
    capsys.readouterr()
    assert cli_main(["plot", str(tmp_path / "r.nc"), "--kind", "energy", "--dof", "0", "-o",
                     str(tmp_path / "x.png")]) == 2
    assert capsys.readouterr().err.splitlines() == [
        "vibroimpact: error: --dof: not an option of --kind energy; it takes no options"]
    assert cli_main(["plot", str(tmp_path / "missing.nc"), "-o", str(tmp_path / "x.png")]) == 2
    assert len(capsys.readouterr().err.splitlines()) == 1
    assert cli_main(["plot", str(tmp_path / "r.nc"), "-o", str(tmp_path / "x.jpg")]) == 2
    assert "-o" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists() and not (tmp_path / "x.jpg").exists()
