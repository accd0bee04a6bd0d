//! Model cost: parameters and multiply-accumulates from the ONNX graph, latency at 256 x 256 px.
//!
//! - **Parameters**: elements of the graph's float initializers.
//! - **MACs** at 1 x 3 x 256 x 256 (the thop / ptflops convention the CAC papers' "FLOPs" columns use):
//!   Conv `prod(output) x Cin/groups x kh x kw`, ConvTranspose `prod(input) x Cout/groups x kh x kw`,
//!   MatMul and Gemm `prod(output) x K`; element-wise and normalisation ops are not counted. The shapes
//!   are the real ones: every such node's operands are added as extra graph outputs, the model is run
//!   once through onnxruntime at 256 x 256, and the shapes are read back (no shape inference of our own,
//!   so any graph onnxruntime runs is measured). `flops_g` = 2 x MACs / 1e9.
//! - **Latency**: median of 5 runs at 1 x 3 x 256 x 256 after one warm-up, with the bench's threads.

use std::collections::{BTreeMap, BTreeSet};
use std::time::Instant;

use prost::Message;
use serde::Serialize;

use crate::contract::{ModelContract, ModelInput};
use crate::error::Result;
use crate::proto::{data_type, type_proto, ModelProto, TypeProto, ValueInfoProto};
use crate::runtime::{Runtime, Tensor};

/// The side of the latency and MAC measurements (px).
pub const COST_SIDE_PX: usize = 256;
const LATENCY_RUNS: usize = 5;

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ModelCost {
    pub params: u64,
    pub macs_g: f64,
    pub flops_g: f64,
    pub latency_ms: f64,
}

/// Zero inputs of 1 x C x side x side for each declared input.
fn inputs(contract: &ModelContract, side: usize) -> Vec<(&'static str, Tensor)> {
    contract
        .inputs
        .iter()
        .map(|i: &ModelInput| {
            let c = i.channels();
            (
                i.name(),
                Tensor {
                    shape: vec![1, c, side, side],
                    data: vec![0.25; c * side * side],
                },
            )
        })
        .collect()
}

fn untyped_output(name: &str) -> ValueInfoProto {
    ValueInfoProto {
        name: name.to_string(),
        r#type: Some(TypeProto {
            value: Some(type_proto::Value::TensorType(type_proto::Tensor {
                elem_type: data_type::FLOAT,
                shape: None,
            })),
            denotation: String::new(),
        }),
        ..Default::default()
    }
}

/// Parameters of the graph.
pub fn parameter_count(model: &ModelProto) -> u64 {
    let graph = model.graph.as_ref().expect("checked model");
    graph
        .initializer
        .iter()
        .filter(|t| t.data_type == data_type::FLOAT || t.data_type == 10 || t.data_type == 16)
        .map(|t| t.dims.iter().product::<i64>().max(0) as u64)
        .sum()
}

/// Parameters, MACs and latency of a contract-checked model.
pub fn measure(
    runtime: &Runtime,
    contract: &ModelContract,
    model: &ModelProto,
    threads: usize,
) -> Result<ModelCost> {
    let graph = model.graph.as_ref().expect("checked model");
    let initializer_shapes: BTreeMap<&str, Vec<usize>> = graph
        .initializer
        .iter()
        .map(|t| (t.name.as_str(), t.dims.iter().map(|&d| d as usize).collect()))
        .collect();
    let counted = ["Conv", "ConvTranspose", "MatMul", "Gemm"];
    let mut probe = model.clone();
    let existing: BTreeSet<String> = graph
        .output
        .iter()
        .chain(&graph.input)
        .map(|v| v.name.clone())
        .collect();
    let mut wanted: BTreeSet<String> = BTreeSet::new();
    for node in graph
        .node
        .iter()
        .filter(|n| counted.contains(&n.op_type.as_str()))
    {
        for name in node.input.iter().take(2).chain(node.output.iter().take(1)) {
            if !name.is_empty() && !initializer_shapes.contains_key(name.as_str()) && !existing.contains(name)
            {
                wanted.insert(name.clone());
            }
        }
    }
    let probe_graph = probe.graph.as_mut().expect("checked model");
    for name in &wanted {
        probe_graph.output.push(untyped_output(name));
    }
    let mut session = runtime.session(&probe.encode_to_vec(), threads, "the cost probe")?;
    let names: Vec<&str> = wanted.iter().map(String::as_str).collect();
    let mut all_names = vec!["restored"];
    all_names.extend(&names);
    let outputs = session.run(inputs(contract, COST_SIDE_PX), &all_names)?;
    let mut shapes: BTreeMap<&str, Vec<usize>> = initializer_shapes.clone();
    for (name, tensor) in all_names.iter().zip(&outputs) {
        shapes.insert(name, tensor.shape.clone());
    }
    for input in &contract.inputs {
        shapes.insert(
            input.name(),
            vec![1, input.channels(), COST_SIDE_PX, COST_SIDE_PX],
        );
    }
    let product = |s: &[usize]| s.iter().product::<usize>() as f64;
    let mut macs = 0.0;
    for node in graph
        .node
        .iter()
        .filter(|n| counted.contains(&n.op_type.as_str()))
    {
        let shape = |i: usize, from_output: bool| -> Option<&Vec<usize>> {
            let name = if from_output {
                node.output.first()
            } else {
                node.input.get(i)
            }?;
            shapes.get(name.as_str())
        };
        let (Some(a), Some(b), Some(out)) = (shape(0, false), shape(1, false), shape(0, true)) else {
            continue;
        };
        macs += match node.op_type.as_str() {
            "Conv" => product(out) * product(&b[1..]),
            "ConvTranspose" => product(a) * product(&b[1..]),
            "MatMul" => product(out) * *a.last().unwrap_or(&1) as f64,
            _ => {
                let trans_a = node.attribute.iter().any(|at| at.name == "transA" && at.i != 0);
                let k = if trans_a { a.first() } else { a.last() };
                product(out) * *k.unwrap_or(&1) as f64
            }
        };
    }
    drop(session);
    // Latency on the model itself (the probe's extra outputs would slow it).
    let mut session = runtime.session(&model.encode_to_vec(), threads, "the latency probe")?;
    session.run(inputs(contract, COST_SIDE_PX), &["restored"])?;
    let mut times: Vec<f64> = (0..LATENCY_RUNS)
        .map(|_| {
            let start = Instant::now();
            session
                .run(inputs(contract, COST_SIDE_PX), &["restored"])
                .map(|_| start.elapsed().as_secs_f64() * 1e3)
        })
        .collect::<Result<_>>()?;
    times.sort_by(f64::total_cmp);
    Ok(ModelCost {
        params: parameter_count(model),
        macs_g: macs / 1e9,
        flops_g: 2.0 * macs / 1e9,
        latency_ms: times[LATENCY_RUNS / 2],
    })
}
