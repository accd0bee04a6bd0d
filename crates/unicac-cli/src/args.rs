//! Every command-line argument of `unicac`, in one place (clap derive).

use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;
use unicac_trace::{Aiming, PupilSampling};

#[derive(Parser)]
#[command(
    name = "unicac",
    version,
    about = "Universal computational aberration correction: lens design, simulation, evaluation and benchmarking"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
    /// Lens files: first-order data, conversion between formats.
    #[command(subcommand)]
    Lens(LensCommand),
    /// Trace one ray: explicit (--ray) or aimed (--field-deg and --pupil).
    Trace(TraceArgs),
    /// Spot diagrams and RMS spot radii per field and wavelength.
    Spot(SpotArgs),
    /// Transverse ray fans (tangential and sagittal) per field and wavelength.
    Fan(FanArgs),
    /// Draw the lens in the y-z plane with ray bundles.
    Layout(LayoutArgs),
}

#[derive(Subcommand)]
pub enum LensCommand {
    /// First-order (paraxial) data, real working F/#, distortion and clear semi-diameters.
    Info(LensInfoArgs),
    /// Convert between unicac JSON and Zemax .zmx (by extension).
    Convert(ConvertArgs),
    /// List the lenses built into this binary (usable as `builtin:NAME` wherever a LENS is expected).
    List,
}

/// LENS: a `.json` or `.zmx` file, or `builtin:NAME` (see `unicac lens list`).
#[derive(Args)]
pub struct LensArg {
    /// A .json or .zmx lens file, or builtin:NAME.
    pub lens: String,
}

#[derive(Args)]
pub struct LensInfoArgs {
    #[command(flatten)]
    pub lens: LensArg,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct ConvertArgs {
    pub input: String,
    pub output: PathBuf,
}

#[derive(Args)]
pub struct TraceArgs {
    #[command(flatten)]
    pub lens: LensArg,
    /// Explicit ray X,Y,Z,L,M,N: start point (mm) and direction (normalised here), global coordinates.
    #[arg(long, value_parser = parse_ray, allow_hyphen_values = true, conflicts_with_all = ["field_deg", "pupil"])]
    pub ray: Option<[f64; 6]>,
    /// Field angle in the y-z plane (deg); the ray travels along (0, sin F, cos F).
    #[arg(long, allow_hyphen_values = true, requires = "pupil")]
    pub field_deg: Option<f64>,
    /// Normalised pupil coordinates PX,PY in [-1, 1].
    #[arg(long, value_parser = parse_pupil, allow_hyphen_values = true)]
    pub pupil: Option<[f64; 2]>,
    /// Ray aiming for --field-deg rays.
    #[arg(long, default_value = "paraxial", value_parser = parse_aiming)]
    pub aim: Aiming,
    /// Wavelength (um); default: the lens's primary wavelength.
    #[arg(long, allow_hyphen_values = true)]
    pub wavelength_um: Option<f64>,
    /// Also report the point on every surface.
    #[arg(long)]
    pub path: bool,
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct SpotArgs {
    #[command(flatten)]
    pub lens: LensArg,
    /// Field angles (deg); default: the lens's fields.
    #[arg(long = "field-deg", allow_hyphen_values = true)]
    pub fields_deg: Vec<f64>,
    /// Wavelengths (um); default: the lens's wavelengths.
    #[arg(long = "wavelength-um", allow_hyphen_values = true)]
    pub wavelengths_um: Vec<f64>,
    #[arg(long, default_value = "paraxial", value_parser = parse_aiming)]
    pub aim: Aiming,
    /// hexapolar:R, grid:N, fibonacci:N or random:N[:SEED].
    #[arg(long, default_value = "hexapolar:10", value_parser = parse_sampling)]
    pub pupil_sampling: PupilSampling,
    #[arg(long)]
    pub json: bool,
    /// Write a spot diagram (.png or .svg).
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

#[derive(Args)]
pub struct FanArgs {
    #[command(flatten)]
    pub lens: LensArg,
    #[arg(long = "field-deg", allow_hyphen_values = true)]
    pub fields_deg: Vec<f64>,
    #[arg(long = "wavelength-um", allow_hyphen_values = true)]
    pub wavelengths_um: Vec<f64>,
    #[arg(long, default_value = "paraxial", value_parser = parse_aiming)]
    pub aim: Aiming,
    /// Points per fan.
    #[arg(long, default_value_t = 41)]
    pub samples: usize,
    #[arg(long)]
    pub json: bool,
    /// Write the fan plot (.png or .svg).
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

#[derive(Args)]
pub struct LayoutArgs {
    #[command(flatten)]
    pub lens: LensArg,
    /// Output picture (.png or .svg).
    #[arg(long)]
    pub plot: PathBuf,
    /// Rays per field.
    #[arg(long, default_value_t = 7)]
    pub rays: usize,
}

fn parse_numbers<const N: usize>(text: &str, what: &str) -> Result<[f64; N], String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .map_err(|_| format!("'{v}' is not a number"))
        })
        .collect::<Result<_, _>>()?;
    let array: [f64; N] = values
        .try_into()
        .map_err(|_| format!("expected {N} comma-separated numbers {what}"))?;
    if array.iter().any(|v| !v.is_finite()) {
        return Err("values must be finite".into());
    }
    Ok(array)
}

fn parse_ray(text: &str) -> Result<[f64; 6], String> {
    let ray = parse_numbers::<6>(text, "X,Y,Z,L,M,N")?;
    if ray[3..].iter().all(|d| *d == 0.0) {
        return Err("the direction L,M,N must not be zero".into());
    }
    Ok(ray)
}

fn parse_pupil(text: &str) -> Result<[f64; 2], String> {
    parse_numbers::<2>(text, "PX,PY")
}

fn parse_aiming(text: &str) -> Result<Aiming, String> {
    text.parse()
}

fn parse_sampling(text: &str) -> Result<PupilSampling, String> {
    text.parse()
}
