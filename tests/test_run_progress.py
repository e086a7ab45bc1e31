"""Issue 7, item 4: the progress bar of a run longer than a second (not with ``--quiet`` or
when stderr is not a terminal) and ``--verbose`` logging of the solver's events as they
happen (step cuts, contacts with their Newton iterations)."""

from __future__ import annotations

import importlib
import io
import itertools
import json
import logging
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import vibroimpact as vi
from test_impulsive_driver import E, oscillator
from vibroimpact.cli import main as cli_main
from vibroimpact.paper import cases
from vibroimpact.simulate import ProgressBar

# the module (``vibroimpact.simulate`` is also the function the package exports)
simulate_module = importlib.import_module("vibroimpact.simulate")
PAPER = Path(__file__).parents[1] / "examples" / "models" / "sdof_paper_ln.toml"


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


class _Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_the_bar_appears_after_the_delay_and_is_throttled() -> None:
    term, clock = _Terminal(), _Clock()
    bar = ProgressBar(0.02, stream=term, clock=clock)
    clock.now = 0.9
    bar.update(0.005)
    assert term.getvalue() == ""  # a run shorter than a second shows nothing
    clock.now = 1.2
    bar.update(0.01)
    assert term.getvalue() == ("\r[###############...............]  50.0 %  t = 1.000e-02 of "
                               "2.000e-02 s  1.2 s")
    clock.now = 1.25
    bar.update(0.015)  # within 0.1 s of the last drawing
    assert term.getvalue().count("\r") == 1
    bar.update(0.02, final=True)  # the end is always drawn
    bar.close()
    last = term.getvalue().split("\r")[-1]
    assert last.startswith("[" + "#" * 30 + "] 100.0 %") and last.endswith("\n")


def test_no_bar_on_a_stream_that_is_not_a_terminal() -> None:
    plain, clock = io.StringIO(), _Clock()
    bar = ProgressBar(1.0, stream=plain, clock=clock)
    clock.now = 5.0
    bar.update(0.5, final=True)
    bar.close()
    assert plain.getvalue() == "" and not bar.enabled


