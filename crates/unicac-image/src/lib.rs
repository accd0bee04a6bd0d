//! # unicac-image
//!
//! Images for the unicac pipeline: the planar f32 buffer every stage shares (`buffer`).

pub mod buffer;

pub use buffer::Planar;
