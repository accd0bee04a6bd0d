//! A small builder for ONNX graphs: float32 inputs and outputs with symbolic or fixed dimensions,
//! float32 initializers, nodes with int/ints/float attributes. Used to build the LPIPS graph from its
//! converted weights and the tiny models of the tests; opset 17 (the contract's minimum), IR version 8.

use prost::Message;

use crate::proto::{
    attribute_type, data_type, tensor_shape_proto, type_proto, AttributeProto, GraphProto, ModelProto,
    NodeProto, OperatorSetIdProto, StringStringEntryProto, TensorProto, TensorShapeProto, TypeProto,
    ValueInfoProto,
};

/// The opset the builder declares.
pub const OPSET: i64 = 17;
const IR_VERSION: i64 = 8;

/// One dimension of a graph input or output.
#[derive(Debug, Clone)]
pub enum Dim {
    Fixed(i64),
    Named(&'static str),
}

/// A node attribute.
#[derive(Debug, Clone)]
pub enum Attr {
    Int(i64),
    Ints(Vec<i64>),
    Float(f32),
}

/// A graph under construction.
#[derive(Debug, Default)]
pub struct GraphBuilder {
    graph: GraphProto,
    metadata: Vec<StringStringEntryProto>,
}

/// A float32 tensor type with the given dimensions.
pub fn float_type(dims: &[Dim]) -> TypeProto {
    let dim = dims
        .iter()
        .map(|d| tensor_shape_proto::Dimension {
            value: Some(match d {
                Dim::Fixed(v) => tensor_shape_proto::dimension::Value::DimValue(*v),
                Dim::Named(n) => tensor_shape_proto::dimension::Value::DimParam((*n).to_string()),
            }),
            denotation: String::new(),
        })
        .collect();
    TypeProto {
        value: Some(type_proto::Value::TensorType(type_proto::Tensor {
            elem_type: data_type::FLOAT,
            shape: Some(TensorShapeProto { dim }),
        })),
        denotation: String::new(),
    }
}

/// N x C x H x W with symbolic N, H, W.
pub fn image_dims(channels: i64) -> Vec<Dim> {
    vec![
        Dim::Named("N"),
        Dim::Fixed(channels),
        Dim::Named("H"),
        Dim::Named("W"),
    ]
}

fn value_info(name: &str, dims: &[Dim]) -> ValueInfoProto {
    ValueInfoProto {
        name: name.to_string(),
        r#type: Some(float_type(dims)),
        ..Default::default()
    }
}

/// A float32 initializer tensor.
pub fn float_tensor(name: &str, dims: &[i64], data: &[f32]) -> TensorProto {
    TensorProto {
        dims: dims.to_vec(),
        data_type: data_type::FLOAT,
        name: name.to_string(),
        raw_data: data.iter().flat_map(|v| v.to_le_bytes()).collect(),
        ..Default::default()
    }
}

/// An int64 initializer tensor (shapes, axes).
pub fn int64_tensor(name: &str, dims: &[i64], data: &[i64]) -> TensorProto {
    TensorProto {
        dims: dims.to_vec(),
        data_type: data_type::INT64,
        name: name.to_string(),
        raw_data: data.iter().flat_map(|v| v.to_le_bytes()).collect(),
        ..Default::default()
    }
}

impl GraphBuilder {
    pub fn new(name: &str) -> GraphBuilder {
        GraphBuilder {
            graph: GraphProto {
                name: name.to_string(),
                ..Default::default()
            },
            metadata: Vec::new(),
        }
    }

    pub fn input(&mut self, name: &str, dims: &[Dim]) -> &mut Self {
        self.graph.input.push(value_info(name, dims));
        self
    }

    pub fn output(&mut self, name: &str, dims: &[Dim]) -> &mut Self {
        self.graph.output.push(value_info(name, dims));
        self
    }

    pub fn initializer(&mut self, tensor: TensorProto) -> &mut Self {
        self.graph.initializer.push(tensor);
        self
    }

    pub fn node(
        &mut self,
        op_type: &str,
        inputs: &[&str],
        outputs: &[&str],
        attrs: &[(&str, Attr)],
    ) -> &mut Self {
        let attribute = attrs
            .iter()
            .map(|(name, value)| {
                let mut a = AttributeProto {
                    name: (*name).to_string(),
                    ..Default::default()
                };
                match value {
                    Attr::Int(v) => {
                        a.r#type = attribute_type::INT;
                        a.i = *v;
                    }
                    Attr::Ints(v) => {
                        a.r#type = attribute_type::INTS;
                        a.ints = v.clone();
                    }
                    Attr::Float(v) => {
                        a.r#type = attribute_type::FLOAT;
                        a.f = *v;
                    }
                }
                a
            })
            .collect();
        let index = self.graph.node.len();
        self.graph.node.push(NodeProto {
            input: inputs.iter().map(|s| s.to_string()).collect(),
            output: outputs.iter().map(|s| s.to_string()).collect(),
            name: format!("{op_type}_{index}"),
            op_type: op_type.to_string(),
            attribute,
            ..Default::default()
        });
        self
    }

    pub fn metadata(&mut self, key: &str, value: &str) -> &mut Self {
        self.metadata.push(StringStringEntryProto {
            key: key.to_string(),
            value: value.to_string(),
        });
        self
    }

    pub fn build(&self) -> ModelProto {
        ModelProto {
            ir_version: IR_VERSION,
            opset_import: vec![OperatorSetIdProto {
                domain: String::new(),
                version: OPSET,
            }],
            producer_name: "unicac".to_string(),
            producer_version: env!("CARGO_PKG_VERSION").to_string(),
            graph: Some(self.graph.clone()),
            metadata_props: self.metadata.clone(),
            ..Default::default()
        }
    }

    /// The serialised model.
    pub fn to_bytes(&self) -> Vec<u8> {
        self.build().encode_to_vec()
    }
}
