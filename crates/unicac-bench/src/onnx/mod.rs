//! ONNX files without an ONNX library: the protobuf messages ([`proto`]) and a small graph builder
//! ([`builder`]) for the LPIPS network and test models.

pub mod builder;
pub mod proto;
