//! `unicac simulate`: sharp images through a lens onto the sensor, with the sensor/ISP chain.

use crate::args::{OutputFormat, SimulateArgs};
use crate::lens_input::load_lens;
use crate::progress_display::ProgressDisplay;
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use unicac_image::io::{declared_size, read_image, Encoding, FileFormat, LoadedImage, SampleDepth};
use unicac_image::isp::{Pipeline, SensorNoise};
use unicac_image::Planar;
use unicac_io::progress::Progress;
use unicac_sim::{image_seed, LensSimulator, SimulationSettings, SimulatorSequence};

pub fn run(args: &SimulateArgs) -> Result<()> {
    let outputs = plan_outputs(args)?;
    let device = super::gpu::selection(&args.device);
    let lens = load_lens(&args.lens.lens)?;
    let created = !args.out.exists();
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    if let Err(error) = unicac_io::clean_stale_temporaries(&args.out) {
        eprintln!(
            "warning: {}: cleaning temporaries of killed runs: {error}",
            args.out.display()
        );
    }
    let result = simulate_all(args, &lens, &outputs, &device);
    super::gpu::print_notes(unicac_psf::HitTracer::take_notes(device.as_ref()));
    // A run that failed before writing anything leaves no empty folder behind.
    if result.is_err() && created {
        let _ = std::fs::remove_dir(&args.out);
    }
    result
}

fn simulate_all(
    args: &SimulateArgs,
    lens: &unicac_optics::Lens,
    outputs: &[(PathBuf, FileFormat)],
    device: &std::sync::Arc<unicac_gpu::DeviceSelection>,
) -> Result<()> {
    let bar = ProgressDisplay::new("simulate");
    bar.stage("images", args.images.len());
    let mut settings = SimulationSettings {
        distortion: !args.no_distortion,
        illumination: !args.no_illumination,
        cache: if args.no_cache {
            None
        } else {
            unicac_sim::PsfCache::default_location()
        },
        ..Default::default()
    };
    // One device for the PSF rays and the image pass (each falls back to the CPU on its own).
    settings.psf.backend = unicac_gpu::DeviceSelection::ray_backend(device);
    settings.image = unicac_gpu::DeviceSelection::image_backend(device);
    let mut simulators = SimulatorSequence::new(lens, args.pixel_um, settings);
    for (index, (path, (out, format))) in args.images.iter().zip(outputs).enumerate() {
        // The PSF map needs only the image's size: it is prepared while the image decodes.
        let (loaded, prepared) = match declared_size(path) {
            Some((width, height)) => rayon::join(
                || read_image(path),
                || simulators.for_size(width, height).map(|_| ()),
            ),
            None => (read_image(path), Ok(())),
        };
        let loaded = loaded?;
        prepared?;
        // Integer codes are finite by construction; float files are checked.
        if loaded.encoding == Encoding::Linear {
            if let Some((channel, x, y, value)) = loaded.image.first_non_finite() {
                bail!(
                    "{}: pixel (x {x}, y {y}) of channel {} is {value}; simulate needs finite values",
                    path.display(),
                    loaded.channel_names.get(channel).map_or("?", String::as_str)
                );
            }
        }
        let bit_depth = loaded.bit_depth;
        let image = rgb(loaded, path)?;
        let sim = simulators.for_size(image.width, image.height)?;
        if index == 0 {
            bar.suspend(|| report_psf_map(sim));
        }
        if let (0, Some(plot)) = (index, &args.psf_plot) {
            plot_psf_map(sim, &args.lens.lens, plot)?;
            bar.suspend(|| eprintln!("wrote {}", plot.display()));
        }
        let pipeline = Pipeline {
            no_isp: args.no_isp,
            no_noise: args.no_noise,
            sensor: SensorNoise {
                bit_depth: args.sensor_bits,
                ..SensorNoise::default()
            },
            ..Default::default()
        };
        if index == 0 {
            bar.suspend(|| report_read_out(&pipeline));
        }
        // The sharp side of --crops, encoded before `degrade` consumes the image.
        let sharp = (index == 0 && args.crops.is_some()).then(|| unicac_image::color::linear_to_srgb(&image));
        let degraded = sim.degrade(&pipeline, image, image_seed(args.seed, index))?;
        write_encoded(&degraded, out, *format, bit_depth)?;
        if let (Some(sharp), Some(crops)) = (sharp, &args.crops) {
            super::crops::write(&sharp, &degraded, crops)?;
            bar.suspend(|| eprintln!("wrote {}", crops.display()));
        }
        bar.advance(1);
    }
    bar.finish();
    eprintln!("wrote {} image(s) to {}", args.images.len(), args.out.display());
    Ok(())
}

