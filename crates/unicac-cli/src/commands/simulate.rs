//! `unicac simulate`: sharp images through a lens onto the sensor, with the sensor/ISP chain.

use super::progress;
use crate::args::SimulateArgs;
use crate::lens_input::load_lens;
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use unicac_image::io::{read_image, FileFormat, LoadedImage, SampleDepth};
use unicac_image::isp::Pipeline;
use unicac_image::Planar;
use unicac_sim::{LensSimulator, SimulationSettings};

pub fn run(args: &SimulateArgs) -> Result<()> {
    let lens = load_lens(&args.lens.lens)?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let bar = progress(args.images.len(), "simulate");
    let mut simulator: Option<LensSimulator> = None;
    for (index, path) in args.images.iter().enumerate() {
        let loaded = read_image(path)?;
        let image = rgb(&loaded, path)?;
        // PSF maps depend on the image size: reuse while it stays the same.
        if simulator
            .as_ref()
            .is_none_or(|s| (s.grid.width_px, s.grid.height_px) != (image.width, image.height))
        {
            let settings = SimulationSettings {
                distortion: !args.no_distortion,
                illumination: !args.no_illumination,
                cache: if args.no_cache {
                    None
                } else {
                    unicac_sim::PsfCache::default_location()
                },
                ..Default::default()
            };
            simulator = Some(LensSimulator::new(
                &lens,
                image.width,
                image.height,
                args.pixel_um,
                settings,
            )?);
        }
        let sim = simulator.as_ref().expect("prepared above");
        if index == 0 && sim.psfs_from_cache {
            bar.println(format!(
                "PSF map loaded from the cache (lens {})",
                &sim.lens_sha256[..16]
            ));
        }
        let pipeline = Pipeline {
            no_isp: args.no_isp,
            no_noise: args.no_noise,
            ..Default::default()
        };
        let seed = args.seed.wrapping_add(index as u64);
        let draw = pipeline.draw(seed)?;
        let raw = pipeline.unprocess(&image, &draw)?;
        let degraded = pipeline.process(&sim.apply(&raw)?, &draw)?;
        let format = args
            .format
            .as_deref()
            .map(format_from_name)
            .unwrap_or(loaded.format);
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| format!("image{index}"));
        let out = args.out.join(format!("{stem}.{}", extension(format)));
        write_encoded(&degraded, &out, format, loaded.bit_depth)?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    eprintln!("wrote {} image(s) to {}", args.images.len(), args.out.display());
    Ok(())
}

/// The linear RGB planes of a loaded image (grey is replicated; alpha dropped).
fn rgb(loaded: &LoadedImage, path: &Path) -> Result<Planar> {
    let linear = loaded.to_linear();
    let (w, h) = (linear.width, linear.height);
    if w == 0 || h == 0 {
        bail!("{}: the image is empty", path.display());
    }
    let colour: Vec<usize> = loaded
        .channel_names
        .iter()
        .enumerate()
        .filter(|(_, n)| n.as_str() != "A")
        .map(|(i, _)| i)
        .collect();
    let planes: Vec<usize> = match colour.as_slice() {
        [y] => vec![*y; 3],
        [r, g, b, ..] => vec![*r, *g, *b],
        _ => bail!("{}: expected a grey or RGB image", path.display()),
    };
    let mut out = Planar::new(w, h, 3);
    for (c, &p) in planes.iter().enumerate() {
        out.plane_mut(c).copy_from_slice(linear.plane(p));
    }
    Ok(out)
}

fn format_from_name(name: &str) -> FileFormat {
    match name {
        "tiff" => FileFormat::Tiff,
        "exr" => FileFormat::OpenExr,
        _ => FileFormat::Png,
    }
}

fn extension(format: FileFormat) -> &'static str {
    match format {
        FileFormat::Png => "png",
        FileFormat::Tiff => "tiff",
        FileFormat::OpenExr => "exr",
    }
}

/// Writes an sRGB-encoded image (the ISP's output): PNG/TIFF at the input's depth (8 or 16 bit),
/// EXR decoded back to linear float.
fn write_encoded(image: &Planar, path: &Path, format: FileFormat, bit_depth: u8) -> Result<()> {
    let depth = if bit_depth > 8 {
        SampleDepth::Sixteen
    } else {
        SampleDepth::Eight
    };
    match format {
        FileFormat::Png => unicac_image::io::write_png(path, image, depth)?,
        FileFormat::Tiff => unicac_image::io::write_tiff(path, image, SampleDepth::Sixteen)?,
        FileFormat::OpenExr => {
            unicac_image::io::write_exr(path, &unicac_image::color::srgb_to_linear(image))?
        }
    }
    Ok(())
}

/// Writes a linear image: EXR as is, PNG/TIFF sRGB-encoded at 16 bits (or `depth`).
pub fn write_linear(image: &Planar, path: &Path, depth: Option<SampleDepth>) -> Result<()> {
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let encoded = || unicac_image::color::linear_to_srgb(image);
    match extension.as_str() {
        "exr" => unicac_image::io::write_exr(path, image)?,
        "png" => unicac_image::io::write_png(path, &encoded(), depth.unwrap_or(SampleDepth::Sixteen))?,
        "tif" | "tiff" => {
            unicac_image::io::write_tiff(path, &encoded(), depth.unwrap_or(SampleDepth::Sixteen))?
        }
        _ => bail!(
            "{}: unknown image extension (expected .png, .tif, .tiff or .exr)",
            PathBuf::from(path).display()
        ),
    }
    Ok(())
}
