//! Network building blocks of `skillmimic_nn` exposed for cross-checks against PyTorch: a
//! transformer encoder layer evaluated from a `state_dict` of `torch.nn.TransformerEncoderLayer`.

use numpy::{
    PyArray1, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use skillmimic_nn::attention::{Dense, MultiHeadAttention, TransformerEncoderLayer};

fn tensor(sd: &Bound<'_, PyDict>, name: &str, len: usize) -> PyResult<Vec<f32>> {
    let item = sd
        .get_item(name)?
        .ok_or_else(|| PyValueError::new_err(format!("state_dict: missing '{name}'")))?;
    let arr: PyReadonlyArray1<'_, f32> = item.extract().map_err(|_| {
        PyValueError::new_err(format!("state_dict['{name}']: expected a flat float32 array"))
    })?;
    let v = arr.as_slice().map_err(|e| PyValueError::new_err(e.to_string()))?.to_vec();
    if v.len() != len {
        return Err(PyValueError::new_err(format!(
            "state_dict['{name}']: {} values, expected {len}",
            v.len()
        )));
    }
    Ok(v)
}

/// Output `(B, S, E)` of a post-norm transformer encoder layer (ReLU, batch-first, no dropout)
/// whose parameters are the flattened float32 arrays of `state_dict` (PyTorch names), on `x`
/// `(B, S, E)` with an optional key padding mask `(B, S)` (True = ignore).
#[pyfunction]
#[pyo3(signature = (state_dict, x, num_heads, key_padding_mask = None))]
pub fn transformer_encoder_layer<'py>(
    py: Python<'py>,
    state_dict: &Bound<'py, PyDict>,
    x: PyReadonlyArray3<'_, f32>,
    num_heads: usize,
    key_padding_mask: Option<PyReadonlyArray2<'_, bool>>,
) -> PyResult<Bound<'py, PyArray1<f32>>> {
    let (b, s, e) = (x.shape()[0], x.shape()[1], x.shape()[2]);
    if num_heads == 0 || !e.is_multiple_of(num_heads) {
        return Err(PyValueError::new_err(format!(
            "num_heads {num_heads} must divide the width {e}"
        )));
    }
    let f = state_dict
        .get_item("linear1.bias")?
        .ok_or_else(|| PyValueError::new_err("state_dict: missing 'linear1.bias'"))?
        .len()?;
    let dense = |name: &str, out: usize, inp: usize| -> PyResult<Dense> {
        Ok(Dense {
            out,
            inp,
            weight: tensor(state_dict, &format!("{name}.weight"), out * inp)?,
            bias: tensor(state_dict, &format!("{name}.bias"), out)?,
        })
    };
    let layer = TransformerEncoderLayer {
        self_attn: MultiHeadAttention {
            embed_dim: e,
            num_heads,
            in_proj: Dense {
                out: 3 * e,
                inp: e,
                weight: tensor(state_dict, "self_attn.in_proj_weight", 3 * e * e)?,
                bias: tensor(state_dict, "self_attn.in_proj_bias", 3 * e)?,
            },
            out_proj: dense("self_attn.out_proj", e, e)?,
        },
        linear1: dense("linear1", f, e)?,
        linear2: dense("linear2", e, f)?,
        norm1: (tensor(state_dict, "norm1.weight", e)?, tensor(state_dict, "norm1.bias", e)?),
        norm2: (tensor(state_dict, "norm2.weight", e)?, tensor(state_dict, "norm2.bias", e)?),
    };
    let dev = candle_core::Device::Cpu;
    let err = |e: candle_core::Error| PyValueError::new_err(format!("candle: {e}"));
    let xt = candle_core::Tensor::from_slice(
        x.as_slice().map_err(|e| PyValueError::new_err(e.to_string()))?,
        (b, s, e),
        &dev,
    )
    .map_err(err)?;
    let mask = match key_padding_mask {
        None => None,
        Some(m) => {
            if m.shape() != [b, s] {
                return Err(PyValueError::new_err(format!(
                    "key_padding_mask: expected shape [{b}, {s}], got {:?}",
                    m.shape()
                )));
            }
            let v: Vec<u8> = m
                .as_slice()
                .map_err(|e| PyValueError::new_err(e.to_string()))?
                .iter()
                .map(|&x| u8::from(x))
                .collect();
            Some(candle_core::Tensor::from_vec(v, (b, s), &dev).map_err(err)?)
        }
    };
    let y: Vec<f32> = layer
        .forward_masked(&xt, mask.as_ref())
        .and_then(|t| t.flatten_all()?.to_vec1())
        .map_err(err)?;
    Ok(PyArray1::from_vec(py, y))
}