def test_the_cli_draws_the_bar_on_a_terminal_unless_quiet(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(simulate_module, "PROGRESS_DELAY_S", 0.0)  # every run is "long"
    # stderr not a terminal (pytest captures it): no bar
    assert cli_main(["run", str(PAPER)]) == 0
    assert "%" not in capsys.readouterr().err
    term = _Terminal()
    monkeypatch.setattr("sys.stderr", term)
    assert cli_main(["run", str(PAPER), "--quiet"]) == 0
    assert term.getvalue() == ""
    assert cli_main(["run", str(PAPER)]) == 0
    drawn = term.getvalue()
    assert drawn.startswith("\r[") and drawn.endswith("] 100.0 %  t = 2.000e-02 of "
                                                      f"2.000e-02 s  {drawn[-6:-3]} s\n")


def _step_cut_model(tmp_path: Path) -> Path:
    """The paper's SDOF case at dt = 50 µs with 3 Newton iterations: some contact steps are
    cut (tests/test_robustness.py shows the cut run matches a fine one)."""
    text = PAPER.read_text().replace("dt = 1e-6 ", "dt = 5e-5 ")
    text = text.replace('method = "newmark"', 'method = "newmark"\nmax_iterations = 3')
    path = tmp_path / "cuts.toml"
    path.write_text(text)
    return path


def test_verbose_logs_step_cuts_and_contacts_with_time_and_gap(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = _step_cut_model(tmp_path)
    package_logger = logging.getLogger("vibroimpact")
    before = (package_logger.level, package_logger.propagate, list(package_logger.handlers))
    assert cli_main(["run", str(model), "--verbose", "--json"]) == 0
    # the command gives the caller's logging back as it found it (not at INFO, not captured)
    assert (package_logger.level, package_logger.propagate,
            list(package_logger.handlers)) == before
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    log = captured.err.splitlines()
    number = r"([-+0-9.e]+)"
    cuts = [re.fullmatch(rf"vibroimpact: solver: t = {number} s: step cut: Newton did not "
                         rf"converge in 3 iterations \(gap 0, penetration {number} m\) on a "
                         rf"step of 5\.000e-05 s; retrying with shorter steps", line)
            for line in log if "step cut:" in line]
    assert summary["step_cuts"] > 0 and len(cuts) == summary["step_cuts"]
    assert all(m is not None and float(m[2]) > 0 for m in cuts)
    closed = [re.fullmatch(rf"vibroimpact: solver: t = {number} s: gap 0 closed \((positive|"
                           rf"negative) wall\), approach speed {number} m/s", line)
              for line in log if " closed (" in line]
    opened = [re.fullmatch(rf"vibroimpact: solver: t = {number} s: gap 0 opened \((positive|"
                           rf"negative) wall\), separation speed {number} m/s, after (\d+) "
                           rf"steps in contact and (\d+) Newton iterations \([0-9.]+ per step\)",
                           line)
              for line in log if " opened (" in line]
    impacts = summary["impacts"]
    assert len(closed) == len(opened) == len(impacts) == 9
    assert all(m is not None for m in closed + opened)
    for start, end, row in zip(closed, opened, impacts, strict=True):
        # logged with the step that closed (opened) the gap: within one step of the located
        # instant of the impact table, with its speeds and wall
        assert 0 <= float(start[1]) - row["t_start"] <= 5e-5 * (1 + 1e-9)
        assert 0 <= float(end[1]) - row["t_end"] <= 5e-5 * (1 + 1e-9)
        assert start[2] == end[2] == row["side"]
        assert float(start[3]) == pytest.approx(row["v_in"], rel=1e-3)
        # the speed at the end of the opening step (the table's is at the located instant)
        assert float(end[3]) == pytest.approx(row["v_out"], rel=1e-2)
        assert int(end[5]) >= int(end[4]) >= 2
    # the post-run summary lines are still there
    assert sum(line.startswith("vibroimpact: contact: gap 0") for line in log) == 9


def test_without_verbose_no_events_are_collected(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main(["run", str(PAPER)]) == 0
    assert "solver: t =" not in capsys.readouterr().err


def test_api_progress_flag_and_events_logger(caplog: pytest.LogCaptureFixture) -> None:
    model = cases.sdof_model("lankarani-nikravesh")
    with caplog.at_level("INFO", logger="vibroimpact.solver"):
        r = vi.simulate(model, t_end=0.02, dt=1e-6, progress=True)
    closing = [rec for rec in caplog.records if " closed (" in rec.getMessage()]
    assert len(closing) == len(r.impacts) == 9
    times = np.array([rec.args[0] for rec in closing])
    assert np.all((times >= r.impacts.t_start) & (times - r.impacts.t_start <= 1e-6 * 1.001))


def _model(name: str) -> vi.Model:
    """The paper's SDOF case, or tests/test_impulsive_driver.py's impact oscillator at 1.8 Hz
    with a stiff Lankarani–Nikravesh stop or a rigid one."""
    if name == "sdof":
        return cases.sdof_model("lankarani-nikravesh")
    if name == "rigid-stop":
        return oscillator(1.8, vi.contact.Rigid(restitution=E))
    return oscillator(1.8, vi.contact.LankaraniNikravesh(stiffness=1e10, exponent=1.5,
                                                         restitution=E))


@pytest.mark.parametrize(("model", "options"), [
    ("sdof", dict(t_end=10.0, dt=1e-6)),
    ("stiff-stop", dict(t_end=2000.0, dt=1e-3, method=vi.Dop853())),
    ("rigid-stop", dict(t_end=50.0, dt=1e-4, method=vi.EventDriven())),
    ("rigid-stop", dict(t_end=50.0, dt=1e-4, method=vi.MoreauJean())),
], ids=["newmark", "dop853", "event-driven", "moreau-jean"])
def test_the_core_publishes_its_progress_during_the_run(
        monkeypatch: pytest.MonkeyPatch, model: str, options: dict[str, Any]) -> None:
    """Every method reports the simulated time it reached while it runs (0.2–0.8 s here,
    polled every 50 ms): the bar of ``progress=True``, on a clock that lets it draw at every
    poll, is updated with times that grow from inside the run to its end. (How many polls
    fall inside the run depends on the machine's load: one is required.)"""
    bars: list[ProgressBar] = []

    def bar(t_end: float) -> ProgressBar:
        ticks = itertools.count()
        bars.append(ProgressBar(t_end, stream=io.StringIO(), enabled=True, delay=0.0,
                                clock=lambda: float(next(ticks))))
        return bars[-1]

    monkeypatch.setattr(simulate_module, "ProgressBar", bar)
    r = vi.simulate(_model(model), every=1000, progress=True, **options)
    assert r.complete and len(bars) == 1
    drawn = [float(m) for m in re.findall(r"t = ([-+0-9.e]+) of", bars[0].stream.getvalue())]
    inside = [t for t in drawn if 0 < t < options["t_end"]]
    # at least one time from inside the run (a loaded machine may poll only once in it)
    assert len(inside) >= 1 and np.all(np.diff(drawn) >= 0), drawn
    assert drawn[-1] == pytest.approx(options["t_end"], rel=1e-12)


def test_verbose_logs_the_step_cuts_of_adaptive_runs(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Adaptive stepping reports its Newton step cuts too, one line per counted cut."""
    text = _step_cut_model(tmp_path).read_text().replace(
        "max_iterations = 3", "max_iterations = 2\nadaptive = true\nrtol = 1e-4")
    model = tmp_path / "adaptive_cuts.toml"
    model.write_text(text)
    assert cli_main(["run", str(model), "--verbose", "--json"]) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    cuts = [line for line in captured.err.splitlines() if "step cut:" in line]
    assert summary["step_cuts"] > 0 and len(cuts) == summary["step_cuts"]
    assert all("converge in 2 iterations (gap 0" in line for line in cuts)


def test_verbose_logs_the_linear_solver_and_its_size(caplog: pytest.LogCaptureFixture) -> None:
    """The effective stiffness's solver is logged once per run: the dense predictor for the
    paper's SDOF case (n² values), a general sparse factor for a block of 5,880 DOFs of
    hexahedra (3-D: a wide band), whose stored values lie between the lower triangle of
    ``K̃`` and a full triangle, and the banded factor for a 2,004-DOF tube of 3-D beam
    elements (its bending planes, axial and torsional DOFs uncoupled: band 3, n (3 + 1)
    values)."""
    from vibroimpact.benchmarks.large_models import hexahedral_block
    from vibroimpact.fe.beam import Beam, Material, Section

    fe = hexahedral_block((40, 6, 6), (0.5, 0.06, 0.06))
    tube = Beam(1.0, 333, Section.tube(0.19, 0.005), Material(207e9, 0.3, 7850.0),
                dofs_per_node=6)
    models = [(cases.sdof_model("lankarani-nikravesh"), 1e-6),
              (vi.Model(fe.to_structure()), 1e-5), (tube.model(), 1e-5)]
    found = []
    for model, dt in models:
        caplog.clear()
        with caplog.at_level("INFO", logger="vibroimpact.solver"):
            vi.simulate(model, t_end=3 * dt, dt=dt)
        lines = [rec.getMessage() for rec in caplog.records if "effective stiffness" in
                 rec.getMessage()]
        assert len(lines) == 1, lines
        m = re.fullmatch(r"solver: effective stiffness \((\d+) DOFs\) for steps of "
                         r"([0-9.e+-]+) s: ([a-z-]+) factor, (\d+) stored values"
                         r"(?:, bandwidth (\d+))?", lines[0])
        assert m is not None, lines[0]
        assert int(m[1]) == model.n_dof and float(m[2]) == pytest.approx(dt)
        found.append((m[3], int(m[4])))
        assert (m[5] is not None) == (m[3] == "banded"), lines[0]
    assert found[0] == ("dense", 1)
    assert found[2] == ("banded", 4 * tube.n_dof)
    solver, stored = found[1]
    n = fe.n_dof
    lower = (fe.stiffness.nnz + n) // 2
    assert solver.startswith("sparse-") and lower <= stored <= n * (n + 1) // 2


def test_a_run_made_on_one_thread_can_be_dropped_on_another(monkeypatch: Any) -> None:
    """A run's core object made on a worker thread (Dask's, a sweep's) and released on
    another: no "dropped on another thread" complaint, the run's results intact."""
    import sys
    import threading

    from vibroimpact import _core

    made: list[Any] = []

    def keeping_start(*args: Any) -> Any:
        made.append(original(*args))
        return made[-1]

    original = _core.start
    monkeypatch.setattr(_core, "start", keeping_start)
    model = vi.load_model(PAPER)
    results: list[Any] = []
    worker = threading.Thread(target=lambda: results.append(model.simulate()))
    worker.start()
    worker.join()
    assert len(made) == 1 and len(results[0].impacts) > 0
    complaints: list[Any] = []
    monkeypatch.setattr(sys, "unraisablehook", complaints.append)
    made.clear()  # the last reference: dropped here, on the main thread
    assert complaints == []
