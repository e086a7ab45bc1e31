//! The matrix exponential by the 2^N algorithm of precise integration (Zhong & Williams 1994,
//! Proc. IMechE C 208:427, "A precise time step integration method"), and the Duhamel
//! integrals of polynomial loads (paper eqs. 38–41) from the same algorithm.
//!
//! `exp(A) = (exp(A / 2^N))^(2^N)`. With `τ = 2^−N`, `exp(Aτ) = I + T` where the increment
//! `T = Aτ + (Aτ)²/2 + (Aτ)³/6 + (Aτ)⁴/24` is tiny; squaring `I + T` is done on the increment
//! alone, `T ← 2T + T²`, N times, and `I` is added only at the end. Adding `I` early would
//! round `T` away (it is ~2^−N of `I`): keeping the increment is what makes the algorithm
//! precise. `N` is chosen so that `‖Aτ‖₁ ≤ 2^−13`, where the Taylor remainder
//! `‖Aτ‖⁵/120` is below the round-off of `T`; Zhong's fixed `N = 20` is the same rule for
//! `‖A‖ ≲ 100`. The matrix is first balanced by exact powers of two (Parlett & Reinsch 1969),
//! so that the very different scales of a structure's `q` and `p` blocks (`M⁻¹ ~ 10⁻²`,
//! `K ~ 10¹⁰`) do not inflate `N` or the round-off of the small blocks.

use nalgebra::{DMatrix, DVector};

/// `‖Aτ‖₁` at which the Taylor series starts: its remainder `θ⁴/120` relative to `T` is
/// below 1e-17.
const THETA: f64 = 1.0 / 8192.0;

/// `exp(A) − I`, by the 2^N algorithm on the increment.
pub fn expm_increment(a: &DMatrix<f64>) -> DMatrix<f64> {
    assert!(a.is_square(), "expm of a non-square matrix");
    let n = a.nrows();
    let (scale, balanced) = balance(a);
    let norm = one_norm(&balanced);
    let doublings = if norm > THETA {
        (norm / THETA).log2().ceil() as i32
    } else {
        0
    };
    let at = balanced * 2f64.powi(-doublings);
    // T = Aτ + (Aτ)² (I + Aτ/3 + (Aτ)²/12) / 2, by Horner.
    let at2 = &at * &at;
    let mut inner = &at2 * (1.0 / 12.0) + &at * (1.0 / 3.0);
    for i in 0..n {
        inner[(i, i)] += 1.0;
    }
    let mut t = &at + (&at2 * inner) * 0.5;
    for _ in 0..doublings {
        let t2 = &t * &t;
        t = t * 2.0 + t2;
    }
    // Undo the balancing: exp(A) = D exp(D⁻¹ A D) D⁻¹, and D I D⁻¹ = I.
    for j in 0..n {
        for i in 0..n {
            t[(i, j)] *= scale[i] / scale[j];
        }
    }
    t
}

/// `exp(A)`, by the 2^N algorithm ([`expm_increment`] plus `I`).
pub fn expm(a: &DMatrix<f64>) -> DMatrix<f64> {
    let mut e = expm_increment(a);
    for i in 0..e.nrows() {
        e[(i, i)] += 1.0;
    }
    e
}

