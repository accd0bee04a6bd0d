//! PSFs of several fields at one common kernel size: the one implementation behind the simulator's
//! radial map (unicac-sim), the ODE's fields (unicac-ode) and `unicac psf` / Python `unicac.psf`.
//!
//! Two levels: `PsfTracer::common_size_psfs` for callers that build their own tracer (pupil sampling,
//! camera curves of their own), and `FieldPsfRequest`, the whole request of a face (mode, fields,
//! wavelengths, pixel pitch, sizing, backend), validated when it is built, with its cache key.

use crate::cache::PsfCache;
use crate::error::{PsfError, PsfResult};
use crate::geometric::{check_kernel_cap, FieldHits, FieldPsf, PsfSettings, PsfTracer};
use crate::hit_tracer::RayBackend;
use crate::spectrum::{visible_wavelengths_um, SpectralResponse, SpectralWeights};
use crate::wave::{WavePsfSettings, WavePsfTracer};
use rayon::prelude::*;
use serde::Serialize;
use unicac_optics::Lens;
use unicac_trace::{check_field_deg, check_fields_deg, check_wavelengths_um, InvalidParameter};

/// Pixel pitch (um) when neither the request nor the lens's sensor gives one.
pub const DEFAULT_PIXEL_UM: f64 = 2.0;
/// Smallest wave-optics kernel (px): room for the diffraction rings.
pub const MIN_WAVE_KERNEL_PX: usize = 31;
/// Wavelengths over 400-700 nm when a request names none.
pub const DEFAULT_WAVELENGTHS: usize = 31;

/// Ray density (geometric) or diffraction (wave).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PsfMode {
    Geometric,
    Wave,
}

impl PsfMode {
    pub fn name(self) -> &'static str {
        match self {
            PsfMode::Geometric => "geometric",
            PsfMode::Wave => "wave",
        }
    }
}

impl std::str::FromStr for PsfMode {
    type Err = PsfError;
    fn from_str(text: &str) -> PsfResult<PsfMode> {
        match text {
            "geometric" => Ok(PsfMode::Geometric),
            "wave" => Ok(PsfMode::Wave),
            _ => Err(
                InvalidParameter::new("mode", format!("'{text}': expected \"geometric\" or \"wave\"")).into(),
            ),
        }
    }
}

/// Which fields without light are an error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DarkFields {
    /// Every field must receive light: a PSF asked for by field is no answer when dark
    /// (`PsfError::FieldVignetted` naming the first dark field).
    Refused,
    /// Dark fields are zero kernels as long as one field is lit (a map over the sensor; else
    /// `PsfError::AllFieldsVignetted`).
    AllowedIfAnyLit,
}

/// PSFs of several fields rasterised at one kernel size.
#[derive(Debug, Clone)]
pub struct CommonSizePsfs {
    pub psfs: Vec<FieldPsf>,
    /// The common size: the largest spot's, capped at `PsfSettings::max_kernel_px`.
    pub kernel_px: usize,
    /// The size the largest spot asked for before the cap.
    pub requested_kernel_px: usize,
}

/// One field traced but not yet rasterised: its reference point and hits per wavelength. Callers
/// that choose more fields after seeing some (the simulator's adaptive radial samples) trace in
/// rounds and rasterise once, at the size the largest spot of all of them asks for.
#[derive(Debug, Clone)]
pub struct TracedField {
    /// The field's y and x angles (deg).
    pub field_deg: f64,
    pub field_x_deg: f64,
    pub reference_mm: [f64; 2],
    pub hits: Vec<FieldHits>,
}

impl TracedField {
    /// No ray of any wavelength reached the image.
    pub fn is_dark(&self) -> bool {
        self.hits.iter().all(|h| h.offsets_um.is_empty())
    }
}

impl PsfTracer {
    /// Reference point and hits of every field along y (in parallel).
    pub fn trace_fields(&self, fields_deg: &[f64]) -> PsfResult<Vec<TracedField>> {
        let fields: Vec<[f64; 2]> = fields_deg.iter().map(|&y| [0.0, y]).collect();
        self.trace_fields_at(&fields)
    }

