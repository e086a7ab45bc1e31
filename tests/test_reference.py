"""Checks of the independent SciPy reference solver (tests/reference.py) against closed forms."""

from __future__ import annotations

import itertools
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

sys.path.insert(0, str(Path(__file__).resolve().parent))

from reference import (
    bilateral_sdof,
    contact_force,
    hertz_closed_form,
    paper_stiffness,
    single_impact,
)

K_PAPER = paper_stiffness()  # ~1.5089e11 N/m^1.5, ball-in-socket of paper case 1


def test_paper_stiffness() -> None:
    assert K_PAPER == pytest.approx(1.5089e11, rel=1e-3)


@pytest.mark.parametrize(
    ("law", "params", "expected"),
    [
        ("hertz", {"K": 2.0, "n": 1.5}, 2.0 * 0.04**1.5),
        ("hunt-crossley", {"K": 2.0, "ce": 0.8}, 2.0 * 0.04**1.5 * (1 + 1.5 * 0.2 * 0.5)),
        ("hunt-crossley", {"K": 2.0, "b": 3.0}, 0.04**1.5 * (2.0 + 3.0 * 1.0)),
        ("lankarani-nikravesh", {"K": 2.0, "ce": 0.8}, 2.0 * 0.04**1.5 * (1 + 0.75 * 0.36 * 0.5)),
        ("gonthier", {"K": 2.0, "ce": 0.8}, 2.0 * 0.04**1.5 * (1 + 0.36 / 0.8 * 0.5)),
        ("flores", {"K": 2.0, "ce": 0.8}, 2.0 * 0.04**1.5 * (1 + 1.6 / 4.0 * 0.5)),
        ("kelvin-voigt", {"k": 2.0, "c": 3.0}, 2.0 * 0.04 + 3.0 * 1.0),
    ],
)
def test_contact_force_formulas(law: str, params: dict, expected: float) -> None:
    # delta = 0.04, delta_dot = 1.0, v_imp = 2.0 (delta_dot / v_imp = 0.5)
    assert contact_force(law, 0.04, 1.0, 2.0, **params) == pytest.approx(expected, rel=1e-14)
    assert contact_force(law, -0.01, 1.0, 2.0, **params) == 0.0


def test_contact_force_never_tensile() -> None:
    assert contact_force("kelvin-voigt", 1e-3, -1.0, 1.0, k=1e3, c=10.0) == 0.0
    assert contact_force("flores", 1e-3, -1.0, 1.0, K=1e9, ce=0.3) == 0.0


def test_hertz_single_impact_closed_form() -> None:
    m, v0 = 0.04, 0.3
    exact = hertz_closed_form(m, v0, K_PAPER)
    # duration = 2 delta_max/v0 * int_0^1 dx / sqrt(1 - x^2.5) = 2.9432752 delta_max/v0
    integral = quad(lambda x: (1.0 - x**2.5) ** -0.5, 0.0, 1.0, limit=200, epsabs=1e-14)[0]
    assert exact["duration"] * v0 / exact["delta_max"] == pytest.approx(2 * integral, rel=1e-11)
    r = single_impact("hertz", m, v0, K=K_PAPER)
    for key in ("delta_max", "force_max", "duration"):
        assert r[key] == pytest.approx(exact[key], rel=1e-8), key
    assert abs(r["restitution_effective"] - 1.0) < 1e-9
    assert r["v_out"] == pytest.approx(v0, rel=1e-9)


def test_single_impact_paper_case_restitutions() -> None:
    # Paper case 1 (ce = 0.5): ~0.2 m/s (HC, LN), ~0.15 m/s (Gonthier, Flores).
    v_out = {
        law: single_impact(law, 0.04, 0.3, K=K_PAPER, ce=0.5)["v_out"]
        for law in ("hunt-crossley", "lankarani-nikravesh", "gonthier", "flores")
    }
    assert 0.18 < v_out["hunt-crossley"] < 0.23
    assert 0.18 < v_out["lankarani-nikravesh"] < 0.23
    assert 0.13 < v_out["gonthier"] < 0.16
    assert 0.13 < v_out["flores"] < 0.16


def test_kelvin_voigt_clamped_separation_matches_analytic() -> None:
    m, k, c, v0 = 1.0, 1e6, 200.0, 1.0
    w = math.sqrt(k / m)
    z = c / (2.0 * math.sqrt(k * m))
    wd = w * math.sqrt(1.0 - z * z)

    def delta(t: float) -> float:
        return v0 / wd * math.exp(-z * w * t) * math.sin(wd * t)

    def rate(t: float) -> float:
        return v0 / wd * math.exp(-z * w * t) * (wd * math.cos(wd * t) - z * w * math.sin(wd * t))

    t_clamp = brentq(
        lambda t: k * delta(t) + c * rate(t),
        0.5 * math.pi / wd,
        math.pi / wd,
        xtol=1e-16,
        rtol=1e-15,
    )
    v_out = -rate(t_clamp)
    duration = t_clamp + delta(t_clamp) / v_out  # free flight at constant speed after the clamp
    r = single_impact("kelvin-voigt", m, v0, k=k, c=c)
    assert r["v_out"] == pytest.approx(v_out, rel=1e-9)
    assert r["duration"] == pytest.approx(duration, rel=1e-9)


def test_bilateral_hertz_timing_and_energy() -> None:
    m, d, v0 = 100.0, 5e-3, 8.0
    r = bilateral_sdof("hertz", m, d, v0, 0.01, K=K_PAPER)
    imps = r["impacts"]
    assert len(imps) >= 5
    assert abs(imps[0]["t_start"] - d / v0) < 1e-12
    assert [i["side"] for i in imps[:4]] == ["positive", "negative", "positive", "negative"]
    exact = hertz_closed_form(m, v0, K_PAPER)
    for a, b in itertools.pairwise(imps):
        assert abs(abs(b["v_in"]) - abs(a["v_out"])) <= 1e-12 * v0
        assert abs(a["v_out"] - v0) <= 1e-9 * v0
        assert a["delta_max"] == pytest.approx(exact["delta_max"], rel=1e-8)
        assert a["t_end"] - a["t_start"] == pytest.approx(exact["duration"], rel=1e-8)
        # free flight across the clearance 2d at constant speed
        assert b["t_start"] - a["t_end"] == pytest.approx(2 * d / v0, rel=1e-9)
    assert r["max_abs_displacement"] == pytest.approx(d + exact["delta_max"], rel=1e-8)
    assert len(r["t"]) == 2001 and r["x"].shape == r["v"].shape == (2001,)


def test_bilateral_free_oscillator_without_impacts() -> None:
    m, k, v0 = 2.0, 800.0, 0.1  # amplitude v0/w = 5 mm < clearance
    w = math.sqrt(k / m)
    r = bilateral_sdof("hertz", m, 0.01, v0, 0.2, stiffness=k, K=1e9)
    assert r["impacts"] == []
    assert np.allclose(r["x"], v0 / w * np.sin(w * r["t"]), rtol=0, atol=1e-14)
    assert r["max_abs_displacement"] == pytest.approx(v0 / w, rel=1e-11)
