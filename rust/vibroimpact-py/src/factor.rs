//! The core's sparse Cholesky factor for the Python side's own sparse solves (the
//! Craig–Bampton reduction's interior stiffness: its constraint modes and the shift-invert
//! of its fixed-interface modes), chosen by the same cost model as a run's factor.

use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArrayDyn, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;

use crate::{convert, ModelError};
use vibroimpact_core::factor::SpdFactor;

/// `A = L Lᵀ` of a sparse symmetric positive definite `A` (a SciPy CSR array with sorted
/// indices): banded or faer's general sparse factor, whichever solves faster
/// (`factor::FactorPlan`).
#[pyclass(module = "vibroimpact._core", frozen)]
pub(crate) struct CholeskyFactor(SpdFactor);

#[pymethods]
impl CholeskyFactor {
    #[new]
    fn new(py: Python<'_>, matrix: &Bound<'_, PyAny>) -> PyResult<Self> {
        let a = convert::csr(matrix, "matrix")?;
        let scale = a.values().iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let asymmetry = a.asymmetry();
        if asymmetry > 1e-12 * scale {
            return Err(ModelError::new_err(format!(
                "matrix: max |A - A^T| = {asymmetry:.3e} (of entries up to {scale:.3e}); \
                 expected a symmetric matrix"
            )));
        }
        py.detach(|| SpdFactor::cheapest(&[(1.0, &a)]))
            .map(Self)
            .ok_or_else(|| {
                ModelError::new_err(
                    "matrix: the Cholesky factorisation failed; expected a symmetric positive \
                     definite matrix",
                )
            })
    }

    /// `A⁻¹ b` for a vector `b` (n) or each column of `b` (n × k).
    fn solve<'py>(
        &self,
        py: Python<'py>,
        b: PyReadonlyArrayDyn<'py, f64>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let n = self.0.permutation().len();
        let shape = b.shape().to_vec();
        if shape.is_empty() || shape.len() > 2 || shape[0] != n {
            let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
            let shown = match dims.len() {
                1 => format!("({},)", dims[0]),
                _ => format!("({})", dims.join(", ")),
            };
            return Err(ModelError::new_err(format!(
                "b: shape {shown} is not valid; expected ({n},) or ({n}, k)"
            )));
        }
        let b = b.as_array();
        let k = if shape.len() == 2 { shape[1] } else { 1 };
        let mut columns: Vec<Vec<f64>> = (0..k)
            .map(|j| {
                (0..n)
                    .map(|i| if shape.len() == 2 { b[[i, j]] } else { b[[i]] })
                    .collect()
            })
            .collect();
        py.detach(|| {
            for c in &mut columns {
                self.0.solve_in_place(c);
            }
        });
        Ok(if shape.len() == 2 {
            Array2::from_shape_fn((n, k), |(i, j)| columns[j][i])
                .into_dyn()
                .into_pyarray(py)
        } else {
            Array1::from_vec(columns.pop().unwrap_or_default())
                .into_dyn()
                .into_pyarray(py)
        })
    }

    /// The factor's kind: `banded`, `sparse-simplicial` or `sparse-supernodal`.
    #[getter]
    fn solver(&self) -> &'static str {
        self.0.describe().solver
    }

    /// Values of `L` the factor stores.
    #[getter]
    fn stored_values(&self) -> usize {
        self.0.describe().stored_values
    }
}