    /// `trace_fields` of 2D fields ([x, y] angles, deg): what a lens that is not rotationally symmetric
    /// needs.
    pub fn trace_fields_at(&self, fields_deg: &[[f64; 2]]) -> PsfResult<Vec<TracedField>> {
        fields_deg
            .par_iter()
            .map(|&field| {
                let reference_mm = self.reference_point_mm_at(field)?;
                Ok(TracedField {
                    field_deg: field[1],
                    field_x_deg: field[0],
                    reference_mm,
                    hits: self.hits_at(field, reference_mm)?,
                })
            })
            .collect()
    }

    /// Kernel size (odd, px, before the cap) holding the energy fraction of the largest traced spot,
    /// dark fields included (they ask for 1 px).
    fn largest_kernel_px(&self, traced: &[TracedField]) -> usize {
        traced
            .iter()
            .map(|field| self.kernel_size_for(&field.hits))
            .max()
            .unwrap_or(1)
    }

    /// `field` rasterised at `size` px (capped at `PsfSettings::max_kernel_px`).
    pub fn rasterise_field(&self, field: &TracedField, size: usize, monochromatic: bool) -> FieldPsf {
        let psf = self.kernels_from_hits(
            field.field_deg,
            field.reference_mm,
            &field.hits,
            size,
            monochromatic,
        );
        FieldPsf {
            field_x_deg: field.field_x_deg,
            ..psf
        }
    }

    /// R, G, B (or monochromatic) kernels of every field at one common size, from the largest spot.
    pub fn common_size_psfs(
        &self,
        fields_deg: &[f64],
        monochromatic: bool,
        dark: DarkFields,
    ) -> PsfResult<CommonSizePsfs> {
        let traced = self.trace_fields(fields_deg)?;
        self.rasterise_common_size(&traced, monochromatic, dark)
    }

    /// `common_size_psfs` of 2D fields ([x, y] angles, deg).
    pub fn common_size_psfs_at(
        &self,
        fields_deg: &[[f64; 2]],
        monochromatic: bool,
        dark: DarkFields,
    ) -> PsfResult<CommonSizePsfs> {
        let traced = self.trace_fields_at(fields_deg)?;
        self.rasterise_common_size(&traced, monochromatic, dark)
    }

    /// Traced fields rasterised at one common size, from the largest spot (dark fields as `dark` says).
    pub fn rasterise_common_size(
        &self,
        traced: &[TracedField],
        monochromatic: bool,
        dark: DarkFields,
    ) -> PsfResult<CommonSizePsfs> {
        match dark {
            DarkFields::Refused => {
                for field in traced {
                    self.require_arrivals(field.field_deg, &field.hits)?;
                }
            }
            DarkFields::AllowedIfAnyLit => {
                if traced.iter().all(TracedField::is_dark) {
                    return Err(PsfError::AllFieldsVignetted {
                        max_field_deg: traced.last().map_or(0.0, |field| field.field_deg),
                        rays_traced: traced
                            .iter()
                            .flat_map(|field| &field.hits)
                            .map(|h| h.counts.total())
                            .sum(),
                    });
                }
            }
        }
        let requested_kernel_px = self.largest_kernel_px(traced);
        let kernel_px = requested_kernel_px.min(self.settings().max_kernel_px);
        let psfs = traced
            .par_iter()
            .map(|field| self.rasterise_field(field, kernel_px, monochromatic))
            .collect();
        Ok(CommonSizePsfs {
            psfs,
            kernel_px,
            requested_kernel_px,
        })
    }
}

/// Spectral weights of a face's wavelength list: none gives R, G, B over 400-700 nm through the
/// default camera, one a monochromatic kernel, several are weighted by the camera into R, G, B.
pub fn weights_for(wavelengths_um: &[f64]) -> SpectralWeights {
    match wavelengths_um {
        [] => SpectralWeights::new(
            &SpectralResponse::default_camera(),
            &visible_wavelengths_um(DEFAULT_WAVELENGTHS),
        ),
        [w] => SpectralWeights::monochromatic(*w),
        many => SpectralWeights::new(&SpectralResponse::default_camera(), many),
    }
}

