//! The linear structure `M x'' + C x' + K x = F(t)` (paper eq. 1) and its external loads.

use std::sync::{Arc, OnceLock};

use nalgebra::DMatrix;

use crate::error::{invalid, SimError};
use crate::factor::SpdFactor;
use crate::linalg::Csr;
use crate::model_catalog;

/// Largest structure (DOFs) that the dense-only methods (precise integration, Bathe, the
/// impulsive methods, Newmark's dense predictor) take: their `n × n` matrices would need
/// `8 n²` bytes each (200 MB at this size).
pub const MAX_DENSE_DOFS: usize = 5_000;

/// Mass, damping and stiffness matrices of the linear part (SI units), held as sparse rows
/// so that an imported FE model is never densified; dense copies are made on demand (and
/// kept) for the methods that need them ([`LinearStructure::dense`]).
///
/// A rotor spinning at `Ω` ([`LinearStructure::spinning`]) adds its gyroscopic forces
/// `Ω G x'` (`G` skew-symmetric): `damping` is then the whole velocity matrix `C + Ω G`,
/// which is not symmetric, so that every method's matrix-vector products and dense LU
/// factors are right as they stand; the Cholesky factors refuse it
/// ([`LinearStructure::damping_is_symmetric`]).
#[derive(Debug, Clone)]
pub struct LinearStructure {
    pub mass: Csr,
    /// The velocity matrix of the equation of motion: `C`, or `C + Ω G` for a spinning rotor.
    pub damping: Csr,
    pub stiffness: Csr,
    /// The gyroscopic matrix `G` (kg·m², skew-symmetric) of a rotor, if any: its forces do no
    /// work, so the energy account takes `Ω G` out of `damping` again.
    pub gyroscopic: Option<Csr>,
    /// The spin speed `Ω(t)` (rad/s) of a rotor: constant (0 for a structure that does not
    /// spin) or a run-up; `damping` holds `Ω(0) G`, and DOP853 adds `(Ω(t) − Ω(0)) G x'`.
    pub spin: SpinProfile,
    /// `M = L Lᵀ` (banded or general sparse, whichever solves faster): the
    /// positive-definiteness check, and the initial acceleration's solve.
    mass_factor: SpdFactor,
    pub(crate) dense: OnceLock<Arc<DenseStructure>>,
}

/// Dense copies of a small structure's matrices.
#[derive(Debug, Clone, PartialEq)]
pub struct DenseStructure {
    pub mass: DMatrix<f64>,
    pub damping: DMatrix<f64>,
    pub stiffness: DMatrix<f64>,
}

impl LinearStructure {
    /// From dense matrices (kept as the dense copies): see [`Self::from_sparse`].
    pub fn new(
        mass: DMatrix<f64>,
        damping: DMatrix<f64>,
        stiffness: DMatrix<f64>,
    ) -> Result<Self, SimError> {
        for (name, m) in [("damping", &damping), ("stiffness", &stiffness)] {
            if m.shape() != mass.shape() {
                return invalid(format!(
                    "structure.{name}: shape {}x{} does not match; expected {}x{}",
                    m.nrows(),
                    m.ncols(),
                    mass.nrows(),
                    mass.ncols()
                ));
            }
        }
        if !mass.is_square() {
            return invalid(format!(
                "structure.mass: shape {}x{} is not square; expected an n x n matrix",
                mass.nrows(),
                mass.ncols()
            ));
        }
        let s = Self::from_sparse(
            Csr::from_dense(&mass),
            Csr::from_dense(&damping),
            Csr::from_dense(&stiffness),
        )?;
        let dense = DenseStructure {
            mass,
            damping,
            stiffness,
        };
        s.dense.set(Arc::new(dense)).expect("a new structure");
        Ok(s)
    }

    /// Checks shapes, finiteness, symmetry (`max |A − Aᵀ| ≤ 1e-9 max |A|`) and that the mass
    /// matrix is positive definite (its Cholesky factor exists), without densifying.
    pub fn from_sparse(mass: Csr, damping: Csr, stiffness: Csr) -> Result<Self, SimError> {
        let n = mass.n();
        if n == 0 {
            return invalid("structure.mass: empty matrix; expected at least one DOF");
        }
        for (name, m) in [
            ("mass", &mass),
            ("damping", &damping),
            ("stiffness", &stiffness),
        ] {
            if m.n() != n {
                return invalid(format!(
                    "structure.{name}: shape {0}x{0} does not match; expected {n}x{n}",
                    m.n()
                ));
            }
            if let Some(v) = m.values().iter().find(|v| !v.is_finite()) {
                return invalid(format!(
                    "structure.{name}: contains {v}; expected finite values"
                ));
            }
            let scale = m
                .values()
                .iter()
                .fold(0.0_f64, |a, v| a.max(v.abs()))
                .max(f64::MIN_POSITIVE);
            let asym = m.asymmetry();
            if asym > 1e-9 * scale {
                return invalid(format!(
                    "structure.{name}: not symmetric (max |A - A^T| = {asym:.3e}); expected a symmetric matrix"
                ));
            }
        }
        let Some(mass_factor) = SpdFactor::cheapest(&[(1.0, &mass)]) else {
            return invalid(
                "structure.mass: not positive definite; expected every DOF to carry mass",
            );
        };
        Ok(Self {
            mass,
            damping,
            stiffness,
            gyroscopic: None,
            spin: SpinProfile::constant(0.0),
            mass_factor,
            dense: OnceLock::new(),
        })
    }