/// The transition matrix and the Duhamel integrals of a step of length `η` of `z' = H z + B f(t)`
/// with `f` a polynomial on the step (paper eqs. 40–41):
/// returns `Φ = exp(Hη)` and `D_m = η ∫₀¹ exp(Hη(1−s)) B s^m ds` for `m = 0..=degree`, so that a
/// load `f(t_k + sη) = Σ_m d_m s^m` moves the state by `Σ_m D_m d_m`
/// (`D_m = η^{m+1} Φ_m(η) B` with the paper's `Φ_m`).
///
/// They come from one exponential of the augmented matrix (Van Loan 1978, IEEE TAC 23:395)
/// `[[Hη, B, 0, 0], [0, 0, I, 0], [0, 0, 0, I], [0, 0, 0, 0]]`, whose first block row is
/// `[Φ, ∫₀¹ e^{Hη(1−s)} B ds, ∫₀¹ e^{Hη(1−s)} B s ds, ∫₀¹ e^{Hη(1−s)} B s²/2 ds, …]`.
/// Its size is `2n + (degree + 1) k` for `k` load columns, never `2n` per column.
pub fn duhamel(
    h: &DMatrix<f64>,
    eta: f64,
    b: &DMatrix<f64>,
    degree: usize,
) -> (DMatrix<f64>, Vec<DMatrix<f64>>) {
    let n = h.nrows();
    let k = b.ncols();
    let blocks = degree + 1;
    let size = n + blocks * k;
    let mut aug = DMatrix::zeros(size, size);
    aug.view_mut((0, 0), (n, n)).copy_from(&(h * eta));
    aug.view_mut((0, n), (n, k)).copy_from(b);
    for blk in 0..degree {
        for j in 0..k {
            aug[(n + blk * k + j, n + (blk + 1) * k + j)] = 1.0;
        }
    }
    let mut e = expm_increment(&aug);
    for i in 0..n {
        e[(i, i)] += 1.0;
    }
    let phi = e.view((0, 0), (n, n)).into_owned();
    let mut factorial = 1.0;
    let integrals = (0..blocks)
        .map(|m| {
            if m > 0 {
                factorial *= m as f64;
            }
            e.view((0, n + m * k), (n, k)).into_owned() * (eta * factorial)
        })
        .collect();
    (phi, integrals)
}

/// Terms of [`expm_action`] before it gives up.
const MAX_TERMS: usize = 40;

/// `exp(Aτ) z` by its Taylor series `Σ (Aτ)^k z / k!`, summed until a term is below the
/// round-off of every component (`2^−56` of that component's scale `|z_i| + |(Aτ z)_i|`),
/// for a trial instant of a flight whose full-step `exp(Ah)` is cached: a few mat-vecs of
/// the small matrix instead of an exponential. `None` when the series is not safe: a term
/// larger than `2^10` of the scale (cancellation would cost more than 3 digits) or no
/// convergence in 40 terms (`‖Aτ‖` too large, a stiff mode); the caller then takes the
/// exponential.
pub fn expm_action(a: &DMatrix<f64>, z: &DVector<f64>, tau: f64) -> Option<DVector<f64>> {
    let mut term = a * z * tau;
    let scale: DVector<f64> = z.abs() + term.abs();
    let mut sum = z + &term;
    for k in 2..=MAX_TERMS {
        term = a * &term * (tau / k as f64);
        sum += &term;
        let mut negligible = true;
        for (t, s) in term.iter().zip(scale.iter()) {
            if t.abs() > 1024.0 * s {
                return None;
            }
            negligible &= t.abs() <= s * f64::EPSILON / 16.0;
        }
        if negligible {
            return Some(sum);
        }
    }
    None
}

