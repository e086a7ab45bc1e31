//! Cholesky factors of the sparse symmetric positive definite matrices of a structure (`M`,
//! and the effective stiffness `K̃ = K + c_M M + c_C C` of the implicit schemes): the banded
//! factor in reverse Cuthill–McKee order ([`BandedCholesky`]: narrow bands, beams and
//! frames) or a general sparse one from `faer` (approximate minimum degree ordering,
//! simplicial or supernodal: 3-D solids, whose bands are wide), whichever is estimated to
//! solve faster ([`FactorPlan`]).
//!
//! Why the banded factor stays beside faer's: on the narrow bands of beams it is the faster
//! one, measured in one process (`examples/factor_compare.rs`, `K + 4M/h²`, fastest of 40
//! interleaved rounds, one core of an EPYC under load): the hollow shaft (42 DOFs, band 3)
//! factors in 1.5 µs against 3.8 µs and solves in 0.35 against 0.39 µs; planar beams of
//! 1,002 and 5,000 DOFs factor in 33 and 165 µs against 75 and 371 µs and solve in 8.6 and
//! 42 µs against 10.3 and 51 µs; 3-D tubes of 2,004 and 5,004 DOFs (the imported model of
//! `vibroimpact bench`) solve in 17 and 43 µs against 21 and 52 µs: faer's solve is
//! 11–24 % slower, its factorisation 2–2.5× slower (with about as many instructions).
//! Instruction counts (callgrind) agree for the solve: faer's takes 26–46 % more on these
//! beams (its simplicial substitution goes through column indices; the band's rows are
//! contiguous and unrolled). On the C3D20 cantilever (1,140 DOFs, band 86) faer's factor
//! stores 64 k values against the band's 99 k and solves in 53 µs against 60 µs, and is the
//! one chosen.

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::{LltParams, LltRegularization};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, simplicial::SimplicialLltRef, supernodal::SupernodalLltRef,
    CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side, Spec};

use crate::linalg::{BandedCholesky, Csr};

/// The factor that solves faster, decided once per sparsity pattern (the union of the
/// patterns of the terms) and reused for every set of coefficients (every step size).
#[derive(Debug, Clone)]
pub struct FactorPlan {
    kind: PlanKind,
    /// Estimated cycles of one solve with the chosen factor.
    solve_cost: usize,
    /// Estimated cycles of one factorisation (a run makes one per step size).
    factor_cost: usize,
}

#[derive(Debug, Clone)]
enum PlanKind {
    Banded { perm: Vec<usize>, bandwidth: usize },
    Sparse(Arc<SymbolicCholesky<usize>>),
}

/// Which factor a plan is for (tests force one).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FactorChoice {
    Cheapest,
    Banded,
    Sparse,
}

impl FactorPlan {
    /// Orders the union of the `patterns` both ways (reverse Cuthill–McKee for the band,
    /// approximate minimum degree for the general factor) and keeps the cheaper solve.
    ///
    /// Rough cycles per solve: the banded substitution runs two passes of `n` rows of `bw`
    /// fused terms, each row waiting on the previous (~8 cycles, `16 n (1 + bw/4)`); the
    /// general one streams the factor's values twice (~1.5 cycles a value) plus ~8 cycles
    /// per column and pass. Measured with one core of an EPYC:
    /// a 5,000-DOF beam (band 3) 42 µs banded, 51 µs simplicial; 3-D lattices of 3,000 and
    /// 12,288 DOFs 4 and 61 ms banded, 0.5 and 10 ms supernodal. The estimates order the
    /// two factors as measured on every model of `examples/factor_compare.rs`.
    ///
    /// A factorisation costs about one cycle per multiply-add of the left-looking column
    /// updates, `Σⱼ cⱼ²` over the factor's column counts `cⱼ` ([`factor_flops`]; the band's
    /// `n (bw + 1)²`).
    pub fn new(patterns: &[&Csr], choice: FactorChoice) -> Self {
        let n = patterns[0].n();
        let banded = || {
            let (perm, bandwidth) = BandedCholesky::ordering(n, patterns);
            let cost = 16 * n * (1 + bandwidth / 4);
            let factor_cost = n * (bandwidth + 1) * (bandwidth + 1);
            (PlanKind::Banded { perm, bandwidth }, cost, factor_cost)
        };
        let sparse = || {
            let union = Csr::combination(&patterns.iter().map(|a| (1.0, *a)).collect::<Vec<_>>());
            let symbolic = SparseCholesky::analyse(&union);
            let cost = 3 * symbolic.len_val() + 16 * n;
            let factor_cost = factor_flops(&symbolic);
            (PlanKind::Sparse(Arc::new(symbolic)), cost, factor_cost)
        };
        let (kind, solve_cost, factor_cost) = match choice {
            FactorChoice::Banded => banded(),
            FactorChoice::Sparse => sparse(),
            FactorChoice::Cheapest => {
                let (b, s) = (banded(), sparse());
                if s.1 < b.1 {
                    s
                } else {
                    b
                }
            }
        };
        Self {
            kind,
            solve_cost,
            factor_cost,
        }
    }