    /// The structure spinning at `spin_speed` Ω (rad/s) with the gyroscopic matrix
    /// `gyroscopic` G (skew-symmetric, `max |G + Gᵀ| ≤ 1e-9 max |G|`): `damping` becomes
    /// `C + Ω G`. Without `G` only the speed is kept (for the loads and gaps that read it).
    pub fn spinning(mut self, gyroscopic: Option<Csr>, spin_speed: f64) -> Result<Self, SimError> {
        model_catalog::SPIN_SPEED.check("structure", spin_speed)?;
        self.spin = SpinProfile::constant(spin_speed);
        let Some(g) = gyroscopic else {
            return Ok(self);
        };
        let n = self.n_dof();
        if g.n() != n {
            return invalid(format!(
                "structure.gyroscopic: shape {0}x{0} does not match; expected {n}x{n}",
                g.n()
            ));
        }
        if let Some(v) = g.values().iter().find(|v| !v.is_finite()) {
            return invalid(format!(
                "structure.gyroscopic: contains {v}; expected finite values"
            ));
        }
        let scale = g.values().iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        let sym = Csr::combination(&[(1.0, &g), (1.0, &g.transpose())]);
        let not_skew = sym.values().iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        if not_skew > 1e-9 * scale.max(f64::MIN_POSITIVE) {
            return invalid(format!(
                "structure.gyroscopic: not skew-symmetric (max |G + G^T| = {not_skew:.3e}); \
                 expected G = -G^T"
            ));
        }
        if scale == 0.0 {
            return Ok(self);
        }
        if spin_speed != 0.0 {
            self.damping = Csr::combination(&[(1.0, &self.damping), (spin_speed, &g)]);
            if let Some(dense) = self.dense.take() {
                let mut d = Arc::unwrap_or_clone(dense);
                d.damping = self.damping.to_dense();
                self.dense.set(Arc::new(d)).expect("taken");
            }
        }
        self.gyroscopic = Some(g);
        Ok(self)
    }

    /// The structure run up (or down) linearly from its spin speed to `end` (rad/s) over
    /// `duration` (s), constant after: `Ω(t) = Ω₀ + (end − Ω₀) t / duration`.
    pub fn run_up(mut self, end: f64, duration: f64) -> Result<Self, SimError> {
        model_catalog::SPIN_SPEED_END.check("structure", end)?;
        model_catalog::RUN_UP_TIME.check("structure", duration)?;
        self.spin = SpinProfile {
            start: self.spin.start,
            end,
            duration,
        };
        Ok(self)
    }

    /// `G` if the gyroscopic forces change in time (a run-up of a structure that has them).
    pub fn varying_gyroscopic(&self) -> Option<&Csr> {
        self.gyroscopic
            .as_ref()
            .filter(|_| !self.spin.is_constant())
    }

    /// Whether `damping` is symmetric: no gyroscopic forces (no `G`, or `Ω = 0`). The
    /// Cholesky factors of the effective stiffness need it; the LU factors do not.
    pub fn damping_is_symmetric(&self) -> bool {
        self.gyroscopic.is_none() || self.spin.start == 0.0
    }

    pub fn n_dof(&self) -> usize {
        self.mass.n()
    }

    /// Solves `M a = r` in place.
    pub fn solve_mass(&self, r: &mut [f64]) {
        self.mass_factor.solve_in_place(r);
    }

    /// Dense `M`, `C`, `K` for `method` (built once, then shared). Refuses structures with
    /// more than [`MAX_DENSE_DOFS`] DOFs with a one-line error naming the method.
    pub fn dense(&self, method: &str) -> Result<Arc<DenseStructure>, SimError> {
        let n = self.n_dof();
        if n > MAX_DENSE_DOFS {
            return invalid(format!(
                "solver.method: {method} needs dense n x n matrices and the structure has {n} DOFs \
                 (more than {MAX_DENSE_DOFS}); use newmark or generalized-alpha (sparse), or \
                 reduce the model (vibroimpact.fe.reduction)"
            ));
        }
        Ok(self
            .dense
            .get_or_init(|| {
                Arc::new(DenseStructure {
                    mass: self.mass.to_dense(),
                    damping: self.damping.to_dense(),
                    stiffness: self.stiffness.to_dense(),
                })
            })
            .clone())
    }
}

/// A rotor's spin speed over time: `start` (rad/s) run linearly to `end` over `duration`
/// (s), then held; constant (`start`) when `duration` is 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpinProfile {
    pub start: f64,
    pub end: f64,
    pub duration: f64,
}

impl SpinProfile {
    pub fn constant(speed: f64) -> Self {
        Self {
            start: speed,
            end: speed,
            duration: 0.0,
        }
    }

    pub fn is_constant(&self) -> bool {
        self.duration == 0.0
    }

    /// `Ω̇` during the run-up, rad/s².
    fn slope(&self) -> f64 {
        if self.is_constant() {
            0.0
        } else {
            (self.end - self.start) / self.duration
        }
    }

    /// `Ω(t)`, rad/s.
    #[inline]
    pub fn speed(&self, t: f64) -> f64 {
        if t >= self.duration {
            self.end
        } else if t <= 0.0 {
            self.start
        } else {
            self.start + self.slope() * t
        }
    }

    /// `Ω̇(t)`, rad/s² (0 before and after the run-up).
    #[inline]
    pub fn acceleration(&self, t: f64) -> f64 {
        if (0.0..self.duration).contains(&t) {
            self.slope()
        } else {
            0.0
        }
    }