/// `‖A‖₁`, the largest column sum of |a_ij|.
fn one_norm(a: &DMatrix<f64>) -> f64 {
    a.column_iter()
        .map(|c| c.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// Diagonal balancing by powers of two (Parlett & Reinsch 1969; LAPACK's `gebal` without
/// permutations): returns `d` and `D⁻¹ A D` with `D = diag(d)`, whose rows and columns have
/// comparable norms. Exact in floating point.
fn balance(a: &DMatrix<f64>) -> (Vec<f64>, DMatrix<f64>) {
    let n = a.nrows();
    let mut b = a.clone();
    let mut d = vec![1.0; n];
    for _sweep in 0..100 {
        let mut converged = true;
        for i in 0..n {
            let (mut c, mut r) = (0.0, 0.0);
            for j in 0..n {
                if j != i {
                    c += b[(j, i)].abs();
                    r += b[(i, j)].abs();
                }
            }
            if c == 0.0 || r == 0.0 {
                continue;
            }
            let s = c + r;
            let mut f = 1.0;
            let (mut cc, mut rr) = (c, r);
            while cc < rr / 2.0 {
                cc *= 2.0;
                rr /= 2.0;
                f *= 2.0;
            }
            while cc >= rr * 2.0 {
                cc /= 2.0;
                rr *= 2.0;
                f /= 2.0;
            }
            if (cc + rr) < 0.95 * s {
                converged = false;
                d[i] *= f;
                for j in 0..n {
                    b[(i, j)] /= f;
                    b[(j, i)] *= f;
                }
            }
        }
        if converged {
            break;
        }
    }
    (d, b)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
        (a - b).norm() / b.norm()
    }

    #[test]
    fn rotation_and_decay() {
        // exp([[0, ω], [−ω, 0]] t) is a rotation by ωt.
        for wt in [1e-6, 1e-3, 0.5, 3.0, 40.0] {
            let a = DMatrix::from_row_slice(2, 2, &[0.0, wt, -wt, 0.0]);
            let e = expm(&a);
            let want = DMatrix::from_row_slice(2, 2, &[wt.cos(), wt.sin(), -wt.sin(), wt.cos()]);
            assert!(rel(&e, &want) < 1e-14, "ωt = {wt}: {}", rel(&e, &want));
        }
        let a = DMatrix::from_row_slice(2, 2, &[-2.0, 1.0, 0.0, -3.0]);
        let e = expm(&a);
        let want = DMatrix::from_row_slice(
            2,
            2,
            &[
                (-2f64).exp(),
                (-2f64).exp() - (-3f64).exp(),
                0.0,
                (-3f64).exp(),
            ],
        );
        assert!(rel(&e, &want) < 1e-14);
    }

    #[test]
    fn action_series_equals_the_exponential() {
        // A damped oscillator driven by a harmonic load carried as its own oscillator
        // (the event-driven method's augmented flow): the series at trial instants of a step
        // against the 2^N exponential, and its refusal of a stiff step.
        let (k, c, w) = (39.48, 0.628, 9.42);
        let a = DMatrix::from_row_slice(
            4,
            4,
            &[
                0.0, 1.0, 0.0, 0.0, -k, -c, 1.0, 0.0, 0.0, 0.0, 0.0, w, 0.0, 0.0, -w, 0.0,
            ],
        );
        let z = DVector::from_row_slice(&[0.005, -0.31, 0.6, -0.8]);
        for tau in [1e-9, 3e-4, 2e-3, 0.05] {
            let want = expm(&(&a * tau)) * &z;
            let got = expm_action(&a, &z, tau).expect("converges");
            let err = (&got - &want).abs().max() / want.abs().max();
            assert!(err < 1e-15, "τ = {tau}: {err}");
        }
        assert!(expm_action(&(&a * 1e4), &z, 1.0).is_none());
    }

    #[test]
    fn increment_keeps_small_steps_precise() {
        // For a tiny step, exp(A) − I ≈ A: the increment keeps all its digits.
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1e-9, -1e-9, 0.0]);
        let t = expm_increment(&a);
        assert!((t[(0, 1)] - 1e-9).abs() < 1e-24);
        assert!((t[(0, 0)] + 0.5e-18).abs() < 1e-32);
    }

    #[test]
    fn duhamel_of_a_free_mass_is_polynomial() {
        // z = (q, p), q' = p/m, p' = f: D_m = η ∫₀¹ [(1−s)η/m, 1] s^m ds.
        let (m, eta) = (2.0, 0.3);
        let h = DMatrix::from_row_slice(2, 2, &[0.0, 1.0 / m, 0.0, 0.0]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let (phi, d) = duhamel(&h, eta, &b, 2);
        assert!((phi[(0, 1)] - eta / m).abs() < 1e-16);
        for (k, dk) in d.iter().enumerate() {
            let k = k as f64;
            let q = eta * eta / m * (1.0 / (k + 1.0) - 1.0 / (k + 2.0));
            let p = eta / (k + 1.0);
            assert!((dk[(0, 0)] - q).abs() < 1e-16 && (dk[(1, 0)] - p).abs() < 1e-16);
        }
    }
}
