//! A policy chain ([`foosball_algos::policy_chain`]) written as an ONNX model (opset
//! [`OPSET`]): input `observation` `[batch, obs_dim]` f32, output `action`
//! `[batch, action_dim]` f32, the batch a named dimension.
//!
//! Each step becomes the standard operators that compute it as the agent does:
//! - hidden values: `Mul` by a mask of ones and zeros (the value set to 0);
//! - [`Step::Standardize`]: `Cast` to double, `Sub` the mean, `Div` by the scale, `Cast`
//!   to float, `Clip`: the f64 arithmetic of `Normalized`, so the same bits;
//! - [`Step::Fourier`]: `Gather` the encoded values, `Unsqueeze`, `Mul` by the frequencies
//!   (`[K]`), `Sin` and `Cos`, interleaved by `Unsqueeze` + `Concat` + `Reshape`, `Concat`
//!   after the raw values, and one `Gather` that puts every block in the observation's
//!   order;
//! - [`Step::Mlp`]: per layer `MatMul` + `Add`, `Relu` or `Tanh` after hidden layers;
//! - [`Step::First`]: `Slice` on axis 1; [`Step::Tanh`]: `Tanh`; [`Step::Clamp`]: `Clip`;
//!   an `Identity` names the result `action`.

use foosball_algos::Step;
use foosball_nets::Activation;
use prost::Message;
use tract_onnx::pb;
use tract_onnx::pb::tensor_proto::DataType;

/// The ONNX operator set the graph is written for (ONNX 1.12, 2022: onnxruntime and tract
/// read it).
pub const OPSET: i64 = 17;
/// The IR version of opset 17.
const IR_VERSION: i64 = 8;
/// The name of the graph's input.
pub const INPUT: &str = "observation";
/// The name of the graph's output.
pub const OUTPUT: &str = "action";

/// The policy `chain` behind the zeroing of the observation values at `hidden`, as an
/// ONNX model's bytes, with `metadata` (key, value) pairs and `doc` as its description;
/// an error names a step whose widths do not follow.
pub fn policy_model(
    obs_dim: usize,
    hidden: &[usize],
    chain: &[Step],
    metadata: &[(&str, String)],
    doc: &str,
) -> Result<Vec<u8>, String> {
    let mut g = Builder::default();
    let mut x = INPUT.to_string();
    let mut width = obs_dim;
    if let Some(&bad) = hidden.iter().find(|&&i| i >= obs_dim) {
        return Err(format!(
            "hidden value {bad} of a {obs_dim}-wide observation"
        ));
    }
    if !hidden.is_empty() {
        let mask: Vec<f32> = (0..obs_dim)
            .map(|i| if hidden.contains(&i) { 0.0 } else { 1.0 })
            .collect();
        let mask = g.floats("hidden_mask", &[obs_dim], mask);
        x = g.node("Mul", &[&x, &mask], vec![]);
    }
    for (k, step) in chain.iter().enumerate() {
        x = g
            .step(step, &x, width)
            .map_err(|why| format!("step {k} ({}): {why}", step_name(step)))?;
        width = step.width_out(width);
    }
    g.nodes.push(pb::NodeProto {
        input: vec![x],
        output: vec![OUTPUT.to_string()],
        name: OUTPUT.to_string(),
        op_type: "Identity".into(),
        ..Default::default()
    });
    let value = |name: &str, width: usize| pb::ValueInfoProto {
        name: name.into(),
        r#type: Some(pb::TypeProto {
            value: Some(pb::type_proto::Value::TensorType(pb::type_proto::Tensor {
                elem_type: DataType::Float as i32,
                shape: Some(pb::TensorShapeProto {
                    dim: vec![dim_param("batch"), dim_value(width)],
                }),
            })),
            ..Default::default()
        }),
        ..Default::default()
    };
    let model = pb::ModelProto {
        ir_version: IR_VERSION,
        opset_import: vec![pb::OperatorSetIdProto {
            domain: String::new(),
            version: OPSET,
        }],
        producer_name: "foosball-rl".into(),
        producer_version: env!("CARGO_PKG_VERSION").into(),
        doc_string: doc.into(),
        graph: Some(pb::GraphProto {
            name: "policy".into(),
            node: g.nodes,
            initializer: g.initializers,
            input: vec![value(INPUT, obs_dim)],
            output: vec![value(OUTPUT, width)],
            ..Default::default()
        }),
        metadata_props: metadata
            .iter()
            .map(|(key, value)| pb::StringStringEntryProto {
                key: (*key).into(),
                value: value.clone(),
            })
            .collect(),
        ..Default::default()
    };
    Ok(model.encode_to_vec())
}