    /// The angle turned since `t = 0`, `∫₀ᵗ Ω dt`, rad.
    #[inline]
    pub fn angle(&self, t: f64) -> f64 {
        if t >= self.duration {
            0.5 * (self.start + self.end) * self.duration + self.end * (t - self.duration)
        } else if t <= 0.0 {
            self.start * t
        } else {
            (self.start + 0.5 * self.slope() * t) * t
        }
    }
}

/// The direction of one of an unbalance's two forces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    X,
    Y,
}

/// Time function of a load.
#[derive(Debug, Clone, PartialEq)]
pub enum LoadHistory {
    /// `A`.
    Constant,
    /// `A sin(2π f t + φ)`.
    Harmonic {
        /// Frequency `f`, Hz.
        frequency: f64,
        /// Phase `φ`, rad.
        phase: f64,
    },
    /// `A · g(t)` with `g` linearly interpolated in a table and held at its end values.
    Table { time: Vec<f64>, value: Vec<f64> },
    /// One force of a rotating unbalance `A = m e` on a rotor spinning at `Ω(t)`, angle
    /// `φ = ∫Ω dt + phase`: x `A (Ω² cos φ + Ω̇ sin φ)`, y `A (Ω² sin φ − Ω̇ cos φ)` (the
    /// reaction of the eccentric mass's acceleration). [`Load::unbalance`] builds the pair.
    Unbalance {
        axis: Axis,
        phase: f64,
        spin: SpinProfile,
    },
}

/// A load `A · g(t)` applied to each of a set of DOFs.
#[derive(Debug, Clone, PartialEq)]
pub struct Load {
    pub dofs: Vec<usize>,
    /// Amplitude `A`, N (for a table: a scale factor on the tabulated newtons).
    pub amplitude: f64,
    pub history: LoadHistory,
}

impl Load {
    pub fn validate(&self, index: usize, n_dof: usize) -> Result<(), SimError> {
        let field = format!("loads[{index}]");
        if self.dofs.is_empty() {
            return invalid(format!(
                "{field}.dof: empty; expected at least one DOF index"
            ));
        }
        if let Some(d) = self.dofs.iter().find(|&&d| d >= n_dof) {
            return invalid(format!(
                "{field}.dof: {d} is out of range; expected 0 <= dof < {n_dof}"
            ));
        }
        // a table's amplitude is its scale; an unbalance's, its m e (checked when built)
        match &self.history {
            LoadHistory::Table { .. } => model_catalog::SCALE.check(&field, self.amplitude)?,
            _ => model_catalog::AMPLITUDE.check(&field, self.amplitude)?,
        };
        match &self.history {
            LoadHistory::Constant => {}
            LoadHistory::Harmonic { frequency, phase } => {
                model_catalog::FREQUENCY.check(&field, *frequency)?;
                model_catalog::PHASE.check(&field, *phase)?;
            }
            LoadHistory::Table { time, value } => {
                if time.len() < 2 || time.len() != value.len() {
                    return invalid(format!(
                        "{field}.table: {} times and {} values; expected two equal-length columns with at least 2 rows",
                        time.len(),
                        value.len()
                    ));
                }
                if time.windows(2).any(|w| w[1] <= w[0] || w[1].is_nan())
                    || time.iter().any(|t| !t.is_finite())
                {
                    return invalid(format!(
                        "{field}.table: times are not strictly increasing; expected increasing finite times in s"
                    ));
                }
                if value.iter().any(|v| !v.is_finite()) {
                    return invalid(format!(
                        "{field}.table: contains a non-finite force; expected finite values in N"
                    ));
                }
            }
            LoadHistory::Unbalance { phase, .. } => {
                model_catalog::PHASE.check(&field, *phase)?;
            }
        }
        Ok(())
    }

    /// The two loads of an unbalance `magnitude` m·e (kg·m) at `phase` (rad) on the DOFs
    /// `[ix, iy]` of a rotor spinning at `spin`: at a constant speed the two harmonic loads
    /// `m e Ω² (cos(Ωt + φ), sin(Ωt + φ))` (`cos θ = sin(θ + π/2)`; a negative Ω turns the
    /// other way: `θ = |Ω| t`, the y force and the phase negated), else
    /// [`LoadHistory::Unbalance`].
    pub fn unbalance(dofs: [usize; 2], magnitude: f64, phase: f64, spin: SpinProfile) -> [Load; 2] {
        let [ix, iy] = dofs;
        if spin.is_constant() {
            let w = spin.start.abs();
            let sign = if spin.start >= 0.0 { 1.0 } else { -1.0 };
            let frequency = w / (2.0 * std::f64::consts::PI);
            let force = magnitude * w * w;
            return [
                Load {
                    dofs: vec![ix],
                    amplitude: force,
                    history: LoadHistory::Harmonic {
                        frequency,
                        phase: sign * phase + std::f64::consts::FRAC_PI_2,
                    },
                },
                Load {
                    dofs: vec![iy],
                    amplitude: sign * force,
                    history: LoadHistory::Harmonic {
                        frequency,
                        phase: sign * phase,
                    },
                },
            ];
        }
        [(ix, Axis::X), (iy, Axis::Y)].map(|(d, axis)| Load {
            dofs: vec![d],
            amplitude: magnitude,
            history: LoadHistory::Unbalance { axis, phase, spin },
        })
    }

    /// `A · g(t)`. In line, with [`Self::shape`], which the Newmark step called per load and
    /// step (the rotor's two unbalance loads: ~40 instructions a step).
    #[inline(always)]
    pub fn value(&self, t: f64) -> f64 {
        self.amplitude * self.shape(t)
    }

