//! `unicac mtf`: slanted-edge MTF (ISO 12233) of an image holding one slanted edge.

use super::print_json;
use crate::args::MtfArgs;
use anyhow::{bail, Result};
use serde::Serialize;
use std::collections::BTreeMap;
use unicac_image::io::read_image;
use unicac_metrics::{slanted_edge_mtf, Roi, SlantedEdgeOptions};

#[derive(Serialize)]
struct ChannelMtf {
    frequency_cy_per_px: Vec<f64>,
    mtf: Vec<f64>,
    mtf50_cy_per_px: f64,
    mtf_area: f64,
}

pub fn run(args: &MtfArgs) -> Result<()> {
    let path = std::path::Path::new(&args.input);
    let loaded = read_image(path)?;
    let image = if args.linear {
        loaded.image.clone()
    } else {
        loaded.to_linear()
    };
    if image.width < 8 || image.height < 8 {
        bail!(
            "{}: the image is too small for a slanted-edge measurement",
            path.display()
        );
    }
    let roi = Roi {
        x: 0,
        y: 0,
        width: image.width,
        height: image.height,
    };
    let mut channels = BTreeMap::new();
    for (c, name) in loaded
        .channel_names
        .iter()
        .enumerate()
        .filter(|(_, n)| n.as_str() != "A")
    {
        let edge = slanted_edge_mtf(&image, c, roi, &SlantedEdgeOptions::default())
            .map_err(|e| anyhow::anyhow!("{} channel {name}: {e}", path.display()))?;
        channels.insert(
            name.clone(),
            ChannelMtf {
                frequency_cy_per_px: edge.frequency_cy_per_px.clone(),
                mtf: edge.mtf.clone(),
                mtf50_cy_per_px: edge.mtf50_cy_per_px,
                mtf_area: edge.mtf_area,
            },
        );
    }
    if let Some(plot) = &args.plot {
        let curves: Vec<unicac_plot::Curve> = channels
            .iter()
            .map(|(name, m)| unicac_plot::Curve {
                label: name.clone(),
                x: m.frequency_cy_per_px.clone(),
                y: m.mtf.clone(),
            })
            .collect();
        unicac_plot::mtf_curves(&format!("Slanted-edge MTF of {}", path.display()), &curves, plot)?;
        eprintln!("wrote {}", plot.display());
    }
    if args.json {
        return print_json(&serde_json::json!({ "image": args.input, "channels": channels }));
    }
    for (name, m) in &channels {
        println!(
            "{name}: MTF50 {:.4} cy/px, MTF area {:.4}",
            m.mtf50_cy_per_px, m.mtf_area
        );
    }
    Ok(())
}
