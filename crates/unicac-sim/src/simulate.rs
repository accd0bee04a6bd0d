//! `LensSimulator`: a sharp linear-light image on the sensor in, the lens's image of it out.
//!
//! Coordinates: the input is the **ideal** image (each scene direction at its paraxial, distortion-free
//! position on the sensor grid). The simulator blurs it with the PSF of the field imaged there
//! (spatially varying, `convolve`), then optionally warps it to the real chief-ray positions
//! (distortion; outside the input it replicates the border) and scales by the relative illumination
//! (chief-ray mapping and vignetting).

use crate::chief::ChiefRayMap;
use crate::convolve::{convolve_varying_with, node_positions, Blend, KernelGrid, Method};
use crate::error::{SimError, SimResult};
use crate::geometry::SensorGrid;
use crate::psf_cache::{lens_fingerprint, PsfCache};
use crate::psf_map::RadialPsfs;
use rayon::prelude::*;
use serde::Serialize;
use unicac_image::isp::Pipeline;
use unicac_image::Planar;
use unicac_optics::Lens;
use unicac_psf::{visible_wavelengths_um, PsfSettings, PsfTracer, SpectralResponse, SpectralWeights};

/// Fidelity and effect switches (defaults at the knee of the sweep in docs/performance.md).
#[derive(Debug, Clone, Serialize)]
pub struct SimulationSettings {
    pub psf: PsfSettings,
    /// Wavelengths from 400 to 700 nm.
    pub wavelengths: usize,
    /// Radial PSF samples from the axis to the corner.
    pub radial_samples: usize,
    /// Kernel-node intervals along the image's longer side. Field-relative, so the interpolation error
    /// stays the same at every resolution (the PSF changes over a fraction of the field, not over a
    /// number of pixels); the spacing never drops below `MIN_NODE_SPACING_PX`.
    pub node_intervals: usize,
    /// Direct or FFT corner convolutions (same result; `Auto` takes the cheaper).
    pub method: Method,
    pub blend: Blend,
    pub distortion: bool,
    pub illumination: bool,
    #[serde(skip)]
    pub response: SpectralResponse,
    /// Where traced PSF maps are kept between runs (`None`: always trace).
    #[serde(skip)]
    pub cache: Option<PsfCache>,
}

/// Most pixels of an image `LensSimulator` takes (2^27, 134 MP). Peak memory is linear in the pixel
/// count (docs/reliability.md gives the measured formula): about 12 GB at this limit.
pub const MAX_SIMULATE_PIXELS: usize = 1 << 27;

/// Node spacing floor (pixels): below it nodes cost more than they correct (docs/performance.md).
pub const MIN_NODE_SPACING_PX: usize = 8;

impl Default for SimulationSettings {
    fn default() -> Self {
        SimulationSettings {
            psf: PsfSettings::new(1.0),
            wavelengths: 31,
            radial_samples: 17,
            node_intervals: 20,
            method: Method::Auto,
            blend: Blend::Bilinear,
            distortion: true,
            illumination: true,
            response: SpectralResponse::default_camera(),
            cache: None,
        }
    }
}

pub struct LensSimulator {
    pub grid: SensorGrid,
    pub chief: ChiefRayMap,
    pub radial: RadialPsfs,
    pub settings: SimulationSettings,
    /// SHA-256 of the lens model (provenance; see `psf_cache`).
    pub lens_sha256: String,
    /// Whether the PSF map came from the cache instead of being traced.
    pub psfs_from_cache: bool,
    /// Why a freshly traced map could not be stored in the cache (the simulation itself is unaffected).
    pub cache_warning: Option<String>,
    kernels: Vec<KernelGrid>,
}