    /// Estimated cycles of one solve.
    pub fn solve_cost(&self) -> usize {
        self.solve_cost
    }

    /// Estimated cycles of one factorisation.
    pub fn factor_cost(&self) -> usize {
        self.factor_cost
    }

    /// Factorises `Σ cₖ Aₖ` (all within the planned pattern). `None` if it is not positive
    /// definite.
    pub fn factor(&self, terms: &[(f64, &Csr)]) -> Option<SpdFactor> {
        match &self.kind {
            PlanKind::Banded { perm, bandwidth } => {
                BandedCholesky::factor(terms, perm.clone(), *bandwidth).map(SpdFactor::Banded)
            }
            PlanKind::Sparse(symbolic) => {
                SparseCholesky::factor(symbolic.clone(), &Csr::combination(terms))
                    .map(SpdFactor::Sparse)
            }
        }
    }
}

/// Multiply-adds of a sparse Cholesky factorisation with the pattern `symbolic`: `Σⱼ cⱼ²`
/// over the column counts `cⱼ` of `L` (a supernode of `w` columns over `p` rows below it has
/// counts `p + w, p + w − 1, …, p + 1`).
fn factor_flops(symbolic: &SymbolicCholesky<usize>) -> usize {
    match symbolic.raw() {
        SymbolicCholeskyRaw::Simplicial(s) => s
            .col_ptr()
            .windows(2)
            .map(|w| (w[1] - w[0]) * (w[1] - w[0]))
            .sum(),
        SymbolicCholeskyRaw::Supernodal(s) => {
            let rows = s.col_ptr_for_row_idx();
            (0..s.n_supernodes())
                .map(|k| {
                    let w = s.supernode_end()[k] - s.supernode_begin()[k];
                    let p = rows[k + 1] - rows[k];
                    (p + 1..=p + w).map(|c| c * c).sum::<usize>()
                })
                .sum()
        }
    }
}

/// `A = L Lᵀ`, banded or general sparse, solved in the factor's own order on a work vector
/// `z` whose body `z[offset .. offset + n]` holds the right-hand side.
#[derive(Debug, Clone)]
pub enum SpdFactor {
    Banded(BandedCholesky),
    Sparse(SparseCholesky),
}

impl SpdFactor {
    /// Factorises `Σ cₖ Aₖ` with the cheaper factor for its pattern.
    pub fn cheapest(terms: &[(f64, &Csr)]) -> Option<Self> {
        let patterns: Vec<&Csr> = terms.iter().map(|t| t.1).collect();
        FactorPlan::new(&patterns, FactorChoice::Cheapest).factor(terms)
    }

    /// `perm[new] = old`: the order the factor works in.
    pub fn permutation(&self) -> &[usize] {
        match self {
            Self::Banded(f) => f.permutation(),
            Self::Sparse(f) => &f.perm,
        }
    }

    /// Where the body starts in the work vector (the band's zero padding before it).
    pub fn offset(&self) -> usize {
        match self {
            Self::Banded(f) => f.bandwidth(),
            Self::Sparse(_) => 0,
        }
    }

    /// Length of the work vector of [`Self::solve_permuted`].
    pub fn work_len(&self) -> usize {
        match self {
            Self::Banded(f) => f.work_len(),
            Self::Sparse(f) => f.perm.len(),
        }
    }

    /// Scratch memory that [`Self::solve_permuted`] needs.
    pub fn scratch(&self) -> StackReq {
        match self {
            Self::Banded(_) => StackReq::EMPTY,
            Self::Sparse(f) => f.scratch(),
        }
    }

    /// Solves `A x = b` with `b` in the factor's order in the body of `z` (the banded factor's
    /// padding must be zero); `x` replaces `b` there.
    pub fn solve_permuted(&self, z: &mut [f64], stack: &mut MemStack) {
        match self {
            Self::Banded(f) => f.solve_padded(z),
            Self::Sparse(f) => f.solve_permuted(z, stack),
        }
    }

