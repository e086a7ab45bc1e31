//! The banded Cholesky factor in reverse Cuthill–McKee order against faer's general sparse
//! one (approximate minimum degree) on the effective stiffness `K + 4M/h²` of beams and of
//! the C3D20 cantilever, in one process: factor time, per-step solve time (the stepper's
//! `solve_permuted` on a preallocated work vector), and the sparse products of a step (our
//! fused rows against faer's sparse × dense product).
//! `cargo run --release --example factor_compare -p vibroimpact-core`
//! (env `REPS`: timing rounds, default 7; each number is the fastest round; `MODEL`: only the
//! models whose name contains it, e.g. for instruction counts under callgrind).

use std::time::Instant;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::reborrow::ReborrowMut;
use faer::sparse::linalg::matmul::sparse_dense_matmul;
use faer::sparse::{SparseRowMatRef, SymbolicSparseRowMatRef};
use faer::{Accum, MatMut, MatRef, Par};
use vibroimpact_core::factor::{FactorChoice, FactorPlan};
use vibroimpact_core::linalg::{Csr, StackedRows};

/// Symmetric matrix assembled from element blocks: `(dofs, values row-major)`.
fn assemble(n: usize, elements: &[(Vec<usize>, Vec<f64>)]) -> Csr {
    let mut rows: Vec<std::collections::BTreeMap<usize, f64>> = vec![Default::default(); n];
    for (dofs, vals) in elements {
        let e = dofs.len();
        for (a, &i) in dofs.iter().enumerate() {
            for (b, &j) in dofs.iter().enumerate() {
                let v = vals[a * e + b];
                if v != 0.0 {
                    *rows[i].entry(j).or_default() += v;
                }
            }
        }
    }
    let (mut ptr, mut idx, mut val) = (vec![0], vec![], vec![]);
    for r in rows {
        for (j, v) in r {
            idx.push(j);
            val.push(v);
        }
        ptr.push(idx.len());
    }
    Csr::from_parts(n, ptr, idx, val).unwrap()
}

/// Euler–Bernoulli bending stiffness and consistent mass of one element (v, θ, v, θ).
fn bending(ei: f64, rho_a: f64, l: f64) -> ([f64; 16], [f64; 16]) {
    let k = [
        12.0,
        6.0 * l,
        -12.0,
        6.0 * l,
        6.0 * l,
        4.0 * l * l,
        -6.0 * l,
        2.0 * l * l,
        -12.0,
        -6.0 * l,
        12.0,
        -6.0 * l,
        6.0 * l,
        2.0 * l * l,
        -6.0 * l,
        4.0 * l * l,
    ]
    .map(|v| v * ei / l.powi(3));
    let m = [
        156.0,
        22.0 * l,
        54.0,
        -13.0 * l,
        22.0 * l,
        4.0 * l * l,
        13.0 * l,
        -3.0 * l * l,
        54.0,
        13.0 * l,
        156.0,
        -22.0 * l,
        -13.0 * l,
        -3.0 * l * l,
        -22.0 * l,
        4.0 * l * l,
    ]
    .map(|v| v * rho_a * l / 420.0);
    (k, m)
}

/// A free steel tube (outer 0.19 m, wall 5 mm, 1 m) of `elements` beam elements with
/// `dofs_per_node` = 2 (planar bending) or 6 (3-D frame: axial, torsion, two bending planes).
fn beam(elements: usize, dofs_per_node: usize) -> (Csr, Csr) {
    let (e, g, rho) = (207e9, 79.6e9, 7850.0);
    let (ro, ri) = (0.095_f64, 0.090_f64);
    let area = std::f64::consts::PI * (ro * ro - ri * ri);
    let inertia = std::f64::consts::PI / 4.0 * (ro.powi(4) - ri.powi(4));
    let l = 1.0 / elements as f64;
    let n = dofs_per_node * (elements + 1);
    let (kb, mb) = bending(e * inertia, rho * area, l);
    let (mut ks, mut ms) = (Vec::new(), Vec::new());
    for el in 0..elements {
        let node = |a: usize, d: usize| (el + a) * dofs_per_node + d;
        // (dof of each end, 2×2 stiffness and mass) pairs and the bending planes
        let planes: Vec<[usize; 2]> = if dofs_per_node == 2 {
            vec![[0, 1]]
        } else {
            vec![[1, 5], [2, 4]]
        };
        for [v, t] in planes {
            let dofs = vec![node(0, v), node(0, t), node(1, v), node(1, t)];
            ks.push((dofs.clone(), kb.to_vec()));
            ms.push((dofs, mb.to_vec()));
        }
        if dofs_per_node == 6 {
            let polar = 2.0 * inertia;
            for (d, stiff, mass) in [(0, e * area, rho * area), (3, g * polar, rho * polar)] {
                let dofs = vec![node(0, d), node(1, d)];
                let k = stiff / l;
                ks.push((dofs.clone(), vec![k, -k, -k, k]));
                let m = mass * l / 6.0;
                ms.push((dofs, vec![2.0 * m, m, m, 2.0 * m]));
            }
        }
    }
    (assemble(n, &ks), assemble(n, &ms))
}

