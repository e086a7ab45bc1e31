"""Damping rules that build ``C`` from ``M`` and ``K``: Rayleigh (``C = αM + βK``) and modal
damping (a ratio per mode). Both are classical (they keep the undamped mode shapes).

Example::

    >>> from vibroimpact.fe import Rayleigh
    >>> r = Rayleigh.from_frequencies(100.0, 1000.0, 0.02, 0.02)   # Hz, Hz, ζ1, ζ2
    >>> round(r.damping_ratio(100.0), 6), round(r.damping_ratio(1000.0), 6)
    (0.02, 0.02)
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from numpy.typing import NDArray

from vibroimpact.errors import ModelError

__all__ = ["Damping", "ModalDamping", "Rayleigh", "damping_from_table"]

#: Modal damping builds ``C`` from every mode (dense); above this many DOFs it refuses.
MODAL_DAMPING_LIMIT = 4000


def _number(value: Any, name: str, expected: str, *, minimum: float = 0.0) -> float:
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    if not ok or not math.isfinite(float(value)) or float(value) < minimum:
        raise ModelError(f"{name}: {value!r} is not valid; expected {expected}")
    return float(value)


class Damping:
    """Base of the damping rules: ``matrix(M, K)`` returns ``C`` (N·s/m)."""

    def matrix(self, mass: Any, stiffness: Any) -> Any:
        raise NotImplementedError


@dataclass(frozen=True)
class Rayleigh(Damping):
    """``C = α M + β K`` (Rayleigh 1877; Clough & Penzien, *Dynamics of Structures*, §12-3).
    The damping ratio of a mode at ``ω`` is ``ζ = α/(2ω) + βω/2``.

    ``mass_coefficient`` α in 1/s, ``stiffness_coefficient`` β in s.
    """

    mass_coefficient: float = 0.0
    stiffness_coefficient: float = 0.0

    def __post_init__(self) -> None:
        _number(self.mass_coefficient, "damping.alpha", "a number >= 0 in 1/s")
        _number(self.stiffness_coefficient, "damping.beta", "a number >= 0 in s")

    @classmethod
    def from_frequencies(
        cls, frequency1: float, frequency2: float, ratio1: float, ratio2: float
    ) -> Rayleigh:
        """α, β giving damping ratios ``ratio1`` at ``frequency1`` and ``ratio2`` at
        ``frequency2`` (Hz): ``ζᵢ = α/(2ωᵢ) + βωᵢ/2`` solved for α, β."""
        f1 = _number(frequency1, "damping.frequencies[0]", "a frequency > 0 in Hz")
        f2 = _number(frequency2, "damping.frequencies[1]", "a frequency > 0 in Hz")
        z1 = _number(ratio1, "damping.ratios[0]", "a damping ratio >= 0")
        z2 = _number(ratio2, "damping.ratios[1]", "a damping ratio >= 0")
        if not (f1 > 0 and f2 > 0 and f1 != f2):
            raise ModelError(
                f"damping.frequencies: [{frequency1!r}, {frequency2!r}] is not valid; expected "
                "two different frequencies > 0 in Hz"
            )
        w1, w2 = 2 * math.pi * f1, 2 * math.pi * f2
        a = np.array([[1 / (2 * w1), w1 / 2], [1 / (2 * w2), w2 / 2]])
        alpha, beta = np.linalg.solve(a, [z1, z2])
        if alpha < 0 or beta < 0:
            raise ModelError(
                f"damping.ratios: [{ratio1!r}, {ratio2!r}] is not valid; expected ratios that give "
                f"alpha >= 0 and beta >= 0 (got alpha = {alpha:.4g} 1/s, beta = {beta:.4g} s)"
            )
        return cls(float(alpha), float(beta))

    def damping_ratio(self, frequency: float) -> float:
        """The damping ratio of a mode at ``frequency`` (Hz)."""
        w = 2 * math.pi * frequency
        return self.mass_coefficient / (2 * w) + self.stiffness_coefficient * w / 2

    def matrix(self, mass: Any, stiffness: Any) -> Any:
        return self.mass_coefficient * mass + self.stiffness_coefficient * stiffness


@dataclass(frozen=True)
class ModalDamping(Damping):
    """A damping ratio per mode: ``C = M Φ diag(2 ζⱼ ωⱼ) Φᵀ M`` with mass-normalised modes Φ
    (Craig & Kurdila, *Fundamentals of Structural Dynamics*, §10.4). ``ratios``: one number for
    every mode, or a list for the elastic modes in ascending order (modes beyond the list take
    the last ratio). Rigid-body modes (ω = 0) get no damping. ``C`` is dense (all modes)."""

    ratios: float | Sequence[float] = 0.0

    def __post_init__(self) -> None:
        values = [self.ratios] if not isinstance(self.ratios, Sequence) else list(self.ratios)
        if not values:
            raise ModelError("damping.ratios: [] is not valid; expected at least one ratio")
        for i, z in enumerate(values):
            _number(z, f"damping.ratios[{i}]", "a damping ratio >= 0")

    def ratio_list(self, n: int) -> NDArray[np.float64]:
        values = [self.ratios] if not isinstance(self.ratios, Sequence) else list(self.ratios)
        out = np.full(n, float(values[-1]))
        k = min(n, len(values))
        out[:k] = values[:k]
        return out

    def matrix(self, mass: Any, stiffness: Any) -> NDArray[np.float64]:
        m = mass.toarray() if sp.issparse(mass) else np.asarray(mass, dtype=float)
        k = stiffness.toarray() if sp.issparse(stiffness) else np.asarray(stiffness, dtype=float)
        n = m.shape[0]
        if n > MODAL_DAMPING_LIMIT:
            raise ModelError(
                f"damping: modal damping of {n} DOFs is not supported; expected at most "
                f"{MODAL_DAMPING_LIMIT} DOFs (reduce the model first, or use Rayleigh damping)"
            )
        lam, phi = scipy.linalg.eigh(k, m)
        from vibroimpact.fe.modal import rigid_body_threshold

        omega = np.sqrt(np.clip(lam, 0.0, None))
        rigid = lam <= rigid_body_threshold(k, m)
        n_rigid = int(rigid.sum())
        zeta = np.zeros(n)
        zeta[n_rigid:] = self.ratio_list(n - n_rigid)
        d = np.where(rigid, 0.0, 2 * zeta * omega)
        mp = m @ phi
        c = (mp * d) @ mp.T
        return 0.5 * (c + c.T)


def damping_from_table(d: Mapping[str, Any]) -> Damping:
    """The rule of a model file's checked ``[structure.damping]`` table (beams, matrices):
    ``kind = "modal"`` with ``ratios``, or ``"rayleigh"`` with ``alpha``/``beta`` or with
    ``frequencies`` and ``ratios``; errors name the TOML path."""
    p = "structure.damping"
    if d.get("kind") == "modal":
        return ModalDamping(list(d["ratios"]))
    has_coeff = "alpha" in d or "beta" in d
    has_freq = "frequencies" in d or "ratios" in d
    if has_coeff == has_freq:
        raise ModelError(
            f"{p}: {sorted(k for k in d if k != 'kind')} is not valid; expected alpha/beta or "
            'frequencies and ratios for kind = "rayleigh"'
        )
    if has_coeff:
        return Rayleigh(float(d.get("alpha", 0.0)), float(d.get("beta", 0.0)))
    f, z = d.get("frequencies"), d.get("ratios")
    if f is None or z is None or len(f) != 2 or len(z) != 2:
        raise ModelError(
            f"{p}.frequencies: {f!r} is not valid; expected two frequencies in Hz with two "
            "ratios (frequencies = [f1, f2], ratios = [z1, z2])"
        )
    return Rayleigh.from_frequencies(f[0], f[1], z[0], z[1])