    /// Solves `A x = b` in place, `b` in the original order (allocates its work space).
    pub fn solve_in_place(&self, b: &mut [f64]) {
        let (perm, offset) = (self.permutation(), self.offset());
        let mut z = vec![0.0; self.work_len()];
        for (new, &old) in perm.iter().enumerate() {
            z[offset + new] = b[old];
        }
        let mut scratch = MemBuffer::new(self.scratch());
        self.solve_permuted(&mut z, MemStack::new(&mut scratch));
        for (new, &old) in perm.iter().enumerate() {
            b[old] = z[offset + new];
        }
    }

    /// What the factor is, for reports: its kind and the values it stores.
    pub fn describe(&self) -> FactorInfo {
        match self {
            Self::Banded(f) => FactorInfo {
                solver: "banded",
                dofs: f.permutation().len(),
                bandwidth: Some(f.bandwidth()),
                stored_values: f.work_len().saturating_sub(2 * f.bandwidth()) * (f.bandwidth() + 1),
            },
            Self::Sparse(f) => FactorInfo {
                solver: f.kind(),
                dofs: f.perm.len(),
                bandwidth: None,
                stored_values: f.symbolic.len_val(),
            },
        }
    }
}

/// A factor's kind and size, for `--verbose` and the benchmarks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FactorInfo {
    /// `dense` (the inverse applied to the operators), `banded`, `sparse-simplicial` or
    /// `sparse-supernodal`.
    pub solver: &'static str,
    /// Order of the factorised matrix.
    pub dofs: usize,
    /// The band's half-width (banded factors only).
    pub bandwidth: Option<usize>,
    /// Values of `L` the factor stores (and every solve reads twice); for `dense`, of the
    /// `n × n` operators.
    pub stored_values: usize,
}

/// A general sparse `A = L Lᵀ` from `faer`, in approximate minimum degree order.
#[derive(Debug, Clone)]
pub struct SparseCholesky {
    symbolic: Arc<SymbolicCholesky<usize>>,
    values: Vec<f64>,
    /// `perm[new] = old`.
    perm: Vec<usize>,
}

