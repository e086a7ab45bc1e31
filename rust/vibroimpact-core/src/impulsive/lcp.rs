//! The linear complementarity problem of the impulsive methods: find `z ≥ 0` with
//! `w = W z + q ≥ 0` and `zᵀ w = 0`, `W` symmetric positive (semi-)definite (the Delassus
//! matrix `G M⁻¹ Gᵀ` of the contacts, or `G Â⁻¹ Gᵀ` in Moreau–Jean).
//!
//! Rule: up to [`ENUMERATION_LIMIT`] contacts the active set is found by enumeration (every
//! subset, smallest first: exact, and for a positive definite `W` the solution is unique);
//! with more contacts, or if no subset passes (a singular `W`), projected Gauss–Seidel
//! `z_i ← max(0, z_i − (W z + q)_i / W_ii)` is iterated until the change is below 1e-14
//! relative or after 10,000 sweeps.

use nalgebra::{DMatrix, DVector};

/// Largest number of contacts solved by enumeration (2^10 subsets).
pub const ENUMERATION_LIMIT: usize = 10;

/// Solves the LCP `(W, q)`; returns `z`.
pub fn solve_lcp(w: &DMatrix<f64>, q: &[f64]) -> Vec<f64> {
    let m = q.len();
    if m == 0 || q.iter().all(|&v| v >= 0.0) {
        return vec![0.0; m];
    }
    let scale = q.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let tol = 1e-12 * scale.max(f64::MIN_POSITIVE);
    if m <= ENUMERATION_LIMIT {
        let mut masks: Vec<u32> = (1..(1u32 << m)).collect();
        masks.sort_by_key(|k| k.count_ones());
        for mask in masks {
            if let Some(z) = try_active_set(w, q, mask, tol) {
                return z;
            }
        }
    }
    projected_gauss_seidel(w, q)
}

fn try_active_set(w: &DMatrix<f64>, q: &[f64], mask: u32, tol: f64) -> Option<Vec<f64>> {
    let m = q.len();
    let idx: Vec<usize> = (0..m).filter(|i| mask & (1 << i) != 0).collect();
    let k = idx.len();
    let a = DMatrix::from_fn(k, k, |r, c| w[(idx[r], idx[c])]);
    let b = DVector::from_iterator(k, idx.iter().map(|&i| -q[i]));
    let sol = a.lu().solve(&b)?;
    if sol.iter().any(|v| !v.is_finite() || *v < -tol) {
        return None;
    }
    let mut z = vec![0.0; m];
    for (r, &i) in idx.iter().enumerate() {
        z[i] = sol[r].max(0.0);
    }
    for i in 0..m {
        let wi: f64 = q[i] + (0..m).map(|j| w[(i, j)] * z[j]).sum::<f64>();
        if wi < -tol.max(1e-10 * w[(i, i)].abs() * z.iter().fold(0.0f64, |a, v| a.max(*v))) {
            return None;
        }
    }
    Some(z)
}

fn projected_gauss_seidel(w: &DMatrix<f64>, q: &[f64]) -> Vec<f64> {
    let m = q.len();
    let mut z = vec![0.0; m];
    for _ in 0..10_000 {
        let mut change = 0.0f64;
        let mut size = 0.0f64;
        for i in 0..m {
            let d = w[(i, i)];
            if d <= 0.0 {
                continue;
            }
            let r: f64 = q[i] + (0..m).map(|j| w[(i, j)] * z[j]).sum::<f64>();
            let new = (z[i] - r / d).max(0.0);
            change = change.max((new - z[i]).abs());
            z[i] = new;
            size = size.max(new.abs());
        }
        if change <= 1e-14 * size.max(f64::MIN_POSITIVE) {
            break;
        }
    }
    z
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(w: &DMatrix<f64>, q: &[f64], z: &[f64]) {
        let m = q.len();
        for i in 0..m {
            let wi: f64 = q[i] + (0..m).map(|j| w[(i, j)] * z[j]).sum::<f64>();
            assert!(z[i] >= 0.0 && wi >= -1e-12, "{z:?}");
            assert!((z[i] * wi).abs() < 1e-12, "{z:?}");
        }
    }

    #[test]
    fn enumeration_and_pgs_agree() {
        let w = DMatrix::from_row_slice(3, 3, &[2.0, 0.5, 0.1, 0.5, 1.5, 0.3, 0.1, 0.3, 1.0]);
        for q in [[-1.0, 0.2, -0.4], [-1.0, -2.0, -0.1], [0.5, -0.1, 1.0]] {
            let z = solve_lcp(&w, &q);
            check(&w, &q, &z);
            let p = projected_gauss_seidel(&w, &q);
            for (a, b) in z.iter().zip(&p) {
                assert!((a - b).abs() < 1e-10);
            }
        }
    }
}