/// PSFs of some fields of a lens, as a face asks for them; every parameter is checked by `new` and the
/// `with_` methods, before any tracing.
#[derive(Debug, Clone)]
pub struct FieldPsfRequest {
    mode: PsfMode,
    /// y angles (deg), with the one x angle `field_x_deg` (0: fields along y).
    fields_deg: Vec<f64>,
    field_x_deg: f64,
    wavelengths_um: Vec<f64>,
    pixel_um: Option<f64>,
    max_kernel_px: Option<usize>,
    backend: RayBackend,
}

/// What a `FieldPsfRequest` traced.
#[derive(Debug, Clone)]
pub struct FieldPsfResponse {
    pub psfs: Vec<FieldPsf>,
    pub weights: SpectralWeights,
    pub pixel_um: f64,
    /// Kernel size the spots asked for before the cap, and the cap (geometric mode).
    pub requested_kernel_px: usize,
    pub max_kernel_px: usize,
    /// True when the wave-optics pupil grid undersampled a wavefront (the PSF is approximate).
    pub undersampled: bool,
}

impl FieldPsfRequest {
    pub fn new(mode: PsfMode, fields_deg: Vec<f64>, wavelengths_um: Vec<f64>) -> PsfResult<FieldPsfRequest> {
        check_fields_deg(&fields_deg)?;
        check_wavelengths_um(&wavelengths_um)?;
        Ok(FieldPsfRequest {
            mode,
            fields_deg,
            field_x_deg: 0.0,
            wavelengths_um,
            pixel_um: None,
            max_kernel_px: None,
            backend: RayBackend::cpu(),
        })
    }

    /// The sensor pitch (um); None: the lens's sensor, else `DEFAULT_PIXEL_UM`.
    pub fn with_pixel_um(self, pixel_um: Option<f64>) -> PsfResult<FieldPsfRequest> {
        pixel_um.map(crate::geometric::check_pixel_um).transpose()?;
        Ok(FieldPsfRequest { pixel_um, ..self })
    }

    /// Geometric mode: the kernel holds every ray up to this size (odd, at most `KERNEL_PX_LIMIT`)
    /// instead of 99.5% of the energy within 127 px.
    pub fn with_kernel_cap(self, max_kernel_px: Option<usize>) -> PsfResult<FieldPsfRequest> {
        if let Some(n) = max_kernel_px {
            check_kernel_cap(n).map_err(|message| InvalidParameter::new("max_kernel_px", message))?;
        }
        Ok(FieldPsfRequest {
            max_kernel_px,
            ..self
        })
    }

    /// Fields off the y axis: every field at this x angle (deg; geometric mode), for lenses that are not
    /// rotationally symmetric (decentred or tilted surfaces), whose PSF at one azimuth does not give the
    /// others by rotation.
    pub fn with_field_x_deg(self, field_x_deg: f64) -> PsfResult<FieldPsfRequest> {
        check_field_deg(field_x_deg).map_err(|e| InvalidParameter::new("field_x_deg", e.message))?;
        if field_x_deg != 0.0 && self.mode == PsfMode::Wave {
            return Err(InvalidParameter::new(
                "field_x_deg",
                format!(
                    "{field_x_deg}: the wave-optics PSF takes fields along y only; use the geometric mode"
                ),
            )
            .into());
        }
        Ok(FieldPsfRequest { field_x_deg, ..self })
    }

    pub fn with_backend(self, backend: RayBackend) -> FieldPsfRequest {
        FieldPsfRequest { backend, ..self }
    }

    pub fn mode(&self) -> PsfMode {
        self.mode
    }

    /// The backend that traces (and names the device in the cache key).
    pub fn backend(&self) -> &RayBackend {
        &self.backend
    }

    pub fn monochromatic(&self) -> bool {
        self.wavelengths_um.len() == 1
    }

    pub fn weights(&self) -> SpectralWeights {
        weights_for(&self.wavelengths_um)
    }