/// The pattern of the CalculiX cantilever of `vibroimpact bench`: 20 × 1 × 2 twenty-node
/// hexahedra (serendipity nodes of a (2·20 + 1) × 3 × 5 grid), clamped at x = 0, three DOFs
/// a node (1,140 DOFs); each element a full 60 × 60 block (`61 I − 11ᵀ`, positive definite)
/// and a lumped unit mass.
fn c3d20_cantilever() -> (Csr, Csr) {
    let (ex, ey, ez) = (20, 1, 2);
    let (gx, gy, gz) = (2 * ex + 1, 2 * ey + 1, 2 * ez + 1);
    let odd = |i: usize, j: usize, k: usize| (i % 2) + (j % 2) + (k % 2);
    let mut index = vec![usize::MAX; gx * gy * gz];
    let mut next = 0;
    for i in 1..gx {
        for j in 0..gy {
            for k in 0..gz {
                if odd(i, j, k) <= 1 {
                    index[(i * gy + j) * gz + k] = next;
                    next += 1;
                }
            }
        }
    }
    let n = 3 * next;
    let mut ks = Vec::new();
    for a in 0..ex {
        for b in 0..ey {
            for c in 0..ez {
                let mut dofs = Vec::new();
                let mut nodes = 0;
                for i in 2 * a..=2 * a + 2 {
                    for j in 2 * b..=2 * b + 2 {
                        for k in 2 * c..=2 * c + 2 {
                            if odd(i, j, k) <= 1 {
                                nodes += 1;
                                let id = index[(i * gy + j) * gz + k];
                                if id != usize::MAX {
                                    dofs.extend((0..3).map(|d| 3 * id + d));
                                }
                            }
                        }
                    }
                }
                assert_eq!(nodes, 20);
                let e = dofs.len();
                let vals = (0..e * e)
                    .map(|p| if p % (e + 1) == 0 { e as f64 } else { -1.0 })
                    .map(|v| v * 1e9)
                    .collect();
                ks.push((dofs, vals));
            }
        }
    }
    let masses = (0..n).map(|i| (vec![i], vec![1e-2])).collect::<Vec<_>>();
    (assemble(n, &ks), assemble(n, &masses))
}

fn as_faer(a: &Csr) -> SparseRowMatRef<'_, usize, f64> {
    let (ptr, idx, val) = a.parts();
    let sym = SymbolicSparseRowMatRef::new_checked(a.n(), a.n(), ptr, None, idx);
    SparseRowMatRef::new(sym, val)
}

/// The fastest of `reps` rounds of `f` run `inner` times, per call, in µs.
fn fastest(reps: usize, inner: usize, mut f: impl FnMut()) -> f64 {
    (0..reps)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..inner {
                f();
            }
            t.elapsed().as_secs_f64() / inner as f64 * 1e6
        })
        .fold(f64::INFINITY, f64::min)
}