    /// `g(t)`: a harmonic load's tested first, on its own (the sweeps' loads, every step),
    /// so that it skips the decoding of the other variants and their frame (callgrind: 19
    /// instructions a call besides the `sin`, before); in line in the per-size Newmark step.
    #[inline(always)]
    pub fn shape(&self, t: f64) -> f64 {
        if let LoadHistory::Harmonic { frequency, phase } = &self.history {
            return (2.0 * std::f64::consts::PI * frequency * t + phase).sin();
        }
        self.other_shape(t)
    }

    /// [`Self::shape`] of the loads that are not harmonic.
    fn other_shape(&self, t: f64) -> f64 {
        match &self.history {
            LoadHistory::Constant => 1.0,
            LoadHistory::Harmonic { .. } => unreachable!("taken by Load::shape"),
            LoadHistory::Unbalance { axis, phase, spin } => {
                let (w, dw) = (spin.speed(t), spin.acceleration(t));
                let (sin, cos) = (spin.angle(t) + phase).sin_cos();
                match axis {
                    Axis::X => w * w * cos + dw * sin,
                    Axis::Y => w * w * sin - dw * cos,
                }
            }
            LoadHistory::Table { time, value } => interpolate(time, value, t),
        }
    }

    /// `A · g⁽ᵏ⁾(t)` into `out[k]` for `k = 0, 1, ...` (`out.len()` of them) of a load smooth
    /// at every time: constant, or harmonic (`A ω^k sin(ω t + φ + k π/2)`; an unbalance at a
    /// constant spin is a pair of them, [`Load::unbalance`]); `false` for the others (a
    /// table's corners, a run-up's).
    pub fn smooth_derivatives(&self, t: f64, out: &mut [f64]) -> bool {
        match &self.history {
            LoadHistory::Constant => {
                out.fill(0.0);
                if let Some(first) = out.first_mut() {
                    *first = self.amplitude;
                }
            }
            LoadHistory::Harmonic { frequency, phase } => {
                let w = 2.0 * std::f64::consts::PI * frequency;
                let (sin, cos) = (w * t + phase).sin_cos();
                let mut scale = self.amplitude;
                for (k, o) in out.iter_mut().enumerate() {
                    *o = scale * [sin, cos, -sin, -cos][k % 4];
                    scale *= w;
                }
            }
            LoadHistory::Unbalance { .. } | LoadHistory::Table { .. } => return false,
        }
        true
    }

    /// `A · g'(t)` (a table's: the slope of the segment holding `t`, zero outside it).
    pub fn rate(&self, t: f64) -> f64 {
        self.amplitude
            * match &self.history {
                LoadHistory::Constant => 0.0,
                LoadHistory::Harmonic { frequency, phase } => {
                    let w = 2.0 * std::f64::consts::PI * frequency;
                    w * (w * t + phase).cos()
                }
                LoadHistory::Table { time, value } => {
                    let last = time.len() - 1;
                    if t < time[0] || t >= time[last] {
                        0.0
                    } else {
                        let i = time.partition_point(|&ti| ti <= t) - 1;
                        (value[i + 1] - value[i]) / (time[i + 1] - time[i])
                    }
                }
                // Ω̈ = 0 inside and outside the run-up (its corners are not represented)
                LoadHistory::Unbalance { axis, phase, spin } => {
                    let (w, dw) = (spin.speed(t), spin.acceleration(t));
                    let (sin, cos) = (spin.angle(t) + phase).sin_cos();
                    match axis {
                        Axis::X => 3.0 * w * dw * cos - w * w * w * sin,
                        Axis::Y => 3.0 * w * dw * sin + w * w * w * cos,
                    }
                }
            }
    }
}

/// A set of loads evaluated together at one time, as an explicit method's right-hand side
/// evaluates them a dozen times a step: the harmonic loads of one frequency (an unbalance's x
/// and y forces, [`Load::unbalance`]) share one angle `θ = 2π f t + φ₀` (`φ₀` the first one's
/// phase; the others `sin(θ + Δ) = sin θ cos Δ + cos θ sin Δ`, `Δ` their phase past it), and
/// `θ` is turned from the nearest anchor `a = k/4` rad of `2π f t` (whose `sin_cos` is kept
/// while the anchor stays) by `δ = 2π f t − a`, `|δ| ≤ 1/8`, whose sine and cosine are their
/// Taylor series ([`small_sin_cos`]): a `sin_cos` every few steps instead of a `sin` per
/// load and stage. The angle carries the rounding of `2π f t` as [`Load::value`]'s does (`a`
/// and `δ` are exact: `a` a multiple of 1/4), so the values agree with it to ~1e-16 of the
/// amplitude times the angle's size.
#[derive(Debug, Clone)]
pub struct LoadValues {
    /// Per load: its group and `(cos Δ, sin Δ)`, or `None` (its own [`Load::value`]).
    shifts: Vec<Option<(usize, [f64; 2])>>,
    /// Per group of harmonic loads of one frequency: its rotation.
    groups: Vec<Rotation>,
    /// Per group: `sin θ`, `cos θ` at the last time evaluated.
    trig: Vec<(f64, f64)>,
    /// Each load's value `A g(t)` at the last time evaluated ([`Self::evaluate`]), N.
    pub values: Vec<f64>,
    /// Each `(load, DOF)` it applies to, in order: one flat loop in [`Self::apply`].
    targets: Vec<Target>,
    /// The targets when they are two harmonic ones of one frequency (an unbalance's pair):
    /// both valued from one rotation in [`Self::apply`], without the per-target dispatch.
    pair: Option<[Shifted; 2]>,
}