    /// The pitch this request traces `lens` at.
    pub fn pixel_um_for(&self, lens: &Lens) -> PsfResult<f64> {
        Ok(crate::geometric::check_pixel_um(
            self.pixel_um
                .or(lens.sensor.map(|s| s.pixel_um))
                .unwrap_or(DEFAULT_PIXEL_UM),
        )?)
    }

    /// The geometric settings this request traces with.
    fn geometric_settings(&self, pixel_um: f64) -> PsfSettings {
        PsfSettings::new(pixel_um)
            .with_kernel_cap(self.max_kernel_px)
            .with_backend(self.backend.clone())
    }

    /// Everything besides the lens the PSFs of `lens` depend on, the tracing device included, as the
    /// canonical bytes of a cache key's part (see `cache::PsfCache::key`).
    pub fn key_bytes(&self, lens: &Lens) -> PsfResult<Vec<u8>> {
        let pixel_um = self.pixel_um_for(lens)?;
        let along_y = (
            self.mode,
            &self.fields_deg,
            pixel_um,
            self.weights(),
            self.monochromatic(),
            &self.backend,
            self.max_kernel_px,
        );
        // Fields along y keep the keys they always had.
        Ok(if self.field_x_deg == 0.0 {
            unicac_io::digest::canonical_json(&along_y)
        } else {
            unicac_io::digest::canonical_json(&(along_y, self.field_x_deg))
        })
    }

    /// The fields as [x, y] angles (deg).
    fn fields_xy_deg(&self) -> Vec<[f64; 2]> {
        self.fields_deg.iter().map(|&y| [self.field_x_deg, y]).collect()
    }

    /// Traces the PSFs: geometric ones sized to the largest spot (dark fields refused); wave ones sized
    /// like the geometric PSFs of the same fields (so both modes compare pixel for pixel), at least
    /// `MIN_WAVE_KERNEL_PX`.
    pub fn run(&self, lens: &Lens) -> PsfResult<FieldPsfResponse> {
        let pixel_um = self.pixel_um_for(lens)?;
        let weights = self.weights();
        let mono = self.monochromatic();
        match self.mode {
            PsfMode::Geometric => {
                let tracer = PsfTracer::new(lens, weights.clone(), self.geometric_settings(pixel_um))?;
                let set = tracer.common_size_psfs_at(&self.fields_xy_deg(), mono, DarkFields::Refused)?;
                Ok(FieldPsfResponse {
                    psfs: set.psfs,
                    weights,
                    pixel_um,
                    requested_kernel_px: set.requested_kernel_px,
                    max_kernel_px: tracer.settings().max_kernel_px,
                    undersampled: false,
                })
            }
            PsfMode::Wave => {
                let sizing = PsfSettings::new(pixel_um).with_backend(self.backend.clone());
                let sizing = PsfTracer::new(lens, weights.clone(), sizing)?;
                // One geometric trace gives both the size and each field's reference point.
                let traced = sizing.trace_fields(&self.fields_deg)?;
                let size = sizing.largest_kernel_px(&traced).max(MIN_WAVE_KERNEL_PX);
                let tracer = WavePsfTracer::new(lens, weights.clone(), WavePsfSettings::new(pixel_um))?;
                let mut psfs = Vec::with_capacity(self.fields_deg.len());
                let mut undersampled = false;
                for field in &traced {
                    let detailed =
                        tracer.field_psf_detailed(field.field_deg, field.reference_mm, size, mono)?;
                    undersampled |= detailed.undersampled;
                    psfs.push(detailed.psf);
                }
                Ok(FieldPsfResponse {
                    psfs,
                    weights,
                    pixel_um,
                    requested_kernel_px: size,
                    max_kernel_px: size,
                    undersampled,
                })
            }
        }
    }
}

/// How `FieldPsfRequest::run_cached` obtained its PSFs.
#[derive(Debug, Clone)]
pub enum Served {
    /// From the cache: the stored PSFs (no trace ran, so there is no trace report).
    Cached(Vec<FieldPsf>),
    /// Traced now (and stored in the cache when one was given).
    Traced(FieldPsfResponse),
}

