"""The paper's hollow shaft (§3.2, docs/paper-cases.md): free–free frequencies against Table 4,
energy conservation of the undamped Hertz run, ``vibroimpact reproduce hollow-shaft`` and the
example model file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from vibroimpact.cli import main as cli_main
from vibroimpact.fe import modes
from vibroimpact.io import load_model
from vibroimpact.paper import cases
from vibroimpact.simulate import simulate

ROOT = Path(__file__).resolve().parents[1]
PAPER = np.array(cases.HOLLOW_SHAFT_PAPER_FREQUENCIES_HZ)


def test_timoshenko_frequencies_match_the_paper() -> None:
    beam = cases.hollow_shaft_beam("timoshenko", 20)
    assert beam.total_mass == pytest.approx(100.0, abs=0.01)
    f = modes(beam, 3)
    assert f.rigid_body_modes == 2  # free-free in the bending plane: translation, rotation
    # Table 4: ABAQUS shell 477 / 1035 / 1614 Hz (the paper's beam: 477 / 1035 / 1637)
    rel = np.abs(f.elastic_frequencies_hz / PAPER - 1)
    assert rel[0] < 0.002 and rel[1] < 0.004 and rel[2] < 0.025
    np.testing.assert_allclose(f.elastic_frequencies_hz, [477, 1035, 1637], rtol=0.007)
    # Euler-Bernoulli ignores shear and rotary inertia: far too stiff for L/r = 15
    eb = modes(cases.hollow_shaft_beam("euler-bernoulli", 20), 3).elastic_frequencies_hz
    assert np.all(eb > 1.15 * PAPER)


def test_undamped_hertz_run_conserves_energy() -> None:
    """No load, no damping, elastic (Hertz) contact: the shaft is kicked towards the sliders
    (1 m/s rigid translation plus its first bending mode) and rattles; the energy account
    must balance, with an error that falls as dt²."""
    beam = cases.hollow_shaft_beam("timoshenko", 20)
    phi = modes(beam, 1).elastic_shapes[:, 0]
    v0 = 1.0 * beam.translation_vector("x") + 0.2 * phi / np.abs(phi).max()
    model = cases.hollow_shaft_model(load=False, initial_velocity=v0)
    errors = {}
    for dt in (2e-6, 1e-6):
        r = simulate(model, t_end=0.03, dt=dt, every=50, dofs=[g.dof for g in model.gaps])
        assert len(r.impacts) >= 6
        assert r.energy.contact_dissipated[-1] == pytest.approx(0.0, abs=1e-12)
        assert np.all(r.energy.damping_dissipated == 0.0)
        assert np.all(r.energy.external_work == 0.0)
        errors[dt] = r.energy.balance_error
    assert errors[1e-6] < 5e-5
    assert errors[2e-6] / errors[1e-6] > 3  # second order


def test_reproduce_hollow_shaft_json(capsys: pytest.CaptureFixture[str]) -> None:
    code = cli_main(["reproduce", "hollow-shaft", "--json", "--t-end", "0.05", "--dt", "5e-6"])
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["frequencies_hz"]) == {"euler-bernoulli", "timoshenko"}
    assert len(out["frequencies_hz"]["timoshenko"]) == 3
    np.testing.assert_allclose(out["frequencies_hz"]["timoshenko"], PAPER, rtol=0.025)
    assert out["sliders"] == ["start", "middle", "end"]
    assert len(out["max_abs_displacement"]) == len(out["impacts"]) == 3
    assert all(isinstance(n, int) for n in out["impacts"]) and sum(out["impacts"]) > 0
    # the sliders hit the chute: peaks just past the 3 mm clearance (the Hertz indentation)
    assert all(0.003 < x < 0.0032 for x in out["max_abs_displacement"])
    assert out["steps"] == 10000 and out["wall_time_s"] > 0
    assert len(out["impact_table"]) == sum(out["impacts"])


def test_reproduce_hollow_shaft_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main(["reproduce", "hollow-shaft", "--t-end", "0.03", "--dt", "1e-5"]) == 0
    text = capsys.readouterr().out
    assert "Euler-Bernoulli" in text and "Timoshenko" in text and "477" in text
    assert "max|x| [mm]" in text and "middle" in text
    assert cli_main(["reproduce", "hollow-shaft", "--elements", "7"]) == 2


def test_the_example_model_file_is_the_case() -> None:
    mf = load_model(ROOT / "examples" / "models" / "hollow_shaft.toml")
    model = cases.hollow_shaft_model()
    for key in ("mass", "stiffness"):
        a, b = getattr(mf.model.structure, key), getattr(model.structure, key)
        np.testing.assert_array_equal(a.toarray(), b.toarray(), err_msg=key)
    assert [g.dof for g in mf.model.gaps] == [g.dof for g in model.gaps] == [0, 20, 40]
    assert [g.law.contact_stiffness for g in mf.model.gaps] == pytest.approx(
        [g.law.contact_stiffness for g in model.gaps])
    assert mf.model.loads[0].dofs == model.loads[0].dofs
    assert mf.beam is not None and mf.beam.n_nodes == 21