/// Each input's output path and format, checked before any work: the input's file name, extension
/// included, inside --out, in the format that extension names (a name whose extension names no format
/// gets the format's extension appended, the format read from the file's signature). `--format`
/// replaces the extension where it names another format. No output may be an input (`simulate d/a.png
/// --out d/`) or another output (`x/a.png y/a.png`), and the PSF-map picture is checked with them.
fn plan_outputs(args: &SimulateArgs) -> Result<Vec<(PathBuf, FileFormat)>> {
    if args.out.exists() && !args.out.is_dir() {
        bail!(
            "--out {}: is a file; --out names the folder the simulated images are written to",
            args.out.display()
        );
    }
    let mut plan = crate::outputs::plan(Some(args.lens.lens.as_str()));
    let mut outputs = Vec::with_capacity(args.images.len());
    for input in &args.images {
        plan.input(input);
        let name = input
            .file_name()
            .ok_or_else(|| anyhow::anyhow!("{}: not a file name", input.display()))?;
        let named = FileFormat::from_extension(&unicac_io::extension_of(input));
        let format = match (args.format, named) {
            (Some(requested), _) => format_from_name(requested),
            (None, Some(format)) => format,
            (None, None) => sniff_format(input)?,
        };
        // BMP is read only (pyiqa's calibration images): a BMP input gives PNG output.
        let format = if format == FileFormat::Bmp {
            FileFormat::Png
        } else {
            format
        };
        let out = match named {
            Some(n) if n == format => args.out.join(name),
            Some(_) => args.out.join(name).with_extension(format.extension()),
            None => args
                .out
                .join(format!("{}.{}", name.to_string_lossy(), format.extension())),
        };
        plan.output("--out", &out);
        outputs.push((out, format));
    }
    crate::outputs::picture(&mut plan, "--psf-plot", args.psf_plot.as_deref())?;
    crate::outputs::picture(&mut plan, "--crops", args.crops.as_deref())?;
    plan.check()?;
    Ok(outputs)
}

/// The format of an image file from its first bytes (for names without a known extension).
fn sniff_format(path: &Path) -> Result<FileFormat> {
    use std::io::Read;
    let mut head = [0u8; 8];
    let read = std::fs::File::open(path)
        .and_then(|mut f| f.read(&mut head))
        .with_context(|| format!("reading {}", path.display()))?;
    FileFormat::sniff(&head[..read])
        .ok_or_else(|| anyhow::anyhow!("{}: not a PNG, TIFF or OpenEXR file", path.display()))
}

/// The sensor read-out in use: its bit depth is a simulation parameter, so it is announced.
fn report_read_out(pipeline: &Pipeline) {
    if pipeline.no_isp && pipeline.no_noise {
        eprintln!("sensor read-out: off (--no-isp --no-noise: optics only, full precision)");
    } else {
        eprintln!(
            "sensor read-out: {} bits (--sensor-bits), black level {} DN",
            pipeline.sensor.bit_depth, pipeline.sensor.black_level_dn
        );
    }
}

/// Where the PSF map came from, and how much energy the kernel-size cap cut.
fn report_psf_map(sim: &LensSimulator) {
    if let Some(warning) = &sim.cache_warning {
        eprintln!("warning: {warning}");
    }
    if sim.psfs_from_cache {
        eprintln!("PSF map loaded from the cache (lens {})", &sim.lens_sha256[..16]);
    }
    if sim.radial().is_none() {
        eprintln!(
            "the lens is decentred or tilted: PSFs traced at {} fields over the whole frame (not one radius; \
             not cached)",
            sim.psfs().len()
        );
    }
    let worst_cut = sim
        .psfs()
        .iter()
        .flat_map(|p| &p.energy_cut)
        .fold(0.0f64, |m, v| m.max(*v));
    if worst_cut > 0.01 {
        eprintln!(
            "warning: PSF kernels capped at {} px; up to {:.2}% of a PSF's energy fell outside and was cut",
            sim.kernel_size(),
            100.0 * worst_cut
        );
    }
}

/// The PSFs the simulator uses at a 7 x 5 grid of sensor positions (corners included).
fn plot_psf_map(sim: &LensSimulator, lens_name: &str, path: &Path) -> Result<()> {
    const COLUMNS: usize = 7;
    const ROWS: usize = 5;
    let [corner_x, corner_y] = sim.grid.to_mm(0.0, 0.0);
    let (half_width, half_height) = (corner_x.abs(), corner_y.abs());
    let cells: Vec<unicac_plot::PsfMapCell> = (0..ROWS)
        .flat_map(|row| (0..COLUMNS).map(move |column| (column, row)))
        .map(|(column, row)| {
            let x_mm = half_width * (2.0 * column as f64 / (COLUMNS - 1) as f64 - 1.0);
            let y_mm = half_height * (1.0 - 2.0 * row as f64 / (ROWS - 1) as f64);
            let kernels = [0, 1, 2].map(|c| sim.kernel_at(x_mm, y_mm, c));
            unicac_plot::PsfMapCell {
                x_mm,
                y_mm,
                size: kernels[0].size,
                rgb: kernels.map(|k| k.data),
            }
        })
        .collect();
    let title = format!(
        "PSF map of {lens_name} on a {} x {} px sensor ({} um pixels)",
        sim.grid.width_px,
        sim.grid.height_px,
        (sim.grid.pitch_um * 1e3).round() / 1e3
    );
    unicac_plot::psf_map(&title, &cells, COLUMNS, sim.grid.pitch_um, path)?;
    Ok(())
}

/// The linear RGB planes of a loaded image (grey is replicated; alpha dropped).
fn rgb(loaded: LoadedImage, path: &Path) -> Result<Planar> {
    if loaded.image.width == 0 || loaded.image.height == 0 {
        bail!("{}: the image is empty", path.display());
    }
    loaded
        .into_linear_rgb()
        .with_context(|| format!("{}: expected a grey or RGB image", path.display()))
}

fn format_from_name(format: OutputFormat) -> FileFormat {
    match format {
        OutputFormat::Png => FileFormat::Png,
        OutputFormat::Tiff => FileFormat::Tiff,
        OutputFormat::Exr => FileFormat::OpenExr,
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
        FileFormat::Png | FileFormat::Bmp => unicac_image::io::write_png(path, image, depth)?,
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
