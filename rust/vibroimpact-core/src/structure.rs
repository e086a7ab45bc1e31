//! The linear structure `M x'' + C x' + K x = F(t)` (paper eq. 1) and its external loads.

use nalgebra::DMatrix;

use crate::error::{invalid, SimError};

/// Mass, damping and stiffness matrices of the linear part (SI units).
#[derive(Debug, Clone, PartialEq)]
pub struct LinearStructure {
    pub mass: DMatrix<f64>,
    pub damping: DMatrix<f64>,
    pub stiffness: DMatrix<f64>,
}

impl LinearStructure {
    /// Checks shapes, finiteness, symmetry and that the mass matrix is positive definite.
    pub fn new(
        mass: DMatrix<f64>,
        damping: DMatrix<f64>,
        stiffness: DMatrix<f64>,
    ) -> Result<Self, SimError> {
        let n = mass.nrows();
        if n == 0 {
            return invalid("structure.mass: empty matrix; expected at least one DOF");
        }
        for (name, m) in [
            ("mass", &mass),
            ("damping", &damping),
            ("stiffness", &stiffness),
        ] {
            if m.nrows() != n || m.ncols() != n {
                return invalid(format!(
                    "structure.{name}: shape {}x{} does not match; expected {n}x{n}",
                    m.nrows(),
                    m.ncols()
                ));
            }
            if let Some(v) = m.iter().find(|v| !v.is_finite()) {
                return invalid(format!(
                    "structure.{name}: contains {v}; expected finite values"
                ));
            }
            let scale = m.amax().max(f64::MIN_POSITIVE);
            let asym = (m - m.transpose()).amax();
            if asym > 1e-9 * scale {
                return invalid(format!(
                    "structure.{name}: not symmetric (max |A - A^T| = {asym:.3e}); expected a symmetric matrix"
                ));
            }
        }
        if mass.clone().cholesky().is_none() {
            return invalid(
                "structure.mass: not positive definite; expected every DOF to carry mass",
            );
        }
        Ok(Self {
            mass,
            damping,
            stiffness,
        })
    }

    pub fn n_dof(&self) -> usize {
        self.mass.nrows()
    }
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
        if !self.amplitude.is_finite() {
            return invalid(format!(
                "{field}.amplitude: {} is not finite; expected a force in N",
                self.amplitude
            ));
        }
        match &self.history {
            LoadHistory::Constant => {}
            LoadHistory::Harmonic { frequency, phase } => {
                if !(frequency.is_finite() && *frequency >= 0.0) {
                    return invalid(format!(
                        "{field}.frequency: {frequency} is not valid; expected a value >= 0 in Hz"
                    ));
                }
                if !phase.is_finite() {
                    return invalid(format!(
                        "{field}.phase: {phase} is not finite; expected an angle in rad"
                    ));
                }
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
        }
        Ok(())
    }

    /// `A · g(t)`.
    #[inline]
    pub fn value(&self, t: f64) -> f64 {
        self.amplitude
            * match &self.history {
                LoadHistory::Constant => 1.0,
                LoadHistory::Harmonic { frequency, phase } => {
                    (2.0 * std::f64::consts::PI * frequency * t + phase).sin()
                }
                LoadHistory::Table { time, value } => interpolate(time, value, t),
            }
    }
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
}