impl LensSimulator {
    /// Prepares PSFs for a `width` x `height` image; `pixel_um` None fills the lens's field.
    pub fn new(
        lens: &Lens,
        width: usize,
        height: usize,
        pixel_um: Option<f64>,
        settings: SimulationSettings,
    ) -> SimResult<LensSimulator> {
        if width < 2 || height < 2 {
            return Err(SimError::InvalidRequest(format!(
                "image of {width} x {height} pixels is too small"
            )));
        }
        if width.saturating_mul(height) > MAX_SIMULATE_PIXELS {
            return Err(SimError::InvalidRequest(format!(
                "image of {width} x {height} pixels exceeds the limit of {MAX_SIMULATE_PIXELS} pixels \
                 (MAX_SIMULATE_PIXELS; peak memory grows with the pixel count, see docs/reliability.md)"
            )));
        }
        let chief = ChiefRayMap::new(lens)?;
        let grid = match pixel_um {
            Some(p) if p.is_finite() && p > 0.0 => SensorGrid {
                width_px: width,
                height_px: height,
                pitch_um: p,
            },
            Some(p) => {
                return Err(SimError::InvalidRequest(format!(
                    "pixel pitch {p} um must be positive"
                )))
            }
            None => SensorGrid::filling_field(width, height, &chief),
        };
        let mut psf_settings = settings.psf;
        psf_settings.pixel_um = grid.pitch_um;
        let weights = SpectralWeights::new(&settings.response, &visible_wavelengths_um(settings.wavelengths));
        let tracer = PsfTracer::new(lens, weights, psf_settings)?;
        let corner = grid.half_diagonal_mm().min(chief.max_height_mm());
        let lens_sha256 = lens_fingerprint(lens);
        // The cache key covers everything the radial PSFs depend on, the tracing device included (a GPU f32
        // map is not served to a CPU run).
        let cache_entry = settings.cache.as_ref().map(|cache| {
            let inputs = (
                psf_settings,
                tracer.weights(),
                corner,
                settings.radial_samples,
                tracer.device(),
            );
            let key = PsfCache::key(&[
                b"radial",
                lens_sha256.as_bytes(),
                format!("{inputs:?}").as_bytes(),
            ]);
            (cache, key)
        });
        let cached = cache_entry
            .as_ref()
            .and_then(|(cache, key)| cache.load(key))
            .and_then(|psfs| RadialPsfs::from_psfs(corner, psfs));
        let psfs_from_cache = cached.is_some();
        let mut cache_warning = None;
        let radial = match cached {
            Some(radial) => radial,
            None => {
                let radial = RadialPsfs::trace(&tracer, &chief, corner, settings.radial_samples, false)?;
                if let Some((cache, key)) = &cache_entry {
                    // A cache that cannot be written costs the next run time, not this run its result.
                    if let Err(error) = cache.store(key, &radial.psfs) {
                        cache_warning = Some(format!("PSF cache {}: {error}", cache.dir.display()));
                    }
                }
                radial
            }
        };
        if radial.kernel_size > grid.width_px.min(grid.height_px) {
            return Err(SimError::InvalidRequest(format!(
                "the PSF ({} px) is larger than the image ({width} x {height} px)",
                radial.kernel_size
            )));
        }
        let mut simulator = LensSimulator {
            grid,
            chief,
            radial,
            settings,
            lens_sha256,
            psfs_from_cache,
            cache_warning,
            kernels: Vec::new(),
        };
        simulator.kernels = (0..3).map(|c| simulator.kernel_grid(c)).collect();
        Ok(simulator)
    }

    /// Real (distorted) sensor position of the field whose ideal image is at `ideal_mm`.
    fn real_position(&self, ideal_mm: [f64; 2]) -> [f64; 2] {
        if !self.settings.distortion || self.chief.paraxial_height_per_tan_mm == 0.0 {
            return ideal_mm;
        }
        let ideal = ideal_mm[0].hypot(ideal_mm[1]);
        if ideal == 0.0 {
            return ideal_mm;
        }
        let angle = (ideal / self.chief.paraxial_height_per_tan_mm)
            .atan()
            .to_degrees();
        let scale = self.chief.height_for_angle(angle) / ideal;
        [ideal_mm[0] * scale, ideal_mm[1] * scale]
    }

    fn kernel_grid(&self, channel: usize) -> KernelGrid {
        let spacing = self.node_spacing_px();
        let nodes = |length: usize| ((length - 1).div_ceil(spacing) + 1).max(2);
        let (nodes_x, nodes_y) = (nodes(self.grid.width_px), nodes(self.grid.height_px));
        let xs = node_positions(self.grid.width_px, nodes_x);
        let ys = node_positions(self.grid.height_px, nodes_y);
        let kernels = ys
            .par_iter()
            .flat_map_iter(|&row| xs.iter().map(move |&column| (column, row)))
            .map(|(column, row)| {
                let [x, y] = self.real_position(self.grid.to_mm(column, row));
                self.radial.kernel_at(x, y, channel)
            })
            .collect();
        KernelGrid {
            nodes_x,
            nodes_y,
            kernels,
        }
    }

