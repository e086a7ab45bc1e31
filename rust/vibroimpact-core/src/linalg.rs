//! Sparse linear algebra for large structures (issue 6, "speed at size"): compressed sparse
//! rows for `M`, `C`, `K`, and a banded Cholesky factorisation of the effective stiffness in
//! reverse Cuthill–McKee order (Cuthill & McKee 1969; George & Liu 1981, §4.3), so that a step
//! of a beam or an imported FE model costs O(nnz + n·bandwidth) instead of O(n²).
//! Both stay beside `faer`'s sparse types because they are faster where they are used (see
//! `factor.rs` and `examples/factor_compare.rs`): the banded factor on beams, and
//! [`StackedRows`], which applies `K`, `C` (and `M`) in one pass over the rows, where faer
//! multiplies one matrix at a time (a 5,000-DOF beam's `K x + C v`: 15 µs against 27 µs; on
//! the 81-entry rows of a 3-D solid faer's products are faster, 39 µs against 59 µs for the
//! C3D20 cantilever, our rows' one addition chain per operator being the limit, but there
//! the step's cost is the solve's).

use nalgebra::DMatrix;

/// `y += alpha x`.
#[inline]
pub(crate) fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += alpha * xi;
    }
}

/// `y −= A x` for a dense row-major `A` (`y.len()` rows of `x.len()` columns).
pub type MatVecSub = fn(&[f64], &[f64], &mut [f64]);

/// The fastest dense `y −= A x` this CPU runs, and how many columns it takes per instruction.
#[derive(Clone, Copy)]
pub struct DenseMatVec {
    pub sub: MatVecSub,
    pub lanes: usize,
}

impl DenseMatVec {
    /// With AVX2 and FMA (checked at run time, so the build stays portable) four rows at a
    /// time, four columns per fused multiply–add; plain Rust elsewhere.
    pub fn fastest() -> Self {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
            return Self {
                sub: |a, x, y| {
                    // SAFETY: the CPU supports AVX2 and FMA (detected above).
                    unsafe { avx2::mat_vec_sub(a, x, y) }
                },
                lanes: 4,
            };
        }
        Self::portable()
    }

    /// Plain Rust, one column at a time.
    pub fn portable() -> Self {
        Self {
            sub: mat_vec_sub_scalar,
            lanes: 1,
        }
    }

    /// `y −= A x`: fewer than four rows in plain Rust at the call site (what the AVX2 kernel
    /// does with them, without its call and setup: the small models' predictor), more by
    /// [`Self::sub`].
    #[inline(always)]
    pub fn apply(&self, a: &[f64], x: &[f64], y: &mut [f64]) {
        if y.len() < 4 {
            mat_vec_sub_scalar(a, x, y)
        } else {
            (self.sub)(a, x, y)
        }
    }
}

/// [`MatVecSub`] in plain Rust.
#[inline]
fn mat_vec_sub_scalar(a: &[f64], x: &[f64], y: &mut [f64]) {
    for (yi, row) in y.iter_mut().zip(a.chunks_exact(x.len())) {
        *yi -= row.iter().zip(x).map(|(r, x)| r * x).sum::<f64>();
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    /// `y −= A x`, four rows at a time (four independent accumulators sharing the loads of
    /// `x`), four columns per `vfmadd`; the last `n mod 4` columns and rows in scalar code.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn mat_vec_sub(a: &[f64], x: &[f64], y: &mut [f64]) {
        let n = x.len();
        let m = y.len();
        assert!(a.len() >= m * n);
        let wide = n - n % 4;
        let rows4 = m - m % 4;
        let (ap, xp) = (a.as_ptr(), x.as_ptr());
        for i in (0..rows4).step_by(4) {
            let mut acc = [_mm256_setzero_pd(); 4];
            for c in (0..wide).step_by(4) {
                // SAFETY: c + 3 < n and (i + r) n + c + 3 < m n <= a.len() (asserted above).
                let xv = _mm256_loadu_pd(xp.add(c));
                for (r, acc_r) in acc.iter_mut().enumerate() {
                    let av = _mm256_loadu_pd(ap.add((i + r) * n + c));
                    *acc_r = _mm256_fmadd_pd(av, xv, *acc_r);
                }
            }
            for (r, acc_r) in acc.iter().enumerate() {
                let mut lanes = [0.0; 4];
                _mm256_storeu_pd(lanes.as_mut_ptr(), *acc_r);
                let row = &a[(i + r) * n..(i + r + 1) * n];
                let tail: f64 = row[wide..].iter().zip(&x[wide..]).map(|(p, q)| p * q).sum();
                y[i + r] -= (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]) + tail;
            }
        }
        super::mat_vec_sub_scalar(&a[rows4 * n..m * n], x, &mut y[rows4..]);
    }
}

