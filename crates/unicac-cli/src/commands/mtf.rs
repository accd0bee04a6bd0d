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
    let lower = args.input.to_ascii_lowercase();
    if args.input.starts_with(crate::lens_input::BUILTIN_PREFIX)
        || lower.ends_with(".json")
        || lower.ends_with(".zmx")
    {
        return lens(args);
    }
    let path = std::path::Path::new(&args.input);
    let mut plan = crate::outputs::plan(None);
    plan.input(path);
    crate::outputs::picture(&mut plan, "--plot", args.plot.as_deref())?;
    plan.check()?;
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

/// `unicac mtf LENS`: slanted-edge and exact MTFs at the ODE fields (green channel plotted).
fn lens(args: &MtfArgs) -> Result<()> {
    crate::outputs::check_lens_and_picture(&args.input, "--plot", args.plot.as_deref())?;
    let lens = crate::lens_input::load_lens(&args.input)?;
    let curves = unicac_ode::lens_mtf(&lens, &unicac_ode::OdeSettings::default())?;
    if let Some(plot) = &args.plot {
        let mut lines = Vec::new();
        for c in curves
            .iter()
            .filter(|c| c.channel == "G" && c.direction == "tangential")
        {
            let label = format!("{:.0}% field", 100.0 * c.field_fraction);
            lines.push(unicac_plot::Curve {
                label: format!("{label} edge"),
                x: c.frequency_cy_per_px.clone(),
                y: c.edge_mtf.clone(),
            });
            lines.push(unicac_plot::Curve {
                label: format!("{label} exact"),
                x: c.frequency_cy_per_px.clone(),
                y: c.exact_mtf.clone(),
            });
        }
        unicac_plot::mtf_curves(
            &format!("Tangential MTF (G) of {}: slanted edge vs exact", args.input),
            &lines,
            plot,
        )?;
        eprintln!("wrote {}", plot.display());
    }
    if args.json {
        return print_json(&serde_json::json!({ "lens": args.input, "curves": curves }));
    }
    for c in &curves {
        let at_nyquist = c.frequency_cy_per_px.iter().position(|f| *f >= 0.25).unwrap_or(0);
        println!(
            "field {:.2} {} {:<10} MTF at 0.25 cy/px: edge {:.3}, exact {:.3}",
            c.field_fraction, c.channel, c.direction, c.edge_mtf[at_nyquist], c.exact_mtf[at_nyquist]
        );
    }
    Ok(())
}