/// A load at one of its DOFs, with what its value needs ([`LoadValues::apply`]): no pass
/// over the loads before the pass over their DOFs, no value stored and read back.
#[derive(Debug, Clone, Copy)]
struct Target {
    load: usize,
    dof: usize,
    amplitude: f64,
    /// The load's group and shift ([`LoadValues::shifts`]).
    shift: Option<(usize, [f64; 2])>,
}

/// A harmonic load of group 0 at one of its DOFs ([`LoadValues::pair`]).
#[derive(Debug, Clone, Copy)]
struct Shifted {
    dof: usize,
    amplitude: f64,
    /// `(cos Δ, sin Δ)` of its phase from the group's.
    shift: [f64; 2],
}

/// The angle `θ = ω t + φ₀` of a group of harmonic loads, its sine and cosine turned from
/// exact anchors `k/4 + φ₀` by a small-angle series.
#[derive(Debug, Clone)]
struct Rotation {
    /// `ω = 2π f` and `φ₀`, the group's first load's phase.
    omega: f64,
    phase: f64,
    /// The last anchors' indices `k` and `sin`, `cos` of `k/4 + φ₀`, anchor `k` in slot
    /// `k mod ANCHOR_SLOTS`.
    anchors: [(f64, (f64, f64)); ANCHOR_SLOTS],
}

/// The spacing (rad) of [`LoadValues`]' anchors, a power of 2 so that they are exact.
const ANCHOR_SPACING: f64 = 0.25;

/// Anchors kept per group: a DOP853 step spans about one spacing and its stages' times go
/// back and forth over it, so with one anchor kept its `sin_cos` was recomputed ~4 times a
/// step; with the neighbours kept, about once.
const ANCHOR_SLOTS: usize = 4;

impl LoadValues {
    pub fn new(loads: &[Load]) -> Self {
        let mut groups: Vec<Rotation> = Vec::new();
        let mut frequencies: Vec<f64> = Vec::new();
        let shifts = loads
            .iter()
            .map(|l| {
                let LoadHistory::Harmonic { frequency, phase } = l.history else {
                    return None;
                };
                let group = match frequencies.iter().position(|&f| f == frequency) {
                    Some(g) => g,
                    None => {
                        frequencies.push(frequency);
                        groups.push(Rotation {
                            omega: 2.0 * std::f64::consts::PI * frequency,
                            phase,
                            anchors: [(f64::NAN, (0.0, 1.0)); ANCHOR_SLOTS],
                        });
                        groups.len() - 1
                    }
                };
                let (sin, cos) = (phase - groups[group].phase).sin_cos();
                Some((group, [cos, sin]))
            })
            .collect();
        let targets = (loads.iter().zip(&shifts).enumerate())
            .flat_map(|(i, (l, &shift))| {
                l.dofs.iter().map(move |&dof| Target {
                    load: i,
                    dof,
                    amplitude: l.amplitude,
                    shift,
                })
            })
            .collect::<Vec<Target>>();
        let shifted = |t: &Target| match t.shift {
            Some((0, shift)) => Some(Shifted {
                dof: t.dof,
                amplitude: t.amplitude,
                shift,
            }),
            _ => None,
        };
        let pair = match targets[..] {
            [a, b] => shifted(&a).zip(shifted(&b)).map(|(a, b)| [a, b]),
            _ => None,
        };
        Self {
            shifts,
            trig: vec![(0.0, 1.0); groups.len()],
            groups,
            values: vec![0.0; loads.len()],
            targets,
            pair,
        }
    }

    /// Adds the loads' values at `t` to their DOFs' entries of `f` and returns their power
    /// `Σ g v[d]` at the velocities `v`: each load valued at each of its DOFs as
    /// [`Self::evaluate`] values it, in one pass (a right-hand side of a few DOFs has no use
    /// for the values themselves).
    #[inline(always)]
    pub fn apply(&mut self, loads: &[Load], t: f64, f: &mut [f64], v: &[f64]) -> f64 {
        let mut power = 0.0;
        if let Some(pair) = self.pair {
            let trig = self.groups[0].turn(t);
            for target in pair {
                let g = harmonic(trig, target.amplitude, target.shift);
                f[target.dof] += g;
                power += g * v[target.dof];
            }
            return power;
        }
        self.turn(t);
        for target in &self.targets {
            let g = match target.shift {
                Some((group, shift)) => harmonic(self.trig[group], target.amplitude, shift),
                None => loads[target.load].value(t),
            };
            f[target.dof] += g;
            power += g * v[target.dof];
        }
        power
    }

    /// Evaluates `loads` (those this was built from) at `t` into [`Self::values`].
    #[inline(always)]
    pub fn evaluate(&mut self, loads: &[Load], t: f64) {
        self.turn(t);
        for ((value, load), &shift) in self.values.iter_mut().zip(loads).zip(&self.shifts) {
            *value = match shift {
                Some((group, shift)) => harmonic(self.trig[group], load.amplitude, shift),
                None => load.value(t),
            };
        }
    }

    /// Each group's `sin θ`, `cos θ` at `t`.
    #[inline(always)]
    fn turn(&mut self, t: f64) {
        for (rotation, trig) in self.groups.iter_mut().zip(&mut self.trig) {
            *trig = rotation.turn(t);
        }
    }
}

/// A harmonic load's value `A sin(θ + Δ)` from its group's `sin θ`, `cos θ`.
#[inline(always)]
fn harmonic((s, c): (f64, f64), amplitude: f64, [cos, sin]: [f64; 2]) -> f64 {
    amplitude * (s * cos + c * sin)
}

