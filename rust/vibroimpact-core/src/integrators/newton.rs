//! Newton–Raphson on the active gap coordinates (paper eqs. 22–27; DESIGN.md §5).
//!
//! With the linear part factorised, a step's unknown is the increment of the gap coordinates
//! `Δu` only: `r(Δu) = Δu − Δu_lin + W φ(Δu) = 0`, `W = B K̃⁻¹ Bᵀ`. The Jacobian is
//! `I + W diag(∂φ/∂u + c_v ∂φ/∂u̇)`, a c×c system on the gaps in contact.

/// Stopping rule and limits of the Newton iterations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonSettings {
    /// Relative tolerance on the increment and on the residual of the gap coordinates
    /// (paper eq. 27, with `e` as a fraction rather than a percentage).
    pub rtol: f64,
    /// Absolute tolerance on them, m.
    pub atol: f64,
    /// Iterations allowed per step before the step is cut.
    pub max_iterations: usize,
    /// Times a step may be halved (recursively) before the run fails.
    pub max_step_cuts: usize,
}

impl Default for NewtonSettings {
    fn default() -> Self {
        Self {
            rtol: 1e-10,
            atol: 1e-15,
            max_iterations: 30,
            max_step_cuts: 12,
        }
    }
}

/// Solves `A z = b` in place for a small dense system (row-major `A`, size m), by Gaussian
/// elimination with partial pivoting. Returns false if `A` is singular.
pub(crate) fn solve_small(a: &mut [f64], b: &mut [f64], m: usize) -> bool {
    if m == 1 {
        if a[0] == 0.0 {
            return false;
        }
        b[0] /= a[0];
        return true;
    }
    for col in 0..m {
        let mut piv = col;
        for row in col + 1..m {
            if a[row * m + col].abs() > a[piv * m + col].abs() {
                piv = row;
            }
        }
        if a[piv * m + col] == 0.0 {
            return false;
        }
        if piv != col {
            for k in 0..m {
                a.swap(col * m + k, piv * m + k);
            }
            b.swap(col, piv);
        }
        let d = a[col * m + col];
        for row in col + 1..m {
            let f = a[row * m + col] / d;
            if f != 0.0 {
                for k in col..m {
                    a[row * m + k] -= f * a[col * m + k];
                }
                b[row] -= f * b[col];
            }
        }
    }
    for col in (0..m).rev() {
        let mut s = b[col];
        for k in col + 1..m {
            s -= a[col * m + k] * b[k];
        }
        b[col] = s / a[col * m + col];
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_solver_matches_nalgebra() {
        let a = [4.0, 1.0, 2.0, 0.5, 3.0, 1.0, 2.0, 1.0, 5.0];
        let b = [1.0, -2.0, 3.0];
        let (mut aa, mut bb) = (a, b);
        assert!(solve_small(&mut aa, &mut bb, 3));
        let m = nalgebra::Matrix3::from_row_slice(&a);
        let x = m
            .lu()
            .solve(&nalgebra::Vector3::from_row_slice(&b))
            .unwrap();
        for i in 0..3 {
            assert!((bb[i] - x[i]).abs() < 1e-14);
        }
    }
}
