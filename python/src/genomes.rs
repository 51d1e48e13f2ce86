//! Genomes as Python users have them: a 2-D numpy array of any float dtype (numpy, pycma,
//! JAX and torch default to float64), turned into the float32 genes hevo evaluates, in one
//! place for `hevo.evaluate` and `hevo.Client.evaluate`. float16 and float32 convert exactly;
//! float64 rounds to the nearest float32 (ties to even, as numpy's `astype(np.float32)`);
//! other float dtypes (longdouble) go through float64. A gene outside the controller files'
//! range [GENE_MIN, GENE_MAX] is clipped to it with `clip=True` and refused otherwise, naming
//! the row of the batch and the gene; NaN and infinity are refused either way.

use crate::ControllerError;
use hevo_sim_core::{GENE_MAX, GENE_MIN};
use numpy::ndarray::ArrayView2;
use numpy::{PyArrayDescrMethods, PyReadonlyArray2, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use std::sync::Arc;

/// One gene as it is evaluated: `value` (any float, as f64) at `[row_idx, gene_idx]` of the
/// batch, clipped to the gene range when `clip` is set, rounded to the nearest f32.
fn gene(value: f64, row_idx: usize, gene_idx: usize, clip: bool) -> PyResult<f32> {
    if !value.is_finite() {
        return Err(ControllerError::new_err(format!(
            "genomes[{row_idx}, {gene_idx}] (row {row_idx} of the batch, gene {gene_idx}) is \
             {value:?}: genes must be finite, with clip=True too"
        )));
    }
    let value = if clip {
        value.clamp(f64::from(GENE_MIN), f64::from(GENE_MAX))
    } else {
        value
    };
    // `as` rounds to the nearest f32, ties to even (a finite f64 beyond f32's range becomes
    // infinite, and is refused below as out of range).
    let rounded = value as f32;
    if !(GENE_MIN..=GENE_MAX).contains(&rounded) {
        // Debug: the shortest text that reads back, and 1e300 rather than 301 digits.
        let shown = if rounded.is_finite() {
            format!("{rounded:?}")
        } else {
            format!("{value:?}")
        };
        return Err(ControllerError::new_err(format!(
            "genomes[{row_idx}, {gene_idx}] (row {row_idx} of the batch, gene {gene_idx}) is \
             {shown}, outside the gene range [{GENE_MIN}, {GENE_MAX}]; pass clip=True to clip \
             genes to the range"
        )));
    }
    Ok(rounded)
}

fn rows_of<T: Copy + Into<f64>>(array: ArrayView2<'_, T>, clip: bool) -> PyResult<Vec<Arc<[f32]>>> {
    array
        .rows()
        .into_iter()
        .enumerate()
        .map(|(row_idx, row)| {
            row.iter()
                .enumerate()
                .map(|(gene_idx, &value)| gene(value.into(), row_idx, gene_idx, clip))
                .collect::<PyResult<Vec<f32>>>()
                .map(Into::into)
        })
        .collect()
}

/// A 2-D float array's values, as they are stored.
enum Floats<'py> {
    Single(PyReadonlyArray2<'py, f32>),
    Double(PyReadonlyArray2<'py, f64>),
}

/// `value` (a numpy array, or anything `numpy.asarray` makes a float array of) as a float
/// array, its shape checked by `check_shape`; `name` names it in errors. TypeError for a dtype
/// that is not a float.
pub(crate) fn float_array<'py>(
    value: &Bound<'py, PyAny>,
    name: &str,
    check_shape: impl FnOnce(&[usize]) -> PyResult<()>,
) -> PyResult<Bound<'py, PyAny>> {
    let array = value
        .py()
        .import("numpy")?
        .getattr("asarray")?
        .call1((value,))?;
    let untyped = array.cast::<PyUntypedArray>()?;
    let dtype = untyped.dtype();
    if dtype.kind() != b'f' {
        return Err(PyTypeError::new_err(format!(
            "{name} must be a float array (float64, float32, ...), got dtype {}; convert it \
             with .astype(numpy.float64)",
            dtype.str()?
        )));
    }
    check_shape(untyped.shape())?;
    Ok(array)
}

/// A 2-D float array's values: float32 as they are, float64 as they are, other float dtypes
/// (float16 exactly, longdouble rounded) as float64.
fn floats_2d(array: Bound<'_, PyAny>) -> PyResult<Floats<'_>> {
    if let Ok(single) = array.extract::<PyReadonlyArray2<'_, f32>>() {
        return Ok(Floats::Single(single));
    }
    if let Ok(double) = array.extract::<PyReadonlyArray2<'_, f64>>() {
        return Ok(Floats::Double(double));
    }
    Ok(Floats::Double(
        array
            .call_method1("astype", ("float64",))?
            .extract::<PyReadonlyArray2<'_, f64>>()?,
    ))
}

/// The rows of `genomes` (a numpy array, or anything `numpy.asarray` makes a float array of)
/// as float32 genomes of `n_genes` genes for the free node `free_path`. TypeError for a
/// dtype that is not a float, ValueError for a shape that does not fit, ControllerError for
/// a gene that cannot be evaluated.
pub(crate) fn genome_rows(
    genomes: &Bound<'_, PyAny>,
    n_genes: usize,
    free_path: &str,
    clip: bool,
) -> PyResult<Vec<Arc<[f32]>>> {
    let array = float_array(genomes, "genomes", |shape| {
        if shape.len() != 2 {
            return Err(PyValueError::new_err(format!(
                "genomes must be 2-D, one genome per row, shape (n, {n_genes}); got shape \
                 {shape:?} (one genome: genomes[None, :])"
            )));
        }
        if shape[1] != n_genes {
            return Err(PyValueError::new_err(format!(
                "genomes has {} column(s), but the free node '{free_path}' takes {n_genes} genes",
                shape[1]
            )));
        }
        Ok(())
    })?;
    match floats_2d(array)? {
        Floats::Single(single) => rows_of(single.as_array(), clip),
        Floats::Double(double) => rows_of(double.as_array(), clip),
    }
}

/// One genome (a 1-D array of any float dtype) as float32 genes, rounded to the nearest as
/// [`genome_rows`] rounds; its range is the controller file's check, which names the node.
pub(crate) fn genes_of(genes: &Bound<'_, PyAny>) -> PyResult<Vec<f32>> {
    let array = float_array(genes, "genes", |shape| {
        if shape.len() == 1 {
            Ok(())
        } else {
            Err(PyValueError::new_err(format!(
                "genes must be 1-D, one genome; got shape {shape:?}"
            )))
        }
    })?;
    let row = array.call_method1("reshape", (1, -1))?;
    Ok(match floats_2d(row)? {
        Floats::Single(single) => single.as_array().iter().copied().collect(),
        // Rounds to the nearest f32, ties to even, as `gene` does.
        Floats::Double(double) => double.as_array().iter().map(|&v| v as f32).collect(),
    })
}