fn step_name(step: &Step) -> &'static str {
    match step {
        Step::Standardize { .. } => "standardize",
        Step::Fourier { .. } => "fourier",
        Step::Mlp(_) => "mlp",
        Step::First(_) => "first",
        Step::Tanh => "tanh",
        Step::Clamp { .. } => "clamp",
    }
}

fn dim_param(name: &str) -> pb::tensor_shape_proto::Dimension {
    pb::tensor_shape_proto::Dimension {
        value: Some(pb::tensor_shape_proto::dimension::Value::DimParam(
            name.into(),
        )),
        ..Default::default()
    }
}

fn dim_value(n: usize) -> pb::tensor_shape_proto::Dimension {
    pb::tensor_shape_proto::Dimension {
        value: Some(pb::tensor_shape_proto::dimension::Value::DimValue(n as i64)),
        ..Default::default()
    }
}

/// The nodes and constants written so far; every value gets a fresh name.
#[derive(Default)]
struct Builder {
    nodes: Vec<pb::NodeProto>,
    initializers: Vec<pb::TensorProto>,
    names: usize,
}

impl Builder {
    fn fresh(&mut self, stem: &str) -> String {
        self.names += 1;
        format!("{stem}_{}", self.names)
    }

    /// A node of `op` on `inputs` with `attributes`; its one output's name.
    fn node(&mut self, op: &str, inputs: &[&str], attribute: Vec<pb::AttributeProto>) -> String {
        let output = self.fresh(&op.to_lowercase());
        self.nodes.push(pb::NodeProto {
            input: inputs.iter().map(|s| s.to_string()).collect(),
            output: vec![output.clone()],
            name: output.clone(),
            op_type: op.into(),
            attribute,
            ..Default::default()
        });
        output
    }

    fn constant(
        &mut self,
        stem: &str,
        dims: &[usize],
        fill: impl FnOnce(&mut pb::TensorProto),
    ) -> String {
        let name = self.fresh(stem);
        let mut t = pb::TensorProto {
            name: name.clone(),
            dims: dims.iter().map(|&d| d as i64).collect(),
            ..Default::default()
        };
        fill(&mut t);
        self.initializers.push(t);
        name
    }

    fn floats(&mut self, stem: &str, dims: &[usize], values: Vec<f32>) -> String {
        self.constant(stem, dims, |t| {
            t.data_type = DataType::Float as i32;
            t.float_data = values;
        })
    }

    fn doubles(&mut self, stem: &str, values: Vec<f64>) -> String {
        self.constant(stem, &[values.len()], |t| {
            t.data_type = DataType::Double as i32;
            t.double_data = values;
        })
    }

    fn ints(&mut self, stem: &str, values: Vec<i64>) -> String {
        self.constant(stem, &[values.len()], |t| {
            t.data_type = DataType::Int64 as i32;
            t.int64_data = values;
        })
    }

    fn cast(&mut self, x: &str, to: DataType) -> String {
        self.node("Cast", &[x], vec![int_attribute("to", to as i64)])
    }

    fn clip(&mut self, x: &str, min: f32, max: f32) -> String {
        let min = self.floats("min", &[], vec![min]);
        let max = self.floats("max", &[], vec![max]);
        self.node("Clip", &[x, &min, &max], vec![])
    }

    fn unsqueeze(&mut self, x: &str, axis: i64) -> String {
        let axes = self.ints("axes", vec![axis]);
        self.node("Unsqueeze", &[x, &axes], vec![])
    }

