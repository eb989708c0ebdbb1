//! A small builder of ONNX graphs over the `onnx-protobuf` messages: float32 / int64 constant
//! initialisers, nodes with integer and float attributes, graph inputs and outputs whose first
//! dimension is the symbolic `batch`.
//!
//! The building blocks of the policy graphs live here too ([`Graph::normalizer`], [`Graph::mlp`]),
//! so the plain and the fused exports build their sub-graphs with one code path.

use onnx_protobuf::tensor_proto::DataType;
use onnx_protobuf::tensor_shape_proto::{Dimension, dimension};
use onnx_protobuf::type_proto::{Tensor, Value};
use onnx_protobuf::{
    AttributeProto, GraphProto, ModelProto, NodeProto, OperatorSetIdProto, StringStringEntryProto,
    TensorProto, TensorShapeProto, TypeProto, ValueInfoProto, attribute_proto::AttributeType,
};
use skillmimic_nn::mlp::Mlp;
use skillmimic_nn::normalizer::RunningMeanStd;

/// The ONNX operator set the graphs are written for (Gemm, Relu, Sub, Mul, Clip with input
/// bounds, ArgMax, Gather, Slice, Concat, Unsqueeze and Reshape with input shapes, Transpose,
/// MatMul, Softmax over one axis: unchanged since opset 13; ReduceL2 with the `axes` attribute:
/// opset ≤ 17).
pub const OPSET: i64 = 17;
/// ONNX IR version that goes with [`OPSET`] (IR 8 = ONNX 1.12–1.13, opset 17).
pub const IR_VERSION: i64 = 8;
/// Name of the symbolic batch dimension of every input and output.
pub const BATCH: &str = "batch";

/// Element types used by the graphs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Elem {
    F32,
    I64,
}

impl Elem {
    fn code(self) -> i32 {
        match self {
            Elem::F32 => DataType::FLOAT as i32,
            Elem::I64 => DataType::INT64 as i32,
        }
    }
}

/// An ONNX graph under construction.
#[derive(Default)]
pub struct Graph {
    g: GraphProto,
    counter: usize,
}

fn attr_int(name: &str, v: i64) -> AttributeProto {
    let mut a = AttributeProto::new();
    a.name = name.to_string();
    a.type_ = AttributeType::INT.into();
    a.i = v;
    a
}

fn attr_ints(name: &str, v: &[i64]) -> AttributeProto {
    let mut a = AttributeProto::new();
    a.name = name.to_string();
    a.type_ = AttributeType::INTS.into();
    a.ints = v.to_vec();
    a
}

/// A `(batch, width…)` tensor type; `width` empty = a `(batch,)` vector.
fn value_info(name: &str, elem: Elem, width: &[usize], doc: &str) -> ValueInfoProto {
    let mut dims = vec![Dimension {
        value: Some(dimension::Value::DimParam(BATCH.to_string())),
        ..Default::default()
    }];
    dims.extend(width.iter().map(|&w| Dimension {
        value: Some(dimension::Value::DimValue(w as i64)),
        ..Default::default()
    }));
    let shape = TensorShapeProto { dim: dims, ..Default::default() };
    let tensor = Tensor { elem_type: elem.code(), shape: Some(shape).into(), ..Default::default() };
    ValueInfoProto {
        name: name.to_string(),
        type_: Some(TypeProto { value: Some(Value::TensorType(tensor)), ..Default::default() })
            .into(),
        doc_string: doc.to_string(),
        ..Default::default()
    }
}

impl Graph {
    /// An empty graph called `name`.
    pub fn new(name: &str) -> Self {
        let mut g = Self::default();
        g.g.name = name.to_string();
        g
    }

    /// A fresh value name `{stem}_{k}`.
    fn fresh(&mut self, stem: &str) -> String {
        self.counter += 1;
        format!("{stem}_{}", self.counter)
    }

    /// A constant initialiser of element type `elem` from little-endian `raw` bytes.
    fn constant(&mut self, name: &str, dims: &[usize], elem: Elem, raw: Vec<u8>) -> String {
        let t = TensorProto {
            name: name.to_string(),
            dims: dims.iter().map(|&d| d as i64).collect(),
            data_type: elem.code(),
            raw_data: raw,
            ..Default::default()
        };
        self.g.initializer.push(t);
        name.to_string()
    }

    /// A float32 constant of shape `dims` (row-major `data`).
    pub fn const_f32(&mut self, name: &str, dims: &[usize], data: &[f32]) -> String {
        debug_assert_eq!(dims.iter().product::<usize>(), data.len());
        self.constant(name, dims, Elem::F32, data.iter().flat_map(|v| v.to_le_bytes()).collect())
    }

