//! Sparse linear algebra for large structures (issue 6, "speed at size"): compressed sparse
//! rows for `M`, `C`, `K`, and a banded Cholesky factorisation of the effective stiffness in
//! reverse Cuthill–McKee order (Cuthill & McKee 1969; George & Liu 1981, §4.3), so that a step
//! of a beam or an imported FE model costs O(nnz + n·bandwidth) instead of O(n²).

use nalgebra::DMatrix;

/// `y += alpha x`.
#[inline]
pub(crate) fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += alpha * xi;
    }
}

/// Compressed sparse rows.
#[derive(Debug, Clone)]
pub struct Csr {
    n: usize,
    row_start: Vec<usize>,
    cols: Vec<usize>,
    vals: Vec<f64>,
}

impl Csr {
    /// The nonzero entries of a dense square matrix.
    pub fn from_dense(a: &DMatrix<f64>) -> Self {
        let n = a.nrows();
        let mut row_start = Vec::with_capacity(n + 1);
        let (mut cols, mut vals) = (Vec::new(), Vec::new());
        row_start.push(0);
        for i in 0..n {
            for j in 0..n {
                let v = a[(i, j)];
                if v != 0.0 {
                    cols.push(j);
                    vals.push(v);
                }
            }
            row_start.push(cols.len());
        }
        Self {
            n,
            row_start,
            cols,
            vals,
        }
    }

    pub fn nnz(&self) -> usize {
        self.vals.len()
    }

    /// `y += alpha A x`.
    #[inline]
    pub fn mul_add(&self, alpha: f64, x: &[f64], y: &mut [f64]) {
        for (i, yi) in y.iter_mut().enumerate().take(self.n) {
            let mut s = 0.0;
            for k in self.row_start[i]..self.row_start[i + 1] {
                s += self.vals[k] * x[self.cols[k]];
            }
            *yi += alpha * s;
        }
    }

    /// `½ yᵀ A y`.
    pub fn quadratic_form(&self, y: &[f64]) -> f64 {
        let mut sum = 0.0;
        for (i, yi) in y.iter().enumerate() {
            let row: f64 = self.row(i).map(|(j, v)| v * y[j]).sum();
            sum += yi * row;
        }
        0.5 * sum
    }

    /// `(x₁ − x₀)ᵀ A (y₀ + y₁)`, without forming the difference of two large products.
    pub fn increment_form(&self, x0: &[f64], x1: &[f64], y0: &[f64], y1: &[f64]) -> f64 {
        (0..self.n)
            .map(|i| (x1[i] - x0[i]) * self.row(i).map(|(j, v)| v * (y0[j] + y1[j])).sum::<f64>())
            .sum()
    }

    fn row(&self, i: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        (self.row_start[i]..self.row_start[i + 1]).map(move |k| (self.cols[k], self.vals[k]))
    }
}

/// Reverse Cuthill–McKee ordering of the symmetric pattern of the given matrices:
/// `perm[new] = old`.
fn reverse_cuthill_mckee(n: usize, patterns: &[&Csr]) -> Vec<usize> {
    let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n];
    for a in patterns {
        for i in 0..n {
            for (j, _) in a.row(i) {
                if i != j {
                    adj[i].push(j);
                    adj[j].push(i);
                }
            }
        }
    }
    for list in &mut adj {
        list.sort_unstable();
        list.dedup();
    }
    let mut order = Vec::with_capacity(n);
    let mut seen = vec![false; n];
    let mut by_degree: Vec<usize> = (0..n).collect();
    by_degree.sort_by_key(|&i| adj[i].len());
    for &start in &by_degree {
        if seen[start] {
            continue;
        }
        seen[start] = true;
        let mut head = order.len();
        order.push(start);
        while head < order.len() {
            let node = order[head];
            head += 1;
            let mut next: Vec<usize> = adj[node].iter().copied().filter(|&j| !seen[j]).collect();
            next.sort_by_key(|&j| adj[j].len());
            for j in next {
                seen[j] = true;
                order.push(j);
            }
        }
    }
    order.reverse();
    order
}

/// `A = L Lᵀ` of a symmetric positive definite matrix stored as a band after reordering.
#[derive(Debug, Clone)]
pub struct BandedCholesky {
    n: usize,
    bandwidth: usize,
    /// `perm[new] = old`.
    perm: Vec<usize>,
    /// Row `i` holds `L[i][i − bandwidth ..= i]`.
    band: Vec<f64>,
}

impl BandedCholesky {
    /// Bandwidth that `matrices`' combined pattern has in reverse Cuthill–McKee order.
    pub fn ordering(n: usize, matrices: &[&Csr]) -> (Vec<usize>, usize) {
        let perm = reverse_cuthill_mckee(n, matrices);
        let mut inv = vec![0; n];
        for (new, &old) in perm.iter().enumerate() {
            inv[old] = new;
        }
        let mut bandwidth = 0;
        for a in matrices {
            for i in 0..n {
                for (j, _) in a.row(i) {
                    bandwidth = bandwidth.max(inv[i].abs_diff(inv[j]));
                }
            }
        }
        (perm, bandwidth)
    }