/// Compressed sparse rows of a square matrix, column indices strictly increasing in each row.
#[derive(Debug, Clone, PartialEq)]
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

    /// A CSR matrix from its arrays (SciPy's `indptr`, `indices`, `data`) for an `n × n`
    /// matrix. Checks that `row_start` starts at 0, never decreases and ends at the number of
    /// entries, and that each row's column indices are below `n` and strictly increasing;
    /// the error names what is wrong.
    pub fn from_parts(
        n: usize,
        row_start: Vec<usize>,
        cols: Vec<usize>,
        vals: Vec<f64>,
    ) -> Result<Self, String> {
        if row_start.len() != n + 1 {
            return Err(format!(
                "indptr has {} entries; expected {} (rows + 1)",
                row_start.len(),
                n + 1
            ));
        }
        if cols.len() != vals.len() {
            return Err(format!(
                "{} indices and {} values; expected one index per value",
                cols.len(),
                vals.len()
            ));
        }
        if row_start[0] != 0 || row_start[n] != cols.len() {
            return Err(format!(
                "indptr runs from {} to {}; expected 0 to {} (the number of values)",
                row_start[0],
                row_start[n],
                cols.len()
            ));
        }
        for (i, w) in row_start.windows(2).enumerate() {
            if w[1] < w[0] {
                return Err(format!(
                    "indptr decreases at row {i}; expected a non-decreasing array"
                ));
            }
            let row = &cols[w[0]..w[1]];
            if let Some(&j) = row.iter().find(|&&j| j >= n) {
                return Err(format!(
                    "row {i} has column {j}; expected columns below {n}"
                ));
            }
            if row.windows(2).any(|p| p[1] <= p[0]) {
                return Err(format!(
                    "row {i}: column indices not strictly increasing; expected sorted indices \
                     without duplicates (scipy: sum_duplicates())"
                ));
            }
        }
        Ok(Self {
            n,
            row_start,
            cols,
            vals,
        })
    }

    pub fn n(&self) -> usize {
        self.n
    }

    pub fn nnz(&self) -> usize {
        self.vals.len()
    }

    /// The stored values, row after row.
    pub fn values(&self) -> &[f64] {
        &self.vals
    }

    /// `(row_start, cols, vals)`: SciPy's `indptr`, `indices`, `data`.
    pub fn parts(&self) -> (&[usize], &[usize], &[f64]) {
        (&self.row_start, &self.cols, &self.vals)
    }

    /// `Σ cₖ Aₖ` on the union of the patterns (an entry whose coefficient is zero is kept, so
    /// that every combination of the same matrices has the same pattern).
    pub fn combination(terms: &[(f64, &Csr)]) -> Self {
        let n = terms[0].1.n;
        let mut row_start = Vec::with_capacity(n + 1);
        let (mut cols, mut vals) = (Vec::new(), Vec::new());
        let mut row: Vec<(usize, f64)> = Vec::new();
        row_start.push(0);
        for i in 0..n {
            row.clear();
            for &(c, a) in terms {
                row.extend(a.row(i).map(|(j, v)| (j, c * v)));
            }
            row.sort_unstable_by_key(|e| e.0);
            for &(j, v) in &row {
                if cols.len() > row_start[i] && cols.last() == Some(&j) {
                    *vals.last_mut().expect("pushed") += v;
                } else {
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

    /// `max |A − Aᵀ|` over the entries, from the rows of `A` and of `Aᵀ` merged column by column.
    pub fn asymmetry(&self) -> f64 {
        let t = self.transpose();
        let mut worst = 0.0_f64;
        for i in 0..self.n {
            let (mut a, mut b) = (self.row(i).peekable(), t.row(i).peekable());
            loop {
                let d = match (a.peek().copied(), b.peek().copied()) {
                    (None, None) => break,
                    (Some((ja, va)), Some((jb, vb))) if ja == jb => {
                        a.next();
                        b.next();
                        va - vb
                    }
                    (Some((ja, va)), Some((jb, _))) if ja < jb => {
                        a.next();
                        va
                    }
                    (Some((_, va)), None) => {
                        a.next();
                        va
                    }
                    (_, Some((_, vb))) => {
                        b.next();
                        vb
                    }
                };
                worst = worst.max(d.abs());
            }
        }
        worst
    }

    /// `Aᵀ` (its rows are the columns of `A`, in increasing column order).
    pub fn transpose(&self) -> Self {
        let mut row_start = vec![0; self.n + 1];
        for &j in &self.cols {
            row_start[j + 1] += 1;
        }
        for i in 0..self.n {
            row_start[i + 1] += row_start[i];
        }
        let mut next = row_start.clone();
        let (mut cols, mut vals) = (vec![0; self.nnz()], vec![0.0; self.nnz()]);
        for i in 0..self.n {
            for (j, v) in self.row(i) {
                cols[next[j]] = i;
                vals[next[j]] = v;
                next[j] += 1;
            }
        }
        Self {
            n: self.n,
            row_start,
            cols,
            vals,
        }
    }

    /// The dense matrix (small models only: `n²` values).
    pub fn to_dense(&self) -> DMatrix<f64> {
        let mut a = DMatrix::zeros(self.n, self.n);
        for i in 0..self.n {
            for (j, v) in self.row(i) {
                a[(i, j)] = v;
            }
        }
        a
    }

    /// `y += alpha A x`.
    #[inline]
    pub fn mul_add(&self, alpha: f64, x: &[f64], y: &mut [f64]) {
        for (i, yi) in y.iter_mut().enumerate().take(self.n) {
            *yi += alpha * self.row_dot(i, |j| x[j]);
        }
    }

    /// `½ yᵀ A y`.
    pub fn quadratic_form(&self, y: &[f64]) -> f64 {
        let sum: f64 = y
            .iter()
            .enumerate()
            .map(|(i, yi)| yi * self.row_dot(i, |j| y[j]))
            .sum();
        0.5 * sum
    }

    /// `(x₁ − x₀)ᵀ A (y₀ + y₁)`, without forming the difference of two large products.
    pub fn increment_form(&self, x0: &[f64], x1: &[f64], y0: &[f64], y1: &[f64]) -> f64 {
        (0..self.n)
            .map(|i| (x1[i] - x0[i]) * self.row_dot(i, |j| y0[j] + y1[j]))
            .sum()
    }

    /// `Σ_j A_ij y(j)` over row `i`, in four independent partial sums (a long row of a dense
    /// or reduced model would otherwise wait on one addition chain).
    #[inline]
    fn row_dot(&self, i: usize, y: impl Fn(usize) -> f64) -> f64 {
        let (lo, hi) = (self.row_start[i], self.row_start[i + 1]);
        let (cols, vals) = (&self.cols[lo..hi], &self.vals[lo..hi]);
        let mut lanes = [0.0; 4];
        let (c4, v4) = (cols.chunks_exact(4), vals.chunks_exact(4));
        let (c_rest, v_rest) = (c4.remainder(), v4.remainder());
        for (c, v) in c4.zip(v4) {
            for k in 0..4 {
                lanes[k] += v[k] * y(c[k]);
            }
        }
        let tail: f64 = c_rest.iter().zip(v_rest).map(|(&j, v)| v * y(j)).sum();
        (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]) + tail
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
///
/// The solve works on a padded vector `z` (see [`BandedCholesky::work_len`]): row `i` of the
/// reordered system lives at `z[bw + i]`, with `bw` zeros on either side, so every row's
/// forward and backward sums are over contiguous slices of fixed length `bw`.
#[derive(Debug, Clone)]
pub struct BandedCholesky {
    n: usize,
    bandwidth: usize,
    /// `perm[new] = old`.
    perm: Vec<usize>,
    /// Row `i` holds `L[i][i − bw .. i] / L[i][i]` (zero where the index is negative).
    lower: Vec<f64>,
    /// Row `i` holds `L[i + 1 ..= i + bw][i] / L[i][i]` (zero past the last row): column `i`
    /// below the diagonal, for the backward solve.
    upper: Vec<f64>,
    /// `1 / L[i][i]`.
    inv_diag: Vec<f64>,
}

impl BandedCholesky {
    /// Bandwidth that `matrices`' combined pattern has in reverse Cuthill–McKee order.
    pub fn ordering(n: usize, matrices: &[&Csr]) -> (Vec<usize>, usize) {
        let perm = reverse_cuthill_mckee(n, matrices);
        let inv = inverse_permutation(&perm);
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
        let bw = bandwidth;
        let inv = inverse_permutation(&perm);
        // Row i of the band: entries j = i − bw ..= i at offsets 0 ..= bw.
        let w = bw + 1;
        let mut band = vec![0.0; n * w];
        for &(c, a) in terms {
            if c == 0.0 {
                continue;
            }
            for i in 0..n {
                for (j, v) in a.row(i) {
                    let (pi, pj) = (inv[i], inv[j]);
                    if pj <= pi {
                        band[pi * w + (pj + bw - pi)] += c * v;
                    }
                }
            }
        }
        for i in 0..n {
            let lo = i.saturating_sub(bw);
            for j in lo..=i {
                let mut s = band[i * w + (j + bw - i)];
                for k in lo.max(j.saturating_sub(bw))..j {
                    s -= band[i * w + (k + bw - i)] * band[j * w + (k + bw - j)];
                }
                if i == j {
                    if !(s > 0.0 && s.is_finite()) {
                        return None;
                    }
                    band[i * w + bw] = s.sqrt();
                } else {
                    band[i * w + (j + bw - i)] = s / band[j * w + bw];
                }
            }
        }
        let mut lower = vec![0.0; n * bw];
        let mut upper = vec![0.0; n * bw];
        let mut inv_diag = vec![0.0; n];
        for i in 0..n {
            inv_diag[i] = 1.0 / band[i * w + bw];
            for k in 0..bw {
                // L[i][i − bw + k] / L[i][i]
                lower[i * bw + k] = band[i * w + k] * inv_diag[i];
                // L[i + 1 + k][i] / L[i][i], stored in row i + 1 + k at offset bw − 1 − k
                if i + 1 + k < n {
                    upper[i * bw + k] = band[(i + 1 + k) * w + (bw - 1 - k)] * inv_diag[i];
                }
            }
        }
        Some(Self {
            n,
            bandwidth,
            perm,
            lower,
            upper,
            inv_diag,
        })
    }

    pub fn bandwidth(&self) -> usize {
        self.bandwidth
    }

    /// `perm[new] = old`: the order the factor works in.
    pub fn permutation(&self) -> &[usize] {
        &self.perm
    }

    /// Length of the padded work vector of [`Self::solve_padded`].
    pub fn work_len(&self) -> usize {
        self.n + 2 * self.bandwidth
    }

    /// Solves `A x = b` with `b` in the factor's order at `z[bw .. bw + n]` (the padding
    /// `z[.. bw]` and `z[bw + n ..]` must be zero); `x` replaces `b` there.
    pub fn solve_padded(&self, z: &mut [f64]) {
        debug_assert_eq!(z.len(), self.work_len());
        // Narrow bands (beams: 3 to 6; 3-D frames: up to about 12) get unrolled row sums.
        match self.bandwidth {
            1 => self.substitute::<1>(z),
            2 => self.substitute::<2>(z),
            3 => self.substitute::<3>(z),
            4 => self.substitute::<4>(z),
            5 => self.substitute::<5>(z),
            6 => self.substitute::<6>(z),
            7 => self.substitute::<7>(z),
            8 => self.substitute::<8>(z),
            9 => self.substitute::<9>(z),
            10 => self.substitute::<10>(z),
            11 => self.substitute::<11>(z),
            12 => self.substitute::<12>(z),
            _ => self.substitute::<0>(z),
        }
    }

    /// Forward and backward substitution with the rows scaled by `1/L[i][i]`, each row's
    /// nearest term subtracted last: the chain from one row to the next is one multiply and
    /// one subtraction. `B` is the bandwidth when it is known at compile time, 0 when not.
    #[inline(always)]
    fn substitute<const B: usize>(&self, z: &mut [f64]) {
        let (n, bw) = (self.n, self.bandwidth);
        for (zi, d) in z[bw..bw + n].iter_mut().zip(&self.inv_diag) {
            *zi *= d;
        }
        if bw == 0 {
            // a diagonal matrix: L = D^½
            for (zi, d) in z.iter_mut().zip(&self.inv_diag) {
                *zi *= d;
            }
            return;
        }
        for i in 0..n {
            let row = &self.lower[i * bw..(i + 1) * bw];
            let far = band_dot::<B>(&row[..bw - 1], &z[i..i + bw - 1]);
            z[bw + i] = (z[bw + i] - far) - row[bw - 1] * z[bw + i - 1];
        }
        for (zi, d) in z[bw..bw + n].iter_mut().zip(&self.inv_diag) {
            *zi *= d;
        }
        for i in (0..n).rev() {
            let col = &self.upper[i * bw..(i + 1) * bw];
            let far = band_dot::<B>(&col[1..], &z[bw + i + 2..2 * bw + i + 1]);
            z[bw + i] = (z[bw + i] - far) - col[0] * z[bw + i + 1];
        }
    }
}

/// `a · b` for two slices of the same length, `B − 1` when `B > 0` (the band's terms but the
/// nearest).
#[inline(always)]
fn band_dot<const B: usize>(a: &[f64], b: &[f64]) -> f64 {
    if B == 0 {
        return a.iter().zip(b).map(|(x, y)| x * y).sum();
    }
    let (a, b) = (&a[..B - 1], &b[..B - 1]);
    (0..B - 1).map(|k| a[k] * b[k]).sum()
}

/// `inv[old] = new` for `perm[new] = old`.
pub(crate) fn inverse_permutation(perm: &[usize]) -> Vec<usize> {
    let mut inv = vec![0; perm.len()];
    for (new, &old) in perm.iter().enumerate() {
        inv[old] = new;
    }
    inv
}

/// Several sparse operators applied together, `r = Σₖ Aₖ yₖ`, with the rows of the union
/// pattern in a given order (the banded factor's) and `K` values per entry: one pass over
/// the indices instead of one per matrix.
#[derive(Debug, Clone)]
pub struct StackedRows<const K: usize> {
    row_start: Vec<usize>,
    /// `(column, [A₀, …, A_{K−1}] at that column)`, row after row.
    entries: Vec<(usize, [f64; K])>,
}

impl<const K: usize> StackedRows<K> {
    /// `Aₖ = Σ_terms c A` for the terms listed under `k`; row `r` of the result is row
    /// `order[r]` of the operators.
    pub fn new(operators: [&[(f64, &Csr)]; K], order: &[usize]) -> Self {
        let mut row_start = Vec::with_capacity(order.len() + 1);
        let mut stacked: Vec<(usize, [f64; K])> = Vec::new();
        row_start.push(0);
        let mut entries: Vec<(usize, usize, f64)> = Vec::new();
        for &i in order {
            entries.clear();
            for (k, terms) in operators.iter().enumerate() {
                for &(c, a) in terms.iter() {
                    entries.extend(a.row(i).map(|(j, v)| (j, k, c * v)));
                }
            }
            entries.sort_unstable_by_key(|e| e.0);
            for &(j, k, v) in &entries {
                let row_begins = stacked.len() == *row_start.last().expect("pushed");
                if row_begins || stacked.last().map(|e| e.0) != Some(j) {
                    stacked.push((j, [0.0; K]));
                }
                stacked.last_mut().expect("pushed").1[k] += v;
            }
            row_start.push(stacked.len());
        }
        Self {
            row_start,
            entries: stacked,
        }
    }

    /// `out[r] += Σₖ (Aₖ yₖ)[r]` for every row `r`, with `y(j) = [y₀[j], …, y_{K−1}[j]]`.
    #[inline]
    pub fn add_to(&self, y: impl Fn(usize) -> [f64; K], out: &mut [f64]) {
        let mut lo = 0;
        for (o, &hi) in out.iter_mut().zip(&self.row_start[1..]) {
            // one accumulator per operator: K independent addition chains
            let mut acc = [0.0; K];
            for (j, v) in &self.entries[lo..hi] {
                let yj = y(*j);
                for k in 0..K {
                    acc[k] += v[k] * yj[k];
                }
            }
            *o += acc.iter().sum::<f64>();
            lo = hi;
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
        crate::factor::SpdFactor::Banded(f).solve_in_place(&mut x);
        let exact = a.lu().solve(&nalgebra::DVector::from_vec(b)).unwrap();
        for i in 0..n {
            assert!((x[i] - exact[i]).abs() < 1e-12, "{i}");
        }
        let mut y = vec![0.0; n];
        csr.mul_add(1.0, &x, &mut y);
        assert!((y[5] - (5.0_f64).sin()).abs() < 1e-12);
    }

    /// Both dense kernels (SIMD where the CPU has it, and plain Rust) subtract `A x` for
    /// every shape, remainders of the four-row and four-column blocks included.
    #[test]
    fn dense_mat_vec_kernels_subtract_a_x() {
        for (rows, cols) in [(1, 1), (2, 3), (3, 5), (4, 4), (7, 9), (13, 6), (42, 42)] {
            let a: Vec<f64> = (0..rows * cols)
                .map(|k| ((k * 37) % 11) as f64 - 5.0)
                .collect();
            let x: Vec<f64> = (0..cols).map(|j| 0.5 + j as f64 * 0.25).collect();
            let expected: Vec<f64> = (0..rows)
                .map(|i| 1.0 - (0..cols).map(|j| a[i * cols + j] * x[j]).sum::<f64>())
                .collect();
            for kernel in [DenseMatVec::fastest(), DenseMatVec::portable()] {
                let mut y = vec![1.0; rows];
                (kernel.sub)(&a, &x, &mut y);
                for (got, want) in y.iter().zip(&expected) {
                    assert!(
                        (got - want).abs() < 1e-12 * want.abs().max(1.0),
                        "{rows}x{cols}"
                    );
                }
                // `apply` (plain Rust at the call below four rows) gives the same bits
                let mut z = vec![1.0; rows];
                kernel.apply(&a, &x, &mut z);
                assert_eq!(y, z, "{rows}x{cols}");
            }
        }
    }

    #[test]
    fn csr_from_parts_checks_its_arrays() {
        let ok = Csr::from_parts(2, vec![0, 2, 3], vec![0, 1, 1], vec![2.0, -1.0, 3.0]).unwrap();
        assert_eq!(
            ok.to_dense(),
            DMatrix::from_row_slice(2, 2, &[2.0, -1.0, 0.0, 3.0])
        );
        assert_eq!(ok.transpose().to_dense(), ok.to_dense().transpose());
        assert_eq!(ok.asymmetry(), 1.0);
        let sym = Csr::from_dense(&DMatrix::from_row_slice(2, 2, &[2.0, -1.0, -1.0, 3.0]));
        assert_eq!(sym.asymmetry(), 0.0);
        for (ptr, idx, what) in [
            (vec![0, 2], vec![0, 1], "indptr has 2 entries"),
            (vec![0, 2, 1], vec![0, 1], "indptr runs from 0 to 1"),
            (
                vec![0, 2, 2],
                vec![1, 0],
                "row 0: column indices not strictly increasing",
            ),
            (
                vec![0, 2, 2],
                vec![0, 0],
                "row 0: column indices not strictly increasing",
            ),
            (vec![0, 1, 2], vec![0, 2], "row 1 has column 2"),
        ] {
            let vals = vec![1.0; idx.len()];
            let e = Csr::from_parts(2, ptr, idx, vals).unwrap_err();
            assert!(e.contains(what), "{e}");
        }
    }

    #[test]
    fn indefinite_matrix_is_refused() {
        let a = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        let csr = Csr::from_dense(&a);
        let (perm, bw) = BandedCholesky::ordering(2, &[&csr]);
        assert!(BandedCholesky::factor(&[(1.0, &csr)], perm, bw).is_none());
    }
}