    /// An int64 constant of shape `dims`.
    pub fn const_i64(&mut self, name: &str, dims: &[usize], data: &[i64]) -> String {
        debug_assert_eq!(dims.iter().product::<usize>(), data.len());
        self.constant(name, dims, Elem::I64, data.iter().flat_map(|v| v.to_le_bytes()).collect())
    }

    /// Append a node `op(inputs) -> outputs` with attributes.
    pub fn node(
        &mut self,
        op: &str,
        inputs: &[&str],
        outputs: &[&str],
        attrs: Vec<AttributeProto>,
    ) {
        let n = NodeProto {
            name: format!("{}_{}", op.to_lowercase(), self.g.node.len()),
            op_type: op.to_string(),
            input: inputs.iter().map(|s| s.to_string()).collect(),
            output: outputs.iter().map(|s| s.to_string()).collect(),
            attribute: attrs,
            ..Default::default()
        };
        self.g.node.push(n);
    }

    /// `op(inputs)` into a fresh value (or into `out` when given); returns its name.
    pub fn op(
        &mut self,
        op: &str,
        inputs: &[&str],
        out: Option<&str>,
        attrs: Vec<AttributeProto>,
    ) -> String {
        let name = match out {
            Some(o) => o.to_string(),
            None => self.fresh(&op.to_lowercase()),
        };
        self.node(op, inputs, &[&name], attrs);
        name
    }

    /// Declare a graph input `(batch, width…)`.
    pub fn input(&mut self, name: &str, elem: Elem, width: &[usize], doc: &str) {
        self.g.input.push(value_info(name, elem, width, doc));
    }

    /// Declare a graph output `(batch, width…)`.
    pub fn output(&mut self, name: &str, elem: Elem, width: &[usize], doc: &str) {
        self.g.output.push(value_info(name, elem, width, doc));
    }

    /// `clamp(x, lo, hi)` (Clip with scalar bound inputs) into `out` or a fresh value.
    pub fn clip(&mut self, x: &str, lo: f32, hi: f32, out: Option<&str>) -> String {
        let lo_name = self.fresh("clip_lo");
        let hi_name = self.fresh("clip_hi");
        self.const_f32(&lo_name, &[], &[lo]);
        self.const_f32(&hi_name, &[], &[hi]);
        self.op("Clip", &[x, &lo_name, &hi_name], out, Vec::new())
    }

    /// The observation normaliser folded into float32 constants:
    /// `clamp((x − mean) · (1/√(var + ε)), −clip, clip)`. The mean and the scale are computed in
    /// float64 and rounded once to float32; the graph then works in float32 (the checkpoint's own
    /// inference computes the whole expression in float64 before rounding — the difference is a
    /// few float32 ulps of the normalised value).
    pub fn normalizer(&mut self, prefix: &str, x: &str, norm: &RunningMeanStd) -> String {
        let d = norm.dim();
        let mean: Vec<f32> = norm.mean.iter().map(|&m| m as f32).collect();
        let scale: Vec<f32> =
            norm.var.iter().map(|&v| (1.0 / (v + norm.eps).sqrt()) as f32).collect();
        let mean = self.const_f32(&format!("{prefix}.mean"), &[d], &mean);
        let scale = self.const_f32(&format!("{prefix}.inv_std"), &[d], &scale);
        let centred = self.op("Sub", &[x, &mean], None, Vec::new());
        let scaled = self.op("Mul", &[&centred, &scale], None, Vec::new());
        self.clip(&scaled, -norm.clip as f32, norm.clip as f32, None)
    }

    /// The MLP: `Gemm(x, W, b, transB = 1)` per layer (W stored `(out, in)` as in the
    /// checkpoint), ReLU after every layer but the last; the last layer writes `out`.
    pub fn mlp(&mut self, prefix: &str, x: &str, mlp: &Mlp, out: Option<&str>) -> String {
        let mut h = x.to_string();
        let layers = mlp.num_layers();
        for l in 0..layers {
            let (fan_in, fan_out) = (mlp.dims[l], mlp.dims[l + 1]);
            let w = self.const_f32(
                &format!("{prefix}.{}.weight", 2 * l),
                &[fan_out, fan_in],
                &mlp.weights[l],
            );
            let b = self.const_f32(&format!("{prefix}.{}.bias", 2 * l), &[fan_out], &mlp.biases[l]);
            let last = l + 1 == layers;
            let y = self.op(
                "Gemm",
                &[&h, &w, &b],
                if last { out } else { None },
                vec![attr_int("transB", 1)],
            );
            h = if last { y } else { self.op("Relu", &[&y], None, Vec::new()) };
        }
        h
    }

    /// `argmax(x, axis 1)` as int64 `(batch,)` (first index on ties, as `numpy.argmax`).
    pub fn argmax(&mut self, x: &str, out: Option<&str>) -> String {
        self.op(
            "ArgMax",
            &[x],
            out,
            vec![attr_int("axis", 1), attr_int("keepdims", 0), attr_int("select_last_index", 0)],
        )
    }