impl Rotation {
    /// `sin θ`, `cos θ` at `t`.
    #[inline(always)]
    fn turn(&mut self, t: f64) -> (f64, f64) {
        let angle = self.omega * t;
        let k = nearest_integer(angle / ANCHOR_SPACING);
        // `k` is an integer: its low bits pick the slot (any slot past 2⁶³, where the
        // conversion saturates)
        let anchor = &mut self.anchors[(k as i64 as usize) % ANCHOR_SLOTS];
        if anchor.0 != k {
            *anchor = (k, (k * ANCHOR_SPACING + self.phase).sin_cos());
        }
        let (sa, ca) = anchor.1;
        let (sd, cd) = small_sin_cos(angle - k * ANCHOR_SPACING);
        (sa * cd + ca * sd, ca * cd - sa * sd)
    }
}

/// `x` rounded to an integer, ties to even: `(x + 1.5·2⁵²) − 1.5·2⁵²`, exact for `|x| < 2⁵¹`
/// (the sum's unit in the last place is 1), two additions where `f64::round` is a library call
/// on x86-64 without SSE4.1; `round` beyond (already integers or halves there).
#[inline(always)]
fn nearest_integer(x: f64) -> f64 {
    const SHIFT: f64 = 6_755_399_441_055_744.0; // 1.5·2⁵²
    if x.abs() < 2_251_799_813_685_248.0 {
        // 2⁵¹
        (x + SHIFT) - SHIFT
    } else {
        x.round()
    }
}

/// `sin δ`, `cos δ` for `|δ| ≤ 1/8` by their Taylor series to `δ¹¹` and `δ¹²` (the first
/// term left out below 3e-21).
#[inline]
fn small_sin_cos(d: f64) -> (f64, f64) {
    let z = d * d;
    let sin = d
        * (1.0
            + z * (-1.0 / 6.0
                + z * (1.0 / 120.0
                    + z * (-1.0 / 5040.0 + z * (1.0 / 362880.0 + z * (-1.0 / 39916800.0))))));
    let cos = 1.0
        + z * (-0.5
            + z * (1.0 / 24.0
                + z * (-1.0 / 720.0
                    + z * (1.0 / 40320.0 + z * (-1.0 / 3628800.0 + z * (1.0 / 479001600.0))))));
    (sin, cos)
}