/// What `FieldPsfRequest::run_cached` returns.
#[derive(Debug, Clone)]
pub struct CachedRun {
    pub served: Served,
    /// Why freshly traced PSFs could not be stored (the result itself is unaffected).
    pub cache_warning: Option<String>,
}

impl FieldPsfRequest {
    /// The cache key of this request's PSFs of `lens`: the lens's fingerprint and `key_bytes`.
    pub fn cache_key(&self, lens: &Lens) -> PsfResult<String> {
        let lens_sha256 = crate::cache::lens_fingerprint(lens);
        Ok(PsfCache::key(&[
            b"field",
            lens_sha256.as_bytes(),
            &self.key_bytes(lens)?,
        ]))
    }

    /// `run` through `cache` when one is given: a hit serves the stored PSFs without tracing; a miss
    /// traces and stores them (a store that fails costs the next run time, not this one its result:
    /// `cache_warning`).
    pub fn run_cached(&self, lens: &Lens, cache: Option<&PsfCache>) -> PsfResult<CachedRun> {
        let key = cache.map(|_| self.cache_key(lens)).transpose()?;
        if let (Some(cache), Some(key)) = (cache, &key) {
            if let Some(psfs) = cache.load(key).filter(|p| p.len() == self.fields_deg.len()) {
                return Ok(CachedRun {
                    served: Served::Cached(psfs),
                    cache_warning: None,
                });
            }
        }
        let traced = self.run(lens)?;
        let cache_warning = match (cache, &key) {
            (Some(cache), Some(key)) => cache
                .store(key, &traced.psfs)
                .err()
                .map(|error| format!("PSF cache {}: {error}", cache.dir.display())),
            _ => None,
        };
        Ok(CachedRun {
            served: Served::Traced(traced),
            cache_warning,
        })
    }
}

/// What is known of one traced field PSF besides its samples: the keys of `unicac psf --json` without
/// `lens`, `out` and the cache's, and of Python's `Psf.metadata()`.
#[derive(Debug, Clone, Serialize)]
pub struct PsfMetadata {
    pub mode: PsfMode,
    pub field_deg: f64,
    /// The field's x angle (deg), when it has one (a lens that is not rotationally symmetric).
    #[serde(skip_serializing_if = "unicac_io::serde_skip::is_zero")]
    pub field_x_deg: f64,
    pub pixel_um: f64,
    pub kernel_px: usize,
    pub wavelengths_um: Vec<f64>,
    pub skipped_wavelengths_um: Vec<f64>,
    /// "R", "G", "B", or "Y" for a monochromatic PSF, one per kernel.
    pub channels: Vec<&'static str>,
    pub reference_mm: [f64; 2],
    pub transmission: f64,
    pub energy_cut: Vec<f64>,
    pub rays_traced: usize,
}

impl PsfMetadata {
    pub fn new(mode: PsfMode, psf: &FieldPsf, pixel_um: f64, weights: &SpectralWeights) -> PsfMetadata {
        PsfMetadata {
            mode,
            field_deg: psf.field_deg,
            field_x_deg: psf.field_x_deg,
            pixel_um,
            kernel_px: psf.kernels.first().map_or(0, |k| k.size),
            wavelengths_um: weights.wavelengths_um.clone(),
            skipped_wavelengths_um: weights.skipped_um.clone(),
            channels: if psf.kernels.len() == 1 {
                vec!["Y"]
            } else {
                vec!["R", "G", "B"]
            },
            reference_mm: psf.reference_mm,
            transmission: psf.transmission,
            energy_cut: psf.energy_cut.clone(),
            rays_traced: psf.rays_traced,
        }
    }
}

/// The JSON sidecar and `--json` report of `unicac psf`.
#[derive(Debug, Clone, Serialize)]
pub struct PsfReport {
    pub lens: String,
    #[serde(flatten)]
    pub metadata: PsfMetadata,
    /// SHA-256 of the lens model (the PSF cache's key starts with it).
    pub lens_sha256: String,
    pub from_cache: bool,
    pub out: String,
}