    /// Rows of the constant `table` picked by the int64 `index` (Gather, axis 0).
    pub fn gather(&mut self, table: &str, index: &str, out: Option<&str>) -> String {
        self.op("Gather", &[table, index], out, vec![attr_int("axis", 0)])
    }

    /// Columns `start..end` of a `(batch, width)` value.
    pub fn columns(&mut self, x: &str, start: usize, end: usize) -> String {
        let s = self.fresh("slice_start");
        let e = self.fresh("slice_end");
        let a = self.fresh("slice_axis");
        self.const_i64(&s, &[1], &[start as i64]);
        self.const_i64(&e, &[1], &[end as i64]);
        self.const_i64(&a, &[1], &[1]);
        self.op("Slice", &[x, &s, &e, &a], None, Vec::new())
    }

    /// `[a | b]` along axis 1.
    pub fn concat(&mut self, a: &str, b: &str) -> String {
        self.op("Concat", &[a, b], None, vec![attr_int("axis", 1)])
    }

    /// `x` with the int64 `shape` (Reshape; 0 keeps that dimension of `x`).
    pub fn reshape(&mut self, x: &str, shape: &[i64]) -> String {
        let s = self.fresh("shape");
        self.const_i64(&s, &[shape.len()], shape);
        self.op("Reshape", &[x, &s], None, Vec::new())
    }

    /// `x` with its axes permuted (Transpose `perm`).
    pub fn transpose(&mut self, x: &str, perm: &[i64]) -> String {
        self.op("Transpose", &[x], None, vec![attr_ints("perm", perm)])
    }

    /// `x` with a new axis of size 1 at `axis` (Unsqueeze).
    pub fn unsqueeze(&mut self, x: &str, axis: i64) -> String {
        let a = self.fresh("unsqueeze_axis");
        self.const_i64(&a, &[1], &[axis]);
        self.op("Unsqueeze", &[x, &a], None, Vec::new())
    }

    /// Elements of `x` at the int64 `indices` along `axis` (Gather with a constant index list, or a
    /// scalar index when `indices` has one entry and `scalar`).
    pub fn take(&mut self, x: &str, axis: i64, indices: &[i64], scalar: bool) -> String {
        let i = self.fresh("indices");
        let len = [indices.len()];
        self.const_i64(&i, if scalar { &[] } else { &len }, indices);
        self.op("Gather", &[x, &i], None, vec![attr_int("axis", axis)])
    }

    /// Concatenation of `xs` along `axis`.
    pub fn concat_all(&mut self, xs: &[String], axis: i64) -> String {
        let refs: Vec<&str> = xs.iter().map(String::as_str).collect();
        self.op("Concat", &refs, None, vec![attr_int("axis", axis)])
    }

    /// Softmax over the last axis.
    pub fn softmax_last(&mut self, x: &str) -> String {
        self.op("Softmax", &[x], None, vec![attr_int("axis", -1)])
    }

    /// `x / max(‖x‖₂, eps)` over the last axis (`F.normalize`).
    pub fn l2_normalize_last(&mut self, x: &str, eps: f32) -> String {
        let norm = self.op(
            "ReduceL2",
            &[x],
            None,
            vec![attr_ints("axes", &[-1]), attr_int("keepdims", 1)],
        );
        let e = self.fresh("eps");
        self.const_f32(&e, &[], &[eps]);
        let safe = self.op("Max", &[&norm, &e], None, Vec::new());
        self.op("Div", &[x, &safe], None, Vec::new())
    }

    /// `x · c` for a scalar constant `c`.
    pub fn scale(&mut self, x: &str, c: f32) -> String {
        let k = self.fresh("scale");
        self.const_f32(&k, &[], &[c]);
        self.op("Mul", &[x, &k], None, Vec::new())
    }

    /// Identity copy of `x` under the name `out` (a graph output that is also an intermediate).
    pub fn identity(&mut self, x: &str, out: &str) -> String {
        self.op("Identity", &[x], Some(out), Vec::new())
    }

    /// The finished model: opset [`OPSET`], IR [`IR_VERSION`], metadata properties in order.
    pub fn into_model(self, doc: &str, props: &[(String, String)]) -> ModelProto {
        let mut m = ModelProto::new();
        m.ir_version = IR_VERSION;
        m.opset_import = vec![OperatorSetIdProto {
            domain: String::new(),
            version: OPSET,
            ..Default::default()
        }];
        m.producer_name = "skillmimic-rs".to_string();
        m.producer_version = env!("CARGO_PKG_VERSION").to_string();
        m.doc_string = doc.to_string();
        m.graph = Some(self.g).into();
        m.metadata_props = props
            .iter()
            .map(|(k, v)| StringStringEntryProto {
                key: k.clone(),
                value: v.clone(),
                ..Default::default()
            })
            .collect();
        m
    }
}