/// Piecewise-linear interpolation, held constant outside the table.
fn interpolate(time: &[f64], value: &[f64], t: f64) -> f64 {
    let last = time.len() - 1;
    if t <= time[0] {
        return value[0];
    }
    if t >= time[last] {
        return value[last];
    }
    let i = time.partition_point(|&ti| ti <= t) - 1;
    let w = (t - time[i]) / (time[i + 1] - time[i]);
    value[i] + w * (value[i + 1] - value[i])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A harmonic load's derivatives equal its value and rate and central differences of
    /// them; a constant's are its value and zeros; a table's and a run-up's are refused.
    #[test]
    fn smooth_derivatives_are_the_loads() {
        let harmonic = Load {
            dofs: vec![0],
            amplitude: 2.0,
            history: LoadHistory::Harmonic {
                frequency: 7.3,
                phase: -1.1,
            },
        };
        let (t, h) = (0.37, 1e-5);
        let mut d = [0.0; 6];
        let mut around = [[0.0; 6]; 2];
        assert!(harmonic.smooth_derivatives(t, &mut d));
        assert!(harmonic.smooth_derivatives(t - h, &mut around[0]));
        assert!(harmonic.smooth_derivatives(t + h, &mut around[1]));
        assert_eq!(d[0], harmonic.value(t));
        assert!((d[1] / harmonic.rate(t) - 1.0).abs() < 1e-14);
        for k in 1..6 {
            let difference = (around[1][k - 1] - around[0][k - 1]) / (2.0 * h);
            // a central difference's error, (ω h)²/6 = 3.5e-8
            assert!(
                (difference / d[k] - 1.0).abs() < 1e-7,
                "{k}: {difference} {}",
                d[k]
            );
        }
        let constant = Load {
            dofs: vec![0],
            amplitude: 0.5,
            history: LoadHistory::Constant,
        };
        assert!(constant.smooth_derivatives(t, &mut d));
        assert_eq!(d, [0.5, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let table = Load {
            dofs: vec![0],
            amplitude: 1.0,
            history: LoadHistory::Table {
                time: vec![0.0, 1.0],
                value: vec![0.0, 3.0],
            },
        };
        let run_up = SpinProfile {
            start: 10.0,
            end: 20.0,
            duration: 1.0,
        };
        let [x, _] = Load::unbalance([0, 1], 1e-4, 0.3, run_up);
        assert!(!table.smooth_derivatives(t, &mut d));
        assert!(!x.smooth_derivatives(t, &mut d));
    }

    /// [`LoadValues`] (an unbalance's pair sharing one angle, a lone harmonic load, a
    /// constant and a table) equals each load's own [`Load::value`] to the rounding of the
    /// angle, over 1e4 revolutions and at the anchors' midpoints; the pair alone (its own
    /// path) gives the same bits; its small-angle sine and cosine equal the library's to 2 ulp.
    #[test]
    fn load_values_equal_each_loads_value() {
        let spin = SpinProfile::constant(150.0);
        let [x, y] = Load::unbalance([0, 1], 1e-4, 0.3, spin);
        let lone = Load {
            dofs: vec![2],
            amplitude: 2.0,
            history: LoadHistory::Harmonic {
                frequency: 7.3,
                phase: -1.1,
            },
        };
        let constant = Load {
            dofs: vec![2],
            amplitude: 0.5,
            history: LoadHistory::Constant,
        };
        let table = Load {
            dofs: vec![1, 2],
            amplitude: 1.0,
            history: LoadHistory::Table {
                time: vec![0.0, 1.0],
                value: vec![0.0, 3.0],
            },
        };
        let loads = vec![x, lone, constant, y, table];
        let mut values = LoadValues::new(&loads);
        let mut worst: f64 = 0.0;
        for i in 0..20_000 {
            // irregular times up to 420 s (1e4 revolutions at 150 rad/s), both directions
            let t = 420.0 * ((i as f64 * 0.618_034) % 1.0);
            values.evaluate(&loads, t);
            for (load, &v) in loads.iter().zip(&values.values) {
                let angle = 2.0 * std::f64::consts::PI * 150.0 * t + 4.0;
                let scale = load.amplitude.abs() * angle * f64::EPSILON;
                worst = worst.max((v - load.value(t)).abs() / scale);
            }
        }
        assert!(worst < 4.0, "{worst} angle roundings");
        // `apply`: each value added to each of its load's DOFs, and their power
        let (mut f, v) = (vec![0.0; 3], [0.5, -2.0, 3.0]);
        let power = values.apply(&loads, 1.3, &mut f, &v);
        values.evaluate(&loads, 1.3);
        let (mut expected, mut expected_power) = (vec![0.0; 3], 0.0);
        for (load, &g) in loads.iter().zip(&values.values) {
            for &d in &load.dofs {
                expected[d] += g;
                expected_power += g * v[d];
            }
        }
        assert_eq!((f, power), (expected, expected_power));
        // an unbalance's pair alone (valued from one rotation): the same bits
        let pair = vec![loads[0].clone(), loads[3].clone()];
        let mut pair_values = LoadValues::new(&pair);
        assert!(pair_values.pair.is_some() && values.pair.is_none());
        for i in 0..1000 {
            let t = 420.0 * ((i as f64 * 0.618_034) % 1.0);
            let (mut f, v) = ([0.0; 2], [0.5, -2.0]);
            let power = pair_values.apply(&pair, t, &mut f, &v);
            values.evaluate(&loads, t);
            let [gx, gy] = [values.values[0], values.values[3]];
            let expected_power = 0.0 + gx * v[0] + gy * v[1];
            assert_eq!((f, power), ([gx, gy], expected_power), "{t}");
        }
        // the anchors' rounding: `round` away from ties (ties to even), either side of 2⁵¹
        for i in 0..100_000 {
            let x = (i as f64 * 0.618_034 - 30_000.0) * 1.37;
            assert_eq!(nearest_integer(x), x.round(), "{x}");
        }
        for (x, even) in [
            (2.5, 2.0),
            (-2.5, -2.0),
            (3.5, 4.0),
            (0.5, 0.0),
            (-0.0, 0.0),
        ] {
            assert_eq!(nearest_integer(x), even, "{x}");
        }
        let big = 2.0_f64.powi(51);
        for x in [
            big - 0.5,
            big - 1.25,
            -big + 0.25,
            big,
            big + 1.5,
            1e300,
            -1e17,
        ] {
            assert_eq!(nearest_integer(x), x.round_ties_even(), "{x}");
        }
        for i in 0..=1000 {
            let d = (i as f64 / 500.0 - 1.0) * ANCHOR_SPACING / 2.0;
            let (s, c) = small_sin_cos(d);
            assert!(
                (s - d.sin()).abs() <= 2.0 * f64::EPSILON * d.abs(),
                "sin {d}"
            );
            assert!((c - d.cos()).abs() <= 2.0 * f64::EPSILON, "cos {d}");
        }
    }

    #[test]
    fn table_interpolates_and_holds() {
        let load = Load {
            dofs: vec![0],
            amplitude: 2.0,
            history: LoadHistory::Table {
                time: vec![0.0, 1.0, 3.0],
                value: vec![0.0, 10.0, 30.0],
            },
        };
        assert_eq!(load.value(-1.0), 0.0);
        assert!((load.value(0.5) - 10.0).abs() < 1e-12);
        assert!((load.value(2.0) - 40.0).abs() < 1e-12);
        assert_eq!(load.value(5.0), 60.0);
    }

    #[test]
    fn harmonic_value() {
        let load = Load {
            dofs: vec![0],
            amplitude: 3.0,
            history: LoadHistory::Harmonic {
                frequency: 2.0,
                phase: 0.25,
            },
        };
        let t = 0.137;
        let expected = 3.0 * (2.0 * std::f64::consts::PI * 2.0 * t + 0.25).sin();
        assert!((load.value(t) - expected).abs() < 1e-14);
    }

    /// `rate` against a central difference of `value`, for a harmonic and a table load.
    #[test]
    fn rate_is_the_derivative_of_value() {
        let harmonic = Load {
            dofs: vec![0],
            amplitude: 3.0,
            history: LoadHistory::Harmonic {
                frequency: 2.0,
                phase: 0.25,
            },
        };
        let table = Load {
            dofs: vec![0],
            amplitude: 2.0,
            history: LoadHistory::Table {
                time: vec![0.0, 1.0, 3.0],
                value: vec![0.0, 10.0, 30.0],
            },
        };
        let tau = 1e-6;
        for (load, t) in [
            (&harmonic, 0.137),
            (&table, 0.5),
            (&table, 2.0),
            (&table, 4.0),
        ] {
            let fd = (load.value(t + tau) - load.value(t - tau)) / (2.0 * tau);
            let got = load.rate(t);
            assert!(
                (got - fd).abs() < 1e-6 * fd.abs().max(1.0),
                "{got} vs {fd} at {t}"
            );
        }
    }

    /// A run-up's angle against the trapezoidal sum of its speed (exact for a piecewise
    /// linear Ω on a grid through the corner), its unbalance forces against their formula,
    /// and their rates against a central difference, inside and after the run-up.
    #[test]
    fn run_up_angle_and_unbalance_forces() {
        let spin = SpinProfile {
            start: 50.0,
            end: 350.0,
            duration: 0.4,
        };
        let (n, t_end) = (4000, 0.8);
        let h = t_end / n as f64;
        let mut angle = 0.0;
        for i in 0..n {
            let t = i as f64 * h;
            angle += 0.5 * h * (spin.speed(t) + spin.speed(t + h));
            assert!((spin.angle(t + h) - angle).abs() < 1e-10 * angle, "at {t}");
        }
        let [x, y] = Load::unbalance([0, 1], 2e-3, 0.3, spin);
        for t in [0.1, 0.37, 0.6] {
            let (w, dw) = (spin.speed(t), if t < 0.4 { 750.0 } else { 0.0 });
            let phi = spin.angle(t) + 0.3;
            let fx = 2e-3 * (w * w * phi.cos() + dw * phi.sin());
            let fy = 2e-3 * (w * w * phi.sin() - dw * phi.cos());
            assert!((x.value(t) - fx).abs() < 1e-12 * fx.abs().max(1.0));
            assert!((y.value(t) - fy).abs() < 1e-12 * fy.abs().max(1.0));
            let tau = 1e-7;
            for load in [&x, &y] {
                let fd = (load.value(t + tau) - load.value(t - tau)) / (2.0 * tau);
                assert!((load.rate(t) - fd).abs() < 1e-6 * fd.abs(), "{t}");
            }
        }
        // at a constant speed: the two harmonic loads of the same forces
        let steady = SpinProfile::constant(-120.0);
        let [hx, hy] = Load::unbalance([0, 1], 2e-3, 0.3, steady);
        for t in [0.01, 0.2] {
            let phi = -120.0 * t + 0.3;
            assert!((hx.value(t) - 2e-3 * 14400.0 * phi.cos()).abs() < 1e-10);
            assert!((hy.value(t) - 2e-3 * 14400.0 * phi.sin()).abs() < 1e-10);
        }
    }

    #[test]
    fn structure_refuses_bad_matrices() {
        let m = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 1.0]);
        let k = DMatrix::from_row_slice(2, 2, &[2.0, -1.0, -1.0, 2.0]);
        let c = DMatrix::zeros(2, 2);
        assert!(LinearStructure::new(m.clone(), c.clone(), k.clone()).is_ok());
        let ks = DMatrix::from_row_slice(2, 2, &[2.0, -1.0, 0.0, 2.0]);
        assert!(LinearStructure::new(m.clone(), c.clone(), ks).is_err());
        let mneg = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, -1.0]);
        assert!(LinearStructure::new(mneg, c.clone(), k.clone()).is_err());
        assert!(LinearStructure::new(m, DMatrix::zeros(3, 3), k).is_err());
    }

    /// A sparse structure is validated, solves with its mass and makes dense copies only
    /// below the dense methods' size limit.
    #[test]
    fn sparse_structure_checks_and_limits_dense_copies() {
        let chain = |n: usize, asym: f64| {
            let mut ptr = vec![0];
            let (mut idx, mut val) = (vec![], vec![]);
            for i in 0..n {
                for j in i.saturating_sub(1)..(i + 2).min(n) {
                    idx.push(j);
                    val.push(match j.cmp(&i) {
                        std::cmp::Ordering::Equal => 2.0,
                        std::cmp::Ordering::Less => -1.0,
                        std::cmp::Ordering::Greater => -1.0 + asym,
                    });
                }
                ptr.push(idx.len());
            }
            Csr::from_parts(n, ptr, idx, val).unwrap()
        };
        let n = MAX_DENSE_DOFS + 1;
        let s = LinearStructure::from_sparse(chain(n, 0.0), chain(n, 0.0), chain(n, 0.0)).unwrap();
        // M a = r for r = M·1: a = 1
        let mut r = vec![0.0; n];
        s.mass.mul_add(1.0, &vec![1.0; n], &mut r);
        s.solve_mass(&mut r);
        assert!(r.iter().all(|v| (v - 1.0).abs() < 1e-9));
        let e = s.dense("precise").unwrap_err().to_string();
        assert!(e.contains("precise") && e.contains(&n.to_string()), "{e}");
        let small = LinearStructure::from_sparse(chain(4, 0.0), chain(4, 0.0), chain(4, 0.0));
        let d = small.unwrap().dense("bathe").unwrap();
        assert_eq!(d.mass, chain(4, 0.0).to_dense());
        let e = LinearStructure::from_sparse(chain(4, 0.0), chain(4, 0.0), chain(4, 1e-3));
        assert!(e
            .unwrap_err()
            .to_string()
            .contains("structure.stiffness: not symmetric"));
        let mut neg = chain(4, 0.0).to_dense();
        neg[(0, 0)] = -1.0;
        let e = LinearStructure::from_sparse(Csr::from_dense(&neg), chain(4, 0.0), chain(4, 0.0));
        assert!(e.unwrap_err().to_string().contains("not positive definite"));
    }
}
