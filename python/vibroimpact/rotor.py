"""Rotors (docs/rotors.md): the Campbell diagram of a spinning structure, the synchronous
unbalance response and its rub-onset speeds, and ROSS rotors brought over (:func:`from_ross`).

A rotor is a :class:`~vibroimpact.Structure` with a spin speed Ω and a gyroscopic matrix
``G``: ``M x'' + (C + Ω G) x' + K x = F`` (``Structure.jeffcott``, a beam with
``dofs_per_node = 4``, or matrices with ``gyroscopic``); unbalance loads
(:class:`~vibroimpact.UnbalanceLoad`) turn with it.

Example — a Jeffcott rotor's response and where it first reaches a 1 mm clearance::

    >>> import vibroimpact as vi
    >>> from vibroimpact import rotor
    >>> model = vi.Model(vi.Structure.jeffcott(mass=10.0, stiffness=1e6, damping=200.0),
    ...                  loads=[vi.UnbalanceLoad(dof=[0, 1], magnitude=1e-3)])
    >>> [round(w, 1) for w in rotor.rub_onset_speeds(model, [0, 1], 1e-3, (1.0, 1000.0))]
    [304.9, 329.6]
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
import scipy.optimize
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibroimpact.errors import ModelError, require
from vibroimpact.fe.dofs import DofMap, FEStructure
from vibroimpact.model import Model, Structure, UnbalanceLoad
from vibroimpact.result import Result

__all__ = [
    "Campbell",
    "FullSpectrum",
    "PerRevolution",
    "Waterfall",
    "campbell",
    "from_ross",
    "full_spectrum",
    "orbit_radius",
    "per_revolution",
    "plot_campbell",
    "plot_waterfall",
    "revolution_times",
    "rub_onset_speeds",
    "translation_pairs",
    "unbalance_response",
    "waterfall",
]

#: A mode whose x and y DOFs move less than this fraction of its whole shape (an axial or
#: torsional mode) has no whirl: ``"none"``.
LATERAL_FLOOR = 1e-6
#: A node's x and y DOFs move less than this fraction of the mode's largest such motion: it
#: does not count in the mode's whirl direction.
WHIRL_AMPLITUDE_FLOOR = 1e-3
#: A node's orbit whose signed area ``|Im(X̄ Y)|`` is below this fraction of ``|X|² + |Y|²``
#: is a line (planar motion): it does not count either.
PLANAR_ORBIT_TOLERANCE = 1e-6


#: An eigenvalue below this fraction of the largest ``|λ|`` is a rigid-body mode.
RIGID_BODY_RTOL = 1e-7


def _dense(a: Any) -> NDArray[np.float64]:
    return np.asarray(a.toarray() if sp.issparse(a) else a, dtype=float)


def translation_pairs(dof_map: DofMap | None, n_dof: int) -> list[tuple[int, int]]:
    """The ``(x, y)`` DOF pairs of every node that has both (a DOF map's order); without a
    map a 2-DOF structure (a Jeffcott rotor) is the pair ``(0, 1)``."""
    if dof_map is None:
        require(n_dof == 2, "structure", f"{n_dof} DOFs without a DOF map",
                "a DOF map (beam, matrices with dof_map) or a Jeffcott rotor (2 DOFs: x, y)")
        return [(0, 1)]
    pairs = []
    for node in dof_map.node_labels:
        try:
            pairs.append((dof_map.index(node, "x"), dof_map.index(node, "y")))
        except ModelError:
            continue
    require(bool(pairs), "structure.dof_map", "no node with both x and y",
            "a rotor with x and y DOFs at its nodes")
    return pairs


@dataclass(frozen=True)
class Campbell:
    """The Campbell diagram: for each of ``speeds`` (rad/s, spin speed Ω) the first modes'
    damped natural frequencies ``frequencies`` (rad/s, rows: speeds, columns: modes in
    increasing frequency), their damping ratios ``damping_ratios`` (``−Re λ / |λ|``) and
    ``whirl``: ``"forward"`` (every moving node orbits with the spin), ``"backward"``
    (against it), ``"mixed"`` (both, or planar orbits) or ``"none"`` (no x–y motion: an
    axial or torsional mode)."""

    speeds: NDArray[np.float64]
    frequencies: NDArray[np.float64]
    damping_ratios: NDArray[np.float64]
    whirl: tuple[tuple[str, ...], ...]

    @property
    def frequencies_hz(self) -> NDArray[np.float64]:
        return self.frequencies / (2 * math.pi)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: ``speeds_rad_s``, ``frequencies_rad_s``, ``frequencies_hz``,
        ``damping_ratios`` (rows: speeds) and ``whirl``."""
        return {
            "speeds_rad_s": self.speeds.tolist(),
            "frequencies_rad_s": self.frequencies.tolist(),
            "frequencies_hz": self.frequencies_hz.tolist(),
            "damping_ratios": self.damping_ratios.tolist(),
            "whirl": [list(w) for w in self.whirl],
        }


def _whirl(shape: NDArray[np.complex128], pairs: Sequence[tuple[int, int]]) -> str:
    """Forward, backward or mixed: the sense of each moving node's orbit in the mode
    ``x(t) = Re(shape e^{iωt})`` (ω > 0), counter-clockwise in x–y (with the spin about +z)
    when its signed area ``−π Im(X̄ Y)`` is positive."""
    x = np.array([shape[i] for i, _ in pairs])
    y = np.array([shape[j] for _, j in pairs])
    size = np.abs(x) ** 2 + np.abs(y) ** 2
    if size.sum() <= LATERAL_FLOOR**2 * float(np.vdot(shape, shape).real):
        return "none"
    area = -np.imag(np.conj(x) * y)
    moving = size > WHIRL_AMPLITUDE_FLOOR * size.max()
    senses = {float(np.sign(a)) for a, s, m in zip(area, size, moving, strict=True)
              if m and abs(a) > PLANAR_ORBIT_TOLERANCE * s}
    if senses == {1.0}:
        return "forward"
    if senses == {-1.0}:
        return "backward"
    return "mixed"


def campbell(structure: Structure, speeds: ArrayLike, n_modes: int = 6,
             pairs: Sequence[tuple[int, int]] | None = None) -> Campbell:
    """The Campbell diagram of ``structure`` at each spin speed of ``speeds`` (rad/s): the
    ``n_modes`` lowest damped natural frequencies of ``M x'' + (C + Ω G) x' + K x = 0``
    (the generalized eigenproblem ``A z = λ B z`` of its first-order form, dense LAPACK;
    rigid-body modes, ``|λ|`` below :data:`RIGID_BODY_RTOL` of the largest, left out) and
    their whirl at the ``(x, y)`` DOF ``pairs``
    (default :func:`translation_pairs` without a map: a Jeffcott rotor)."""
    w = np.atleast_1d(np.asarray(speeds, dtype=float))
    require(w.ndim == 1 and w.size > 0 and bool(np.all(np.isfinite(w))), "speeds", speeds,
            "finite spin speeds in rad/s")
    require(isinstance(n_modes, int) and n_modes >= 1, "n_modes", n_modes, "an integer >= 1")
    m, k, c = structure.dense_matrices()
    g = np.zeros_like(m) if structure.gyroscopic is None else _dense(structure.gyroscopic)
    n = m.shape[0]
    pairs = translation_pairs(None, n) if pairs is None else list(pairs)
    eye, zero = np.eye(n), np.zeros((n, n))
    b = np.block([[eye, zero], [zero, m]])
    rows_f, rows_z, rows_w = [], [], []
    for omega in w:
        a = np.block([[zero, eye], [-k, -(c + omega * g)]])
        lam, vec = scipy.linalg.eig(a, b)
        finite = np.isfinite(lam)
        # rigid-body modes: |λ| at round-off of the largest
        floor = RIGID_BODY_RTOL * float(np.abs(lam[finite]).max(initial=0.0))
        keep = finite & (lam.imag > floor)
        lam, vec = lam[keep], vec[:n, keep]
        order = np.argsort(lam.imag)[:n_modes]
        require(order.size == n_modes, "n_modes", n_modes,
                f"at most {order.size} vibrating modes (the structure has {n} DOFs)")
        lam, vec = lam[order], vec[:, order]
        rows_f.append(lam.imag)
        rows_z.append(-lam.real / np.abs(lam))
        rows_w.append(tuple(_whirl(vec[:, j], pairs) for j in range(n_modes)))
    return Campbell(w, np.array(rows_f), np.array(rows_z), tuple(rows_w))


def unbalance_response(model: Model, speeds: ArrayLike) -> NDArray[np.complex128]:
    """The steady synchronous response to the model's unbalance loads at each spin speed of
    ``speeds`` (rad/s): complex amplitudes ``Z`` (rows: speeds, columns: DOFs) with
    ``x(t) = Re(Z e^{iΩt})``, from ``(K − Ω² M + iΩ (C + Ω G)) Z = F̂`` and
    ``F̂ = m e Ω² e^{iφ} (1, −i)`` on each load's ``(x, y)`` DOFs. Other loads and the gaps
    are not part of it (the response without contact)."""
    w = np.atleast_1d(np.asarray(speeds, dtype=float))
    require(w.ndim == 1 and bool(np.all(np.isfinite(w))), "speeds", speeds,
            "finite spin speeds in rad/s")
    unbalances = [ld for ld in model.loads if isinstance(ld, UnbalanceLoad)]
    require(bool(unbalances), "loads", "no unbalance load", "an UnbalanceLoad")
    st = model.structure
    m, k, c = st.dense_matrices()
    g = np.zeros_like(m) if st.gyroscopic is None else _dense(st.gyroscopic)
    out = np.zeros((w.size, st.n_dof), dtype=complex)
    for row, omega in enumerate(w):
        f = np.zeros(st.n_dof, dtype=complex)
        for ld in unbalances:
            ix, iy = ld.dofs
            amp = ld.magnitude * omega**2 * np.exp(1j * ld.phase)
            f[ix] += amp
            f[iy] += -1j * amp
        dynamic = k - omega**2 * m + 1j * omega * (c + omega * g)
        out[row] = np.linalg.solve(dynamic, f)
    return out


def orbit_radius(z: ArrayLike, dofs: Sequence[int]) -> NDArray[np.float64]:
    """The largest distance from the centre of the elliptic orbit ``x = Re(X e^{iΩt})``,
    ``y = Re(Y e^{iΩt})`` at the DOFs ``dofs = [ix, iy]`` of complex amplitudes ``z`` (one
    row per speed): ``√((|X|² + |Y|²)/2 + |X² + Y²|/2)``, m."""
    a = np.atleast_2d(np.asarray(z))
    x, y = a[:, dofs[0]], a[:, dofs[1]]
    return np.sqrt(0.5 * (np.abs(x) ** 2 + np.abs(y) ** 2) + 0.5 * np.abs(x**2 + y**2))


def rub_onset_speeds(model: Model, dofs: Sequence[int], clearance: float,
                     speed_range: tuple[float, float], samples: int = 400) -> list[float]:
    """The spin speeds (rad/s) in ``speed_range`` at which the synchronous unbalance orbit at
    ``dofs = [ix, iy]`` (:func:`unbalance_response`, :func:`orbit_radius`) reaches
    ``clearance`` (m): each crossing of ``samples`` log-spaced speeds refined by Brent's method
    to a relative 1e-14."""
    require(len(dofs) == 2, "dofs", dofs, "two DOFs [ix, iy]")
    require(math.isfinite(clearance) and clearance > 0, "clearance", clearance,
            "a clearance > 0 in m")
    lo, hi = (float(v) for v in speed_range)
    require(0 < lo < hi and math.isfinite(hi), "speed_range", speed_range,
            "two speeds 0 < low < high in rad/s")

    def excess(omega: float) -> float:
        return float(orbit_radius(unbalance_response(model, [omega]), dofs)[0]) - clearance

    grid = np.geomspace(lo, hi, samples)
    values = [excess(w) for w in grid]
    roots = []
    for a, b, fa, fb in zip(grid[:-1], grid[1:], values[:-1], values[1:], strict=True):
        if fa == 0:
            roots.append(float(a))
        elif fa * fb < 0:
            roots.append(float(scipy.optimize.brentq(excess, a, b, xtol=1e-14 * b, rtol=1e-15)))
    return roots


@dataclass(frozen=True)
class FullSpectrum:
    """The full spectrum of an orbit: ``frequency`` (Hz, ascending, signed: > 0 forward whirl,
    with the spin; < 0 backward) and each line's ``amplitude`` (m: the radius of its circular
    whirl) and ``phase`` (rad, at the record's first sample)."""

    frequency: NDArray[np.float64]
    amplitude: NDArray[np.float64]
    phase: NDArray[np.float64]

    def at(self, frequency: float) -> float:
        """The amplitude (m) of the line nearest ``frequency`` (Hz, signed)."""
        return float(self.amplitude[int(np.argmin(np.abs(self.frequency - frequency)))])


def full_spectrum(x: ArrayLike, y: ArrayLike, dt: float) -> FullSpectrum:
    """The forward/backward whirl decomposition of the orbit ``x(t), y(t)`` (m, sampled every
    ``dt`` s): the discrete Fourier transform of ``z = x + i y``, ``Z_k / N`` (Goldman &
    Muszynska, *Orbit Monitoring and Full Spectrum*, 1999): ``z = Σ_k Z_k e^{i 2π f_k t}`` is a
    sum of circular whirls of radius ``|Z_k| / N``, forward for ``f_k > 0``. No window: a line
    at a frequency that fits a whole number of times in the record is exact, any other leaks
    into its neighbours."""
    xa = np.asarray(x, dtype=float).ravel()
    ya = np.asarray(y, dtype=float).ravel()
    require(xa.size == ya.size and xa.size >= 2, "y", f"{ya.size} samples",
            f"as many samples as x ({xa.size}), at least 2")
    require(bool(np.all(np.isfinite(xa)) and np.all(np.isfinite(ya))), "x, y", "NaN",
            "finite displacements in m")
    require(math.isfinite(dt) and dt > 0, "dt", dt, "a sampling step > 0 in s")
    z = np.fft.fftshift(np.fft.fft(xa + 1j * ya)) / xa.size
    f = np.fft.fftshift(np.fft.fftfreq(xa.size, dt))
    return FullSpectrum(f, np.abs(z), np.angle(z))


@dataclass(frozen=True)
class Waterfall:
    """Full spectra over a speed sweep: at each ``speeds`` (rad/s; the swept
    ``structure.spin_speed``) the lines ``frequency`` (Hz, signed: > 0 forward whirl, < 0
    backward; rows: speeds) and their ``amplitude`` (m, radius of each circular whirl)."""

    speeds: NDArray[np.float64]
    frequency: NDArray[np.float64]
    amplitude: NDArray[np.float64]


def waterfall(sweep: Any, dofs: Sequence[int] | None = None) -> Waterfall:
    """The :func:`full_spectrum` of each point of a sweep over ``structure.spin_speed`` (a
    Dataset or file of :func:`vibroimpact.sweeps.run_sweep` / ``vibroimpact sweep``, run with
    ``samples_per_period`` > 1: its samples are the orbit every ``T / N``) at the sampled
    DOFs ``dofs = [ix, iy]`` (default the first two)."""
    from vibroimpact.sweeps.plot import sweep_dataset

    ds = sweep_dataset(sweep)
    path = "structure.spin_speed"
    require(path in ds.dims and len(ds.dims) > 0 and "direction" not in ds.dims
            and sum(d not in ("sample", "dof", "gap", "impact", "model_dof") for d in ds.dims)
            == 1, "sweep", f"parameters {ds.attrs.get('params', '')}",
            "a sweep over structure.spin_speed alone (one direction)")
    per_period = int(ds.attrs.get("samples_per_period", 1))
    require(per_period >= 4, "--samples-per-period", per_period,
            "a sweep run with --samples-per-period of at least 4 (a spectrum per speed)")
    sampled = [int(d) for d in ds["dof"].values]
    ix, iy = (sampled[:2] if dofs is None else [int(d) for d in dofs])
    for d in (ix, iy):
        require(d in sampled, "--dof", d, f"one of the sampled DOFs {sampled}")
    x = ds["poincare_displacement"].sel(dof=ix).values
    y = ds["poincare_displacement"].sel(dof=iy).values
    periods = ds["forcing_period"].values
    freqs, amps = [], []
    for k in range(x.shape[0]):
        s = full_spectrum(x[k], y[k], float(periods[k]) / per_period)
        freqs.append(s.frequency)
        amps.append(s.amplitude)
    return Waterfall(np.asarray(ds[path].values, dtype=float), np.array(freqs), np.array(amps))


def plot_waterfall(sweep: Any, dofs: Sequence[int] | None = None, path: Any = None,
                   title: str | None = None) -> Any:
    """The full-spectrum waterfall of a speed sweep (:func:`waterfall`): each speed's
    spectrum as a line raised by its speed (rad/s, vertical axis) against the whirl frequency
    (Hz, horizontal: backward < 0 < forward), scaled so that the largest line spans the
    speed step, with the ±1× lines ``f = ±Ω / 2π``."""
    from vibroimpact.plotting import new_figure, save_figure

    w = waterfall(sweep, dofs)
    fig, ax = new_figure(height=5.0)
    step = float(np.ptp(w.speeds)) / max(len(w.speeds) - 1, 1) or 1.0
    scale = step / max(float(w.amplitude.max()), np.finfo(float).tiny)
    for speed, f, a in zip(w.speeds, w.frequency, w.amplitude, strict=True):
        ax.plot(f, speed + scale * a, color="C0", lw=0.8)
    for sign, text in ((1, "+1x (forward)"), (-1, "-1x (backward)")):
        ax.plot(sign * w.speeds / (2 * math.pi), w.speeds, "k--", lw=0.6, alpha=0.6,
                label=text)
    ax.set_xlabel("whirl frequency [Hz] (< 0: backward, > 0: forward)")
    ax.set_ylabel(f"spin speed [rad/s] (lines: amplitude, {step / scale:.3g} m per step)")
    ax.legend(fontsize="small", loc="upper right")
    ax.grid(True, alpha=0.3)
    ax.set_title(title or "full-spectrum waterfall")
    if path is not None:
        save_figure(fig, path)
    return fig


def revolution_times(structure: Structure, t_end: float, t_start: float = 0.0,
                     phase: float = 0.0) -> NDArray[np.float64]:
    """The instants in ``[t_start, t_end]`` (s) at which the rotor has turned a whole number
    of revolutions past ``phase`` (rad): ``∫₀ᵗ Ω dt = 2π k + phase``, inverted in closed form
    for the structure's spin profile (constant: ``t = θ/Ω``; during a linear run-up
    ``Ω₀ t + ½ Ω̇ t² = θ``, ``t = 2θ / (Ω₀ + √(Ω₀² + 2 Ω̇ θ))``). Needs ``Ω ≥ 0``."""
    require(structure.spin_speed >= 0 and (structure.spin_speed_end or 0.0) >= 0,
            "structure.spin_speed", structure.spin_speed,
            "a spin speed >= 0 (and spin_speed_end >= 0) for revolutions")
    require(math.isfinite(t_end) and t_end >= t_start >= 0, "t_end", t_end,
            f"an instant >= t_start = {t_start} >= 0 in s")
    angle = structure.spin(np.array([t_start, t_end]))[2]
    k = np.arange(math.ceil((angle[0] - phase) / (2 * math.pi) - 1e-12),
                  math.floor((angle[1] - phase) / (2 * math.pi) + 1e-12) + 1)
    theta = 2 * math.pi * k + phase
    theta = theta[theta >= 0]
    w0 = structure.spin_speed
    if structure.spin_profile == "constant":
        require(w0 > 0, "structure.spin_speed", w0, "a spin speed > 0 for revolutions")
        return np.asarray(theta / w0, dtype=float)
    w1, duration = float(structure.spin_speed_end), float(structure.run_up_time)  # type: ignore[arg-type]
    slope = (w1 - w0) / duration
    theta_end = 0.5 * (w0 + w1) * duration
    ramp = theta < theta_end
    with np.errstate(divide="ignore", invalid="ignore"):
        during = 2 * theta / (w0 + np.sqrt(np.maximum(w0 * w0 + 2 * slope * theta, 0.0)))
        after = duration + (theta - theta_end) / w1
    t = np.where(ramp, during, after)
    return np.asarray(t[(t >= t_start - 1e-12 * max(t_end, 1.0)) & np.isfinite(t)], dtype=float)


@dataclass(frozen=True)
class PerRevolution:
    """The once-per-revolution Poincaré section of a run: at each ``time`` (s) that the
    rotor has turned a whole revolution (:func:`revolution_times`), the ``displacement`` and
    ``velocity`` of the result's recorded DOFs (rows: revolutions); ``revolution`` counts
    them from ``t = 0``; ``speed`` is ``Ω`` there (rad/s)."""

    time: NDArray[np.float64]
    revolution: NDArray[np.int64]
    speed: NDArray[np.float64]
    displacement: NDArray[np.float64]
    velocity: NDArray[np.float64]


def per_revolution(result: Result, model: Model | None = None, phase: float = 0.0,
                   transient: float = 0.0) -> PerRevolution:
    """The once-per-revolution section of ``result`` (its model's spin profile, or that of
    ``model``) from ``transient`` s on, at the angle ``phase`` (rad): each sample is the
    cubic Hermite interpolant of the recorded rows (displacement with the velocity as its
    derivative, velocity with the acceleration), exact where a row lands on the revolution
    (a constant spin with a whole number of steps per revolution)."""
    from scipy.interpolate import CubicHermiteSpline

    model = result.model if model is None else model
    require(model is not None, "model", None, "the model of the run (the result has none)")
    assert model is not None
    t = np.asarray(result.time, dtype=float)
    require(t.size >= 2, "result.time", f"{t.size} rows", "at least 2 recorded rows")
    st = model.structure
    times = revolution_times(st, float(t[-1]), max(float(t[0]), transient), phase)
    turns = np.rint((st.spin(times)[2] - phase) / (2 * math.pi)).astype(np.int64)
    x = CubicHermiteSpline(t, result.displacement, result.velocity, axis=0)(times)
    v = CubicHermiteSpline(t, result.velocity, result.acceleration, axis=0)(times)
    return PerRevolution(times, turns, st.spin(times)[0], np.atleast_2d(x), np.atleast_2d(v))


def from_ross(rotor: Any, speed: float = 0.0) -> FEStructure:
    """A ROSS rotor (``ross.Rotor``, the optional extra ``ross``) as an
    :class:`~vibroimpact.fe.FEStructure` spinning at ``speed`` (rad/s): ROSS's ``M()``,
    ``K(speed)``, ``C(speed)`` (its bearings' coefficients at that speed) and ``G()``, and a
    DOF map of its nodes (ROSS's directions x, y, z, α, β, θ per node as x, y, z, rx, ry, rz;
    4 per node: x, y, rx, ry)."""
    try:
        m = _dense(rotor.M(speed) if _takes_speed(rotor.M) else rotor.M())
        k, c, g = _dense(rotor.K(speed)), _dense(rotor.C(speed)), _dense(rotor.G())
        per_node = int(rotor.number_dof)
        nodes = [int(v) for v in rotor.nodes]
    except AttributeError as e:
        raise ModelError(f"rotor: {type(rotor).__name__} is not valid ({e}); expected a "
                         "ross.Rotor") from None
    names = {4: ("x", "y", "rx", "ry"), 6: ("x", "y", "z", "rx", "ry", "rz")}
    require(per_node in names, "rotor.number_dof", per_node, "4 or 6 DOFs per node")
    require(m.shape[0] == per_node * len(nodes), "rotor.M", f"shape {m.shape}",
            f"{per_node} DOFs for each of its {len(nodes)} nodes")
    dof_map = DofMap([n for n in nodes for _ in range(per_node)],
                     [d for _ in nodes for d in names[per_node]])
    return FEStructure(m, k, c, dof_map, gyroscopic=g, spin_speed=float(speed))


def _takes_speed(method: Any) -> bool:
    import inspect

    try:
        return len(inspect.signature(method).parameters) > 0
    except (TypeError, ValueError):
        return False


def plot_campbell(diagram: Campbell) -> Any:
    """A matplotlib figure of the Campbell diagram: each mode's frequency (Hz) against the
    spin speed (rad/s), marked by whirl (▲ forward, ▼ backward, ● mixed, × none), and the
    synchronous line ``f = Ω / 2π`` (where unbalance excites a mode: a critical speed)."""
    import matplotlib.pyplot as plt

    markers = {"forward": "^", "backward": "v", "mixed": "o", "none": "x"}
    fig, ax = plt.subplots(figsize=(7, 4.5))
    f = diagram.frequencies_hz
    for j in range(f.shape[1]):
        ax.plot(diagram.speeds, f[:, j], color="0.6", lw=0.8)
        for kind, marker in markers.items():
            at = [i for i, row in enumerate(diagram.whirl) if row[j] == kind]
            if at:
                ax.plot(diagram.speeds[at], f[at, j], marker, ls="none", ms=4,
                        color={"forward": "C0", "backward": "C3"}.get(kind, "0.3"),
                        label=kind if j == 0 or kind not in ax.get_legend_handles_labels()[1]
                        else None)
    ax.plot(diagram.speeds, diagram.speeds / (2 * math.pi), "k--", lw=0.8, label="1x")
    ax.set_xlabel("spin speed Ω [rad/s]")
    ax.set_ylabel("damped natural frequency [Hz]")
    ax.set_ylim(0, 1.05 * float(f.max()))
    ax.legend(loc="upper left")
    ax.set_title("Campbell diagram")
    fig.tight_layout()
    return fig