    /// Factorises `Σ cₖ Aₖ` (all with the pattern the ordering was made for). `None` if it is
    /// not positive definite.
    pub fn factor(terms: &[(f64, &Csr)], perm: Vec<usize>, bandwidth: usize) -> Option<Self> {
        let n = perm.len();
        let w = bandwidth + 1;
        let mut inv = vec![0; n];
        for (new, &old) in perm.iter().enumerate() {
            inv[old] = new;
        }
        let mut band = vec![0.0; n * w];
        for &(c, a) in terms {
            if c == 0.0 {
                continue;
            }
            for i in 0..n {
                for (j, v) in a.row(i) {
                    let (pi, pj) = (inv[i], inv[j]);
                    if pj <= pi {
                        band[pi * w + (pj + bandwidth - pi)] += c * v;
                    }
                }
            }
        }
        for i in 0..n {
            let lo = i.saturating_sub(bandwidth);
            for j in lo..=i {
                let mut s = band[i * w + (j + bandwidth - i)];
                let klo = lo.max(j.saturating_sub(bandwidth));
                for k in klo..j {
                    s -= band[i * w + (k + bandwidth - i)] * band[j * w + (k + bandwidth - j)];
                }
                if i == j {
                    if !(s > 0.0 && s.is_finite()) {
                        return None;
                    }
                    band[i * w + bandwidth] = s.sqrt();
                } else {
                    band[i * w + (j + bandwidth - i)] = s / band[j * w + bandwidth];
                }
            }
        }
        Some(Self {
            n,
            bandwidth,
            perm,
            band,
        })
    }

    /// Solves `A x = b` in place; `work` has length n.
    pub fn solve_in_place(&self, b: &mut [f64], work: &mut [f64]) {
        let (n, bw, w) = (self.n, self.bandwidth, self.bandwidth + 1);
        let y = work;
        for (new, &old) in self.perm.iter().enumerate() {
            y[new] = b[old];
        }
        for i in 0..n {
            let lo = i.saturating_sub(bw);
            let row = &self.band[i * w..(i + 1) * w];
            let mut s = y[i];
            for k in lo..i {
                s -= row[k + bw - i] * y[k];
            }
            y[i] = s / row[bw];
        }
        for i in (0..n).rev() {
            let hi = (i + bw).min(n - 1);
            let mut s = y[i];
            for (k, yk) in y.iter().enumerate().take(hi + 1).skip(i + 1) {
                s -= self.band[k * w + (i + bw - k)] * yk;
            }
            y[i] = s / self.band[i * w + bw];
        }
        for (new, &old) in self.perm.iter().enumerate() {
            b[old] = y[new];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scrambled banded SPD matrix: the factor solves it like a dense LU does.
    #[test]
    fn banded_cholesky_matches_dense_solve() {
        let n = 40;
        let mut a = DMatrix::<f64>::zeros(n, n);
        let p: Vec<usize> = (0..n).map(|i| (i * 17) % n).collect();
        for i in 0..n {
            a[(p[i], p[i])] = 4.0 + i as f64 * 0.1;
            if i + 1 < n {
                a[(p[i], p[i + 1])] = -1.0;
                a[(p[i + 1], p[i])] = -1.0;
            }
            if i + 3 < n {
                a[(p[i], p[i + 3])] = 0.5;
                a[(p[i + 3], p[i])] = 0.5;
            }
        }
        let csr = Csr::from_dense(&a);
        let (perm, bw) = BandedCholesky::ordering(n, &[&csr]);
        assert!(bw <= 6, "{bw}");
        let f = BandedCholesky::factor(&[(1.0, &csr)], perm, bw).unwrap();
        let b: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let mut x = b.clone();
        f.solve_in_place(&mut x, &mut vec![0.0; n]);
        let exact = a.lu().solve(&nalgebra::DVector::from_vec(b)).unwrap();
        for i in 0..n {
            assert!((x[i] - exact[i]).abs() < 1e-12, "{i}");
        }
        let mut y = vec![0.0; n];
        csr.mul_add(1.0, &x, &mut y);
        assert!((y[5] - (5.0_f64).sin()).abs() < 1e-12);
    }

    #[test]
    fn indefinite_matrix_is_refused() {
        let a = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        let csr = Csr::from_dense(&a);
        let (perm, bw) = BandedCholesky::ordering(2, &[&csr]);
        assert!(BandedCholesky::factor(&[(1.0, &csr)], perm, bw).is_none());
    }
}