    /// Distance between kernel nodes (pixels) for this image size.
    pub fn node_spacing_px(&self) -> usize {
        let longer = self.grid.width_px.max(self.grid.height_px);
        (longer / self.settings.node_intervals.max(1)).max(MIN_NODE_SPACING_PX)
    }

    /// Simulates the lens on a linear RGB image of the prepared size.
    pub fn apply(&self, image: &Planar) -> SimResult<Planar> {
        let (w, h) = (self.grid.width_px, self.grid.height_px);
        if image.width != w || image.height != h || image.channels != 3 {
            return Err(SimError::InvalidRequest(format!(
                "expected a {w} x {h} RGB image, got {} x {} with {} channels",
                image.width, image.height, image.channels
            )));
        }
        let mut out = Planar::new(w, h, 3);
        for c in 0..3 {
            let blurred = convolve_varying_with(
                image.plane(c),
                w,
                h,
                &self.kernels[c],
                self.settings.method,
                self.settings.blend,
            );
            out.plane_mut(c).copy_from_slice(&blurred);
        }
        if self.settings.distortion {
            out = self.warp(&out);
        }
        if self.settings.illumination {
            self.shade(&mut out);
        }
        Ok(out)
    }

    /// The whole chain on one sharp linear image, as `unicac simulate` runs it: the ISP draw of `seed`
    /// (white-balance perturbation, noise seed), inverse white balance, the optics (`apply`), then sensor
    /// noise and the ISP.
    pub fn degrade(&self, pipeline: &Pipeline, image: &Planar, seed: u64) -> SimResult<Planar> {
        let draw = pipeline.draw(seed)?;
        let raw = pipeline.unprocess(image, &draw)?;
        Ok(pipeline.process(&self.apply(&raw)?, &draw)?)
    }

    /// Moves content from ideal to real positions: output pixel at real position r samples the
    /// blurred ideal image at the ideal position of the field landing at r (bilinear).
    fn warp(&self, image: &Planar) -> Planar {
        let (w, h) = (image.width, image.height);
        let mut out = Planar::new(w, h, image.channels);
        let sources: Vec<[f64; 2]> = (0..h)
            .into_par_iter()
            .flat_map_iter(|row| (0..w).map(move |column| (column, row)))
            .map(|(column, row)| {
                let real = self.grid.to_mm(column as f64, row as f64);
                let radius = real[0].hypot(real[1]);
                if radius == 0.0 {
                    return [column as f64, row as f64];
                }
                let scale = self.chief.ideal_height(radius) / radius;
                self.grid.to_px([real[0] * scale, real[1] * scale])
            })
            .collect();
        for c in 0..image.channels {
            let plane = image.plane(c);
            let target = out.plane_mut(c);
            target
                .par_iter_mut()
                .zip(&sources)
                .for_each(|(v, &[x, y])| *v = sample_bilinear(plane, w, h, x, y));
        }
        out
    }

    /// Relative illumination: chief-ray mapping times vignetting, normalised by the peak transmission.
    fn shade(&self, image: &mut Planar) {
        let (w, h) = (image.width, image.height);
        let axis = self.radial.peak_transmission().max(1e-12);
        let factors: Vec<f32> = (0..w * h)
            .into_par_iter()
            .map(|i| {
                let [x, y] = self.grid.to_mm((i % w) as f64, (i / w) as f64);
                let radius = x.hypot(y);
                (self.chief.illumination_factor(radius) * self.radial.transmission_at(radius) / axis) as f32
            })
            .collect();
        for c in 0..image.channels {
            image
                .plane_mut(c)
                .iter_mut()
                .zip(&factors)
                .for_each(|(v, f)| *v *= f);
        }
    }
}

/// Bilinear sample with replicated borders.
fn sample_bilinear(plane: &[f32], width: usize, height: usize, x: f64, y: f64) -> f32 {
    let x = x.clamp(0.0, width as f64 - 1.0);
    let y = y.clamp(0.0, height as f64 - 1.0);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(width - 1), (y0 + 1).min(height - 1));
    let (tx, ty) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
    let top = plane[y0 * width + x0] * (1.0 - tx) + plane[y0 * width + x1] * tx;
    let bottom = plane[y1 * width + x0] * (1.0 - tx) + plane[y1 * width + x1] * tx;
    top * (1.0 - ty) + bottom * ty
}