impl SparseCholesky {
    /// The fill-reducing order and the pattern of `L` for the pattern of the symmetric `a`.
    pub fn analyse(a: &Csr) -> SymbolicCholesky<usize> {
        let (row_start, cols, _) = a.parts();
        // a symmetric pattern: the rows of `a` are its columns
        let pattern = SymbolicSparseColMatRef::new_checked(a.n(), a.n(), row_start, None, cols);
        factorize_symbolic_cholesky(
            pattern,
            Side::Lower,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .expect("the symbolic analysis of a checked pattern")
    }

    /// Factorises the symmetric `a` (whose pattern `symbolic` was made for). `None` if it is
    /// not positive definite.
    pub fn factor(symbolic: Arc<SymbolicCholesky<usize>>, a: &Csr) -> Option<Self> {
        let (row_start, cols, vals) = a.parts();
        let pattern = SymbolicSparseColMatRef::new_checked(a.n(), a.n(), row_start, None, cols);
        let matrix = SparseColMatRef::new(pattern, vals);
        let mut values = vec![0.0; symbolic.len_val()];
        let params: Spec<LltParams, f64> = Default::default();
        let mut scratch =
            MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, params));
        symbolic
            .factorize_numeric_llt(
                &mut values,
                matrix,
                Side::Lower,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut scratch),
                params,
            )
            .ok()?;
        if values.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let perm = match symbolic.perm() {
            Some(p) => p.arrays().0.to_vec(),
            None => (0..a.n()).collect(),
        };
        Some(Self {
            symbolic,
            values,
            perm,
        })
    }

    fn kind(&self) -> &'static str {
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(_) => "sparse-simplicial",
            SymbolicCholeskyRaw::Supernodal(_) => "sparse-supernodal",
        }
    }

    fn scratch(&self) -> StackReq {
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(s) => s.solve_in_place_scratch::<f64>(1),
            SymbolicCholeskyRaw::Supernodal(s) => s.solve_in_place_scratch::<f64>(1, Par::Seq),
        }
    }

    /// Forward and backward substitution on `z` in the factor's order.
    fn solve_permuted(&self, z: &mut [f64], stack: &mut MemStack) {
        let rhs = MatMut::from_column_major_slice_mut(z, z.len(), 1);
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(s) => SimplicialLltRef::new(s, &self.values)
                .solve_in_place_with_conj(Conj::No, rhs, Par::Seq, stack),
            SymbolicCholeskyRaw::Supernodal(s) => SupernodalLltRef::new(s, &self.values)
                .solve_in_place_with_conj(Conj::No, rhs, Par::Seq, stack),
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::*;

    /// The stiffness of a 3-D lattice of `k × k × k` nodes with springs to the six nearest
    /// neighbours and to the ground, in scrambled node order: a pattern with a wide band.
    pub(crate) fn lattice(k: usize) -> DMatrix<f64> {
        let n = k * k * k;
        let scramble = |i: usize| (i * 7919) % n;
        let mut a = DMatrix::zeros(n, n);
        for x in 0..k {
            for y in 0..k {
                for z in 0..k {
                    let i = scramble((x * k + y) * k + z);
                    a[(i, i)] += 1.0 + 0.01 * i as f64;
                    for (dx, dy, dz) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                        let (p, q, r) = (x + dx, y + dy, z + dz);
                        if p < k && q < k && r < k {
                            let j = scramble((p * k + q) * k + r);
                            let s = 10.0 + (i + j) as f64 * 0.1;
                            a[(i, i)] += s;
                            a[(j, j)] += s;
                            a[(i, j)] -= s;
                            a[(j, i)] -= s;
                        }
                    }
                }
            }
        }
        a
    }

    /// Both factors, forced and chosen, solve the lattice like a dense LU does; on this wide
    /// band the general factor stores fewer values and is the one chosen.
    #[test]
    fn sparse_and_banded_factors_match_dense_solve() {
        let a = lattice(7);
        let n = a.nrows();
        let csr = Csr::from_dense(&a);
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let exact = a.clone().lu().solve(&DVector::from_vec(b.clone())).unwrap();
        let mut infos = Vec::new();
        for choice in [
            FactorChoice::Banded,
            FactorChoice::Sparse,
            FactorChoice::Cheapest,
        ] {
            let f = FactorPlan::new(&[&csr], choice)
                .factor(&[(1.0, &csr)])
                .unwrap();
            let mut x = b.clone();
            f.solve_in_place(&mut x);
            for i in 0..n {
                assert!(
                    (x[i] - exact[i]).abs() < 1e-12 * exact.amax(),
                    "{choice:?} {i}"
                );
            }
            infos.push(f.describe());
        }
        assert_eq!(infos[0].solver, "banded");
        assert!(infos[1].solver.starts_with("sparse"), "{:?}", infos[1]);
        assert!(infos[1].stored_values < infos[0].stored_values, "{infos:?}");
        assert_eq!(infos[2], infos[1]);
    }

    /// On a lattice large enough for dense blocks (flops per value above faer's threshold)
    /// the supernodal factor is chosen, and solves with a residual at round-off.
    #[test]
    fn supernodal_factor_solves_a_larger_lattice() {
        let a = Csr::from_dense(&lattice(13));
        let n = a.n();
        let f = SpdFactor::cheapest(&[(1.0, &a)]).unwrap();
        assert_eq!(f.describe().solver, "sparse-supernodal");
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut x = b.clone();
        f.solve_in_place(&mut x);
        let mut r = b.clone();
        a.mul_add(-1.0, &x, &mut r);
        let worst = r.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        assert!(worst < 1e-12, "{worst:e}");
    }

    /// A combination of two matrices with different patterns is factorised as their sum;
    /// one that is not positive definite is refused.
    #[test]
    fn combinations_and_indefinite_matrices() {
        let k = Csr::from_dense(&lattice(3));
        let m = Csr::from_dense(&DMatrix::from_diagonal(&DVector::from_fn(27, |i, _| {
            1.0 + i as f64
        })));
        let sum = k.to_dense() + m.to_dense() * 3.0;
        let plan = FactorPlan::new(&[&k, &m], FactorChoice::Sparse);
        let f = plan.factor(&[(1.0, &k), (3.0, &m)]).unwrap();
        let b: Vec<f64> = (0..27).map(|i| 1.0 + i as f64).collect();
        let mut x = b.clone();
        f.solve_in_place(&mut x);
        let exact = sum.lu().solve(&DVector::from_vec(b)).unwrap();
        for i in 0..27 {
            assert!((x[i] - exact[i]).abs() < 1e-12 * exact.amax(), "{i}");
        }
        assert!(plan.factor(&[(1.0, &k), (-1e3, &m)]).is_none());
    }
}
