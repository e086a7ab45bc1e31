"""Plots of a continued branch (``vibroimpact plot BRANCH.nc --kind branch|multipliers``):
the lines carry the branch's own values (solid where stable, dashed where not), the special
points are marked where they were located, a sweep over the same parameter is drawn under
it, the multipliers lie where the branch has them, and bad kinds, files and options are
one-line errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import vibroimpact as vi
from vibroimpact.cli import main
from vibroimpact.plotting.branch import branch_values, plot_branch

FREQUENCY = "loads.0.frequency"
#: The rigid impact oscillator at w = 2 (``d = 0.2``, ``r = 0.8``, ``ζ = 0.05``).
RIGID_MODEL = Path(__file__).resolve().parents[1] / "examples/models/impact_oscillator_rigid.toml"


@pytest.fixture(scope="module")
def branch_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The rigid stop's period-1 branch through its period-doubling (unstable beyond it)."""
    model = vi.load_model(RIGID_MODEL).model
    branch = vi.continue_orbit(model, FREQUENCY, 2.0 / (2 * np.pi), 2.3 / (2 * np.pi),
                               transient=100, max_points=40)
    path = tmp_path_factory.mktemp("branch") / "branch.nc"
    vi.io.results_file.save(branch.to_dataset(), path)
    return path


def _lines(ax, style: str) -> list:
    return [ln for ln in ax.get_lines() if ln.get_linestyle() == style]


def test_branch_lines_are_the_branch_solid_where_stable_dashed_where_not(branch_file) -> None:
    ds = vi.io.results_file.load(branch_file)
    stable = ds["stable"].values.astype(bool)
    assert stable.any() and not stable.all()  # the fixture crosses the period-doubling
    for quantity in ("amplitude", "displacement", "impact-velocity"):
        ax = plot_branch(branch_file, "branch", quantity=quantity).axes[0]
        x, y = ds["parameter"].values, branch_values(ds, quantity)
        drawn = {"-": [], "--": []}
        for style in drawn:
            for line in _lines(ax, style):
                xs, ys = line.get_xdata(), line.get_ydata()
                idx = [int(np.flatnonzero(x == v)[0]) for v in xs]
                assert np.array_equal(ys, y[idx])
                # every segment but its joining last point has that stability
                assert all(stable[i] == (style == "-") for i in idx[:-1] or idx)
                drawn[style].extend(idx)
        assert set(drawn["-"]) | set(drawn["--"]) == set(range(len(x)))
    amplitude = np.maximum(np.abs(ds["displacement_max"].values[:, 0]),
                           np.abs(ds["displacement_min"].values[:, 0]))
    assert np.array_equal(branch_values(ds, "amplitude"), amplitude)
    assert np.array_equal(branch_values(ds, "displacement"), ds["state"].values[:, 0])
    assert np.all(branch_values(ds, "impact-velocity") > 0)  # one impact a period
    assert ax.get_xlabel() == f"{FREQUENCY} [Hz]"
    assert ax.get_ylabel().endswith("gap 0 [m/s]")


def test_special_points_are_marked_and_named_at_their_values(branch_file) -> None:
    ds = vi.io.results_file.load(branch_file)
    ax = plot_branch(branch_file, "branch", quantity="amplitude").axes[0]
    names = [t.get_text() for t in ax.texts]
    assert names == list(ds["special_type"].values.astype(str))
    assert "period-doubling" in names
    markers = [ln for ln in ax.get_lines() if ln.get_linestyle() == "None"]
    assert [float(m.get_xdata()[0]) for m in markers] == list(ds["special_value"].values)


def test_sweep_under_the_branch(tmp_path: Path, branch_file) -> None:
    from vibroimpact.sweeps import Param, Sweep, run_sweep

    ds = vi.io.results_file.load(branch_file)
    sweep = run_sweep(Sweep(vi.load_model(RIGID_MODEL).model,
                            [Param(FREQUENCY, np.linspace(0.32, 0.36, 5))], dt=0.02,
                            method=vi.EventDriven(), transient=100, periods=4),
                      progress=False)
    ax = plot_branch(ds, "branch", quantity="displacement", sweep=sweep).axes[0]
    (dots,) = ax.collections
    xy = dots.get_offsets()
    expected = sweep["poincare_displacement"].sel(dof=0).values
    assert np.allclose(np.sort(xy[:, 1]), np.sort(expected[np.isfinite(expected)].ravel()))


def test_multipliers_in_the_complex_plane_with_the_unit_circle(branch_file) -> None:
    ds = vi.io.results_file.load(branch_file)
    ax = plot_branch(branch_file, "multipliers").axes[0]
    circle = next(ln for ln in ax.get_lines() if ln.get_label() == "unit circle")
    assert np.allclose(np.hypot(circle.get_xdata(), circle.get_ydata()), 1.0)
    points = ax.collections[0]
    expected = np.column_stack([ds["multiplier_real"].values.ravel(),
                                ds["multiplier_imag"].values.ravel()])
    assert np.array_equal(points.get_offsets(), expected)
    # coloured by the parameter: each multiplier's colour value is its point's parameter
    assert np.array_equal(points.get_array(),
                          np.repeat(ds["parameter"].values, ds.sizes["multiplier"]))


def test_plot_command_draws_a_branch_file(tmp_path: Path, branch_file) -> None:
    out = tmp_path / "branch.png"
    assert main(["plot", str(branch_file), "--kind", "branch", "-o", str(out)]) == 0
    assert out.stat().st_size > 0
    out = tmp_path / "multipliers.svg"
    assert main(["plot", str(branch_file), "--kind", "multipliers", "-o", str(out)]) == 0
    assert out.stat().st_size > 0


@pytest.mark.parametrize(("args", "message"), [
    (["--kind", "branch", "--quantity", "speed"], "--quantity: 'speed' is not valid; expected "
     "one of amplitude, displacement, impact-velocity"),
    (["--kind", "branch", "--dof", "3"], "--dof: 3 is not valid; expected a DOF of the branch"),
    (["--kind", "multipliers", "--quantity", "amplitude"], "--quantity: not an option of "
     "--kind multipliers"),
    (["--kind", "displacement", "--sweep", "s.nc"], "--sweep: not an option of --kind "
     "displacement"),
])
def test_bad_options_are_one_line_errors(tmp_path: Path, capsys, branch_file, args,
                                         message) -> None:
    out = tmp_path / "figure.png"
    code = main(["plot", str(branch_file), *args, "-o", str(out)])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not out.exists()


def test_a_bad_kind_is_refused(branch_file) -> None:
    with pytest.raises(vi.ModelError, match=r"^--kind: 'branches' is not valid; expected one "
                       r"of branch, multipliers$"):
        plot_branch(branch_file, "branches")


def test_a_file_that_is_not_a_branch_is_refused(tmp_path: Path, capsys) -> None:
    run = tmp_path / "run.nc"
    model = vi.Model(vi.Structure.sdof(mass=1.0, stiffness=1.0, damping=0.1))
    vi.simulate(model, 0.1, 0.01).save(run)
    out = tmp_path / "figure.png"
    assert main(["plot", str(run), "--kind", "branch", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "is not valid; expected a branch written by vibroimpact " \
        "continue -o" in err[0], err
    assert main(["plot", str(tmp_path / "missing.nc"), "--kind", "multipliers", "-o",
                 str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "expected an existing result file" in err[0], err
    assert not out.exists()