    /// `step` on `x` (`[batch, width]`); its output's name.
    fn step(&mut self, step: &Step, x: &str, width: usize) -> Result<String, String> {
        Ok(match step {
            Step::Standardize { mean, scale, clip } => {
                if mean.len() != width || scale.len() != width {
                    return Err(format!(
                        "{} means and {} scales for {width} values",
                        mean.len(),
                        scale.len()
                    ));
                }
                let wide = self.cast(x, DataType::Double);
                let mean = self.doubles("mean", mean.clone());
                let scale = self.doubles("scale", scale.clone());
                let centred = self.node("Sub", &[&wide, &mean], vec![]);
                let z = self.node("Div", &[&centred, &scale], vec![]);
                let z = self.cast(&z, DataType::Float);
                self.clip(&z, -clip, *clip)
            }
            Step::Fourier {
                encoded,
                frequencies,
            } => self.fourier(x, width, encoded, frequencies)?,
            Step::Mlp(mlp) => {
                if mlp.input_dim() != width {
                    return Err(format!(
                        "it reads {} values, given {width}",
                        mlp.input_dim()
                    ));
                }
                let widths = mlp.widths();
                let mut y = x.to_string();
                for l in 0..widths.len() - 1 {
                    let (w, b) = mlp.layer(l);
                    let w = self.floats("weight", &[widths[l], widths[l + 1]], w.to_vec());
                    let b = self.floats("bias", &[widths[l + 1]], b.to_vec());
                    let z = self.node("MatMul", &[&y, &w], vec![]);
                    y = self.node("Add", &[&z, &b], vec![]);
                    if l + 2 < widths.len() {
                        let op = match mlp.activation() {
                            Activation::Relu => "Relu",
                            Activation::Tanh => "Tanh",
                        };
                        y = self.node(op, &[&y], vec![]);
                    }
                }
                y
            }
            Step::First(n) => {
                if *n > width {
                    return Err(format!("the first {n} of {width} values"));
                }
                let starts = self.ints("starts", vec![0]);
                let ends = self.ints("ends", vec![*n as i64]);
                let axes = self.ints("axes", vec![1]);
                self.node("Slice", &[x, &starts, &ends, &axes], vec![])
            }
            Step::Tanh => self.node("Tanh", &[x], vec![]),
            Step::Clamp { min, max } => self.clip(x, *min, *max),
        })
    }

    /// [`Step::Fourier`] on `x` (`[batch, width]`, module docs).
    fn fourier(
        &mut self,
        x: &str,
        width: usize,
        encoded: &[bool],
        frequencies: &[f32],
    ) -> Result<String, String> {
        if encoded.len() != width {
            return Err(format!("{} flags for {width} values", encoded.len()));
        }
        let picked: Vec<i64> = (0..width as i64).filter(|&j| encoded[j as usize]).collect();
        let pair = 2 * frequencies.len();
        if picked.is_empty() || pair == 0 {
            return Ok(x.to_string());
        }
        // [batch, E] -> [batch, E, K] angles -> [batch, E, K, 2] (sin, cos) -> [batch, E 2K].
        let columns = self.ints("encoded", picked);
        let values = self.node("Gather", &[x, &columns], vec![int_attribute("axis", 1)]);
        let values = self.unsqueeze(&values, 2);
        let f = self.floats("frequencies", &[frequencies.len()], frequencies.to_vec());
        let angles = self.node("Mul", &[&values, &f], vec![]);
        let sin = self.node("Sin", &[&angles], vec![]);
        let cos = self.node("Cos", &[&angles], vec![]);
        let sin = self.unsqueeze(&sin, 3);
        let cos = self.unsqueeze(&cos, 3);
        let pairs = self.node("Concat", &[&sin, &cos], vec![int_attribute("axis", 3)]);
        let shape = self.ints("shape", vec![0, -1]);
        let features = self.node("Reshape", &[&pairs, &shape], vec![]);
        let all = self.node("Concat", &[x, &features], vec![int_attribute("axis", 1)]);
        // Value j, then its block's 2K features where encoded, in the observation's order.
        let mut order = Vec::new();
        let mut e = 0;
        for (j, &enc) in encoded.iter().enumerate() {
            order.push(j as i64);
            if enc {
                let start = width + e * pair;
                order.extend((start..start + pair).map(|c| c as i64));
                e += 1;
            }
        }
        let order = self.ints("order", order);
        Ok(self.node("Gather", &[&all, &order], vec![int_attribute("axis", 1)]))
    }
}

fn int_attribute(name: &str, i: i64) -> pb::AttributeProto {
    pb::AttributeProto {
        name: name.into(),
        r#type: pb::attribute_proto::AttributeType::Int as i32,
        i,
        ..Default::default()
    }
}