fn main() {
    let reps: usize = std::env::var("REPS")
        .map(|s| s.parse().unwrap())
        .unwrap_or(7);
    let h = 1e-6;
    let models: Vec<(&str, (Csr, Csr))> = vec![
        ("hollow shaft, 20 planar elements", beam(20, 2)),
        ("planar beam, 500 elements", beam(500, 2)),
        ("planar beam, 2,499 elements", beam(2499, 2)),
        ("3-D frame tube, 333 elements", beam(333, 6)),
        ("3-D frame tube, 833 elements", beam(833, 6)),
        ("C3D20 cantilever 20x1x2", c3d20_cantilever()),
    ];
    println!(
        "{:<34} {:>6} {:>9} {:>9} {:>10} {:>10} {:>9} {:>9} {:>9} {:>9}",
        "model",
        "DOFs",
        "chosen",
        "band",
        "L banded",
        "L sparse",
        "fact b µs",
        "fact s µs",
        "solve b µs",
        "solve s µs"
    );
    let only = std::env::var("MODEL").unwrap_or_default();
    for (name, (k, m)) in models.iter().filter(|(name, _)| name.contains(&only)) {
        let n = k.n();
        let terms = [(1.0, k), (4.0 / (h * h), m)];
        let cheapest = FactorPlan::new(&[m, k], FactorChoice::Cheapest);
        let banded_plan = FactorPlan::new(&[m, k], FactorChoice::Banded);
        let sparse_plan = FactorPlan::new(&[m, k], FactorChoice::Sparse);
        let chosen = cheapest.factor(&terms).unwrap().describe();
        let fb = banded_plan.factor(&terms).unwrap();
        let fs = sparse_plan.factor(&terms).unwrap();
        let (ib, is) = (fb.describe(), fs.describe());
        let inner_f = (2_000_000 / (n * 40)).max(1);
        let inner_s = (20_000_000 / (n * 40)).max(1);
        // [factor banded, factor sparse, solve banded, solve sparse], interleaved rounds
        let mut best = [f64::INFINITY; 4];
        let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        // the right-hand side in each factor's order
        let rb: Vec<f64> = fb.permutation().iter().map(|&old| rhs[old]).collect();
        let rs: Vec<f64> = fs.permutation().iter().map(|&old| rhs[old]).collect();
        let mut zb = vec![0.0; fb.work_len()];
        let mut zs = vec![0.0; fs.work_len()];
        let mut bufb = MemBuffer::new(fb.scratch());
        let mut bufs = MemBuffer::new(fs.scratch());
        for _ in 0..reps {
            best[0] = best[0].min(fastest(1, inner_f, || {
                std::hint::black_box(banded_plan.factor(&terms));
            }));
            best[1] = best[1].min(fastest(1, inner_f, || {
                std::hint::black_box(sparse_plan.factor(&terms));
            }));
            best[2] = best[2].min(fastest(1, inner_s, || {
                let off = fb.offset();
                zb[off..off + n].copy_from_slice(&rb);
                fb.solve_permuted(&mut zb, MemStack::new(&mut bufb));
                std::hint::black_box(&zb);
            }));
            best[3] = best[3].min(fastest(1, inner_s, || {
                zs[..n].copy_from_slice(&rs);
                fs.solve_permuted(&mut zs, MemStack::new(&mut bufs));
                std::hint::black_box(&zs);
            }));
        }
        // the solves agree
        let (pb, ps) = (fb.permutation(), fs.permutation());
        let worst = (0..n)
            .map(|i| (zb[fb.offset() + i], pb[i]))
            .map(|(v, old)| {
                let new = ps.iter().position(|&p| p == old).unwrap();
                (v - zs[new]).abs()
            })
            .fold(0.0_f64, f64::max);
        let scale = zs[..n].iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        assert!(worst <= 1e-9 * scale, "{name}: {worst:e} of {scale:e}");
        println!(
            "{:<34} {:>6} {:>9} {:>9} {:>10} {:>10} {:>9.1} {:>9.1} {:>9.2} {:>9.2}",
            name,
            n,
            chosen.solver.trim_start_matches("sparse-"),
            ib.bandwidth.unwrap(),
            ib.stored_values,
            is.stored_values,
            best[0],
            best[1],
            best[2],
            best[3],
        );
        // the per-step products R = K x + C v: our fused rows against faer's product
        let stacked = StackedRows::<2>::new([&[(1.0, k)], &[(1.0, m)]], fb.permutation());
        let (x, v) = (rhs.clone(), rhs.iter().map(|a| 2.0 * a).collect::<Vec<_>>());
        let mut out = vec![0.0; n];
        let ours = fastest(reps, inner_s, || {
            out.fill(0.0);
            stacked.add_to(|j| [x[j], v[j]], &mut out);
            std::hint::black_box(&out);
        });
        let (fk, fm) = (as_faer(k), as_faer(m));
        let theirs = fastest(reps, inner_s, || {
            let mut dst = MatMut::from_column_major_slice_mut(&mut out, n, 1);
            sparse_dense_matmul(
                dst.rb_mut(),
                Accum::Replace,
                fk,
                MatRef::from_column_major_slice(&x, n, 1),
                1.0,
                Par::Seq,
            );
            sparse_dense_matmul(
                dst,
                Accum::Add,
                fm,
                MatRef::from_column_major_slice(&v, n, 1),
                1.0,
                Par::Seq,
            );
            std::hint::black_box(&out);
        });
        println!(
            "{:<34} products K x + M v: ours {ours:.2} µs, faer {theirs:.2} µs",
            ""
        );
    }
}
