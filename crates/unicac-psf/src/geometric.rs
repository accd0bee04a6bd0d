//! Geometric PSFs: rays through the entrance pupil land on the image surface and are rasterised at
//! the sensor pitch.
//!
//! Reference point: every wavelength's PSF of a field is placed relative to the **primary-wavelength
//! real chief ray** (aimed at the stop centre). Lateral colour therefore stays in the R, G, B kernels
//! (it is a blur the restoration network must undo), while distortion (the chief ray's displacement
//! from the ideal image point) is left out of the kernels and applied by the simulator as a geometric
//! warp, where it costs one resampling instead of huge, mostly empty kernels.
//!
//! Orientation: kernel columns follow sensor +x; kernel rows follow image rows, which run towards
//! sensor -y (the sensor's +y is up, image rows go down).

use crate::error::{PsfError, PsfResult};
use crate::hit_tracer::RayBackend;
use crate::kernel::{size_for_fraction, Kernel, Rasteriser};
use crate::spectrum::{combine_channels, SpectralWeights};
use serde::{Deserialize, Serialize};
use unicac_optics::Lens;
use unicac_trace::{
    check_at_least, check_odd, Aimer, Aiming, Clipping, PupilSampling, StatusCounts, TraceSystem,
};

/// Largest kernel a caller may ask for (`PsfSettings::with_kernel_cap`): 4095^2 f32 samples are 64 MiB
/// per channel.
pub const KERNEL_PX_LIMIT: usize = 4095;

/// Smallest pixel pitch (um): a thousandth of a micrometre, far below any wavelength (finer sampling
/// than this resolves nothing and sizes kernels beyond any count).
pub const MIN_PIXEL_UM: f64 = 1e-3;
/// Largest pixel pitch (um): 10 cm, beyond any sensor's pixel (a tiny image over a large field).
pub const MAX_PIXEL_UM: f64 = 1e5;

/// A pixel pitch, checked: finite and within [`MIN_PIXEL_UM`, `MAX_PIXEL_UM`].
pub fn check_pixel_um(pixel_um: f64) -> Result<f64, unicac_trace::InvalidParameter> {
    if !(MIN_PIXEL_UM..=MAX_PIXEL_UM).contains(&pixel_um) {
        return Err(unicac_trace::InvalidParameter::new(
            "pixel_um",
            format!("{pixel_um:?}: the pixel pitch must lie in [{MIN_PIXEL_UM}, {MAX_PIXEL_UM}] um"),
        ));
    }
    Ok(pixel_um)
}

/// A requested kernel cap, checked: odd and 1..=`KERNEL_PX_LIMIT` pixels.
pub fn check_kernel_cap(max_kernel_px: usize) -> Result<usize, String> {
    if max_kernel_px.is_multiple_of(2) || !(1..=KERNEL_PX_LIMIT).contains(&max_kernel_px) {
        return Err(format!(
            "{max_kernel_px}: expected an odd number of pixels from 1 to {KERNEL_PX_LIMIT}"
        ));
    }
    Ok(max_kernel_px)
}

/// Fidelity knobs of a geometric PSF (defaults from the sweep in docs/performance.md).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PsfSettings {
    pub pupil_sampling: PupilSampling,
    pub aiming: Aiming,
    /// Sub-cells per pixel and axis for the splat.
    pub oversample: usize,
    /// Sensor pixel pitch.
    pub pixel_um: f64,
    /// Energy a kernel must contain when its size is chosen from the spot.
    pub energy_fraction: f64,
    /// Largest kernel size (odd); bigger spots are cut, with a warning naming the lost energy.
    pub max_kernel_px: usize,
    /// Who traces the rays (CPU or GPU), chosen by the face; its description is part of every cache
    /// key built from these settings.
    #[serde(skip)]
    pub backend: RayBackend,
}

impl PsfSettings {
    pub fn new(pixel_um: f64) -> PsfSettings {
        PsfSettings {
            pupil_sampling: PupilSampling::Fibonacci { n: 2048 },
            aiming: Aiming::Auto,
            oversample: 4,
            pixel_um,
            energy_fraction: 0.995,
            max_kernel_px: 127,
            backend: RayBackend::cpu(),
        }
    }

    /// These settings traced by `backend`.
    pub fn with_backend(self, backend: RayBackend) -> PsfSettings {
        PsfSettings { backend, ..self }
    }

    /// These settings, or, given a size, the whole PSF: the kernel sized to hold every ray (energy
    /// fraction 1), capped at `max_kernel_px` (odd) instead of the default 127 px.
    pub fn with_kernel_cap(self, max_kernel_px: Option<usize>) -> PsfSettings {
        match max_kernel_px {
            Some(max_kernel_px) => PsfSettings {
                max_kernel_px,
                energy_fraction: 1.0,
                ..self
            },
            None => self,
        }
    }
}

/// The ray hits of one field at one wavelength, as offsets (um) from the reference point in kernel
/// orientation (x right, y down the rows).
#[derive(Debug, Clone)]
pub struct FieldHits {
    pub wavelength_um: f64,
    pub offsets_um: Vec<[f64; 2]>,
    pub counts: StatusCounts,
}

/// R, G, B (or one monochromatic) kernels of one field.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FieldPsf {
    /// The field's y angle (deg).
    pub field_deg: f64,
    /// Its x angle (deg): 0 for the fields along y that a rotationally symmetric lens needs (and then
    /// left out of the JSON); a lens that is not symmetric has PSFs of their own at any (x, y).
    #[serde(default, skip_serializing_if = "unicac_io::serde_skip::is_zero")]
    pub field_x_deg: f64,
    /// Primary-wavelength real chief ray on the image surface (the kernels' centre).
    pub reference_mm: [f64; 2],
    pub kernels: Vec<Kernel>,
    /// Fraction of traced rays that reached the image, weighted over the spectrum (vignetting).
    pub transmission: f64,
    /// Energy outside the kernel, per channel, before normalisation (non-zero when the size was capped).
    pub energy_cut: Vec<f64>,
    pub rays_traced: usize,
}

/// The primary-wavelength real chief ray (aimed at the stop centre, unclipped): the point every PSF of
/// a field is centred on, by both the geometric and the wave-optics tracers.
pub struct ChiefReference {
    system: TraceSystem,
    aimer: Aimer,
}

impl ChiefReference {
    pub fn new(lens: &Lens) -> PsfResult<ChiefReference> {
        let primary = lens.primary_wavelength_um();
        Ok(ChiefReference {
            system: TraceSystem::new(lens, primary, Clipping::None)?,
            aimer: Aimer::new(lens, primary, Aiming::Real)?,
        })
    }

    /// The chief ray's image-surface intercept, if it arrives.
    pub fn point_mm(&self, field_deg: f64) -> PsfResult<[f64; 2]> {
        self.point_mm_at([0.0, field_deg])
    }

    /// `point_mm` of a 2D field (x, y angles, `Aimer::ray_at`).
    pub fn point_mm_at(&self, field_deg: [f64; 2]) -> PsfResult<[f64; 2]> {
        let mut ray = self.aimer.ray_at(field_deg, 0.0, 0.0)?;
        if !self.system.trace(&mut ray).is_ok() {
            return Err(PsfError::FieldVignetted {
                field_deg: field_deg[1],
                rays_traced: 1,
            });
        }
        Ok([ray.position_mm[0], ray.position_mm[1]])
    }
}

/// Traces PSFs of one lens: one trace system and aimer per wavelength, built once.
pub struct PsfTracer {
    settings: PsfSettings,
    pupil: Vec<[f64; 2]>,
    weights: SpectralWeights,
    systems: Vec<(TraceSystem, Aimer)>,
    reference: ChiefReference,
}

impl PsfTracer {
    pub fn new(lens: &Lens, weights: SpectralWeights, settings: PsfSettings) -> PsfResult<PsfTracer> {
        check_pixel_um(settings.pixel_um)?;
        check_at_least("oversample", settings.oversample, 1)?;
        check_odd("max_kernel_px", settings.max_kernel_px)?;
        let systems = weights
            .wavelengths_um
            .iter()
            .map(|&w| {
                Ok((
                    TraceSystem::new(lens, w, Clipping::Apertures)?,
                    Aimer::new(lens, w, settings.aiming)?,
                ))
            })
            .collect::<PsfResult<Vec<_>>>()?;
        let reference = ChiefReference::new(lens)?;
        Ok(PsfTracer {
            pupil: settings.pupil_sampling.points(),
            settings,
            weights,
            systems,
            reference,
        })
    }

    /// Which device traces the rays ("cpu", "gpu (f32, ...)"): part of a PSF's provenance and cache key.
    pub fn device(&self) -> String {
        self.settings.backend.describe()
    }

    pub fn settings(&self) -> &PsfSettings {
        &self.settings
    }

    pub fn weights(&self) -> &SpectralWeights {
        &self.weights
    }

    /// The primary-wavelength real chief ray's intercept, if it arrives.
    pub fn reference_point_mm(&self, field_deg: f64) -> PsfResult<[f64; 2]> {
        self.reference.point_mm(field_deg)
    }

    /// `reference_point_mm` of a 2D field ([x, y] angles, deg).
    pub fn reference_point_mm_at(&self, field_deg: [f64; 2]) -> PsfResult<[f64; 2]> {
        self.reference.point_mm_at(field_deg)
    }

    /// Hits of every wavelength for one field, relative to `reference_mm`.
    pub fn hits(&self, field_deg: f64, reference_mm: [f64; 2]) -> PsfResult<Vec<FieldHits>> {
        self.hits_at([0.0, field_deg], reference_mm)
    }

    /// `hits` of a 2D field (x, y angles, `Aimer::ray_at`).
    pub fn hits_at(&self, field_deg: [f64; 2], reference_mm: [f64; 2]) -> PsfResult<Vec<FieldHits>> {
        self.systems
            .iter()
            .map(|(system, aimer)| {
                let mut rays: Vec<_> = aimer
                    .rays_at(field_deg, &self.pupil)
                    .into_iter()
                    .filter_map(Result::ok)
                    .collect();
                let statuses = self.settings.backend.trace(system, &mut rays)?;
                let mut counts = StatusCounts::from_statuses(&statuses);
                counts.missed += self.pupil.len() - rays.len();
                let offsets_um = rays
                    .iter()
                    .zip(&statuses)
                    .filter(|(_, s)| s.is_ok())
                    .map(|(r, _)| {
                        [
                            (r.position_mm[0] - reference_mm[0]) * 1e3,
                            -(r.position_mm[1] - reference_mm[1]) * 1e3,
                        ]
                    })
                    .collect();
                Ok(FieldHits {
                    wavelength_um: system.wavelength_um,
                    offsets_um,
                    counts,
                })
            })
            .collect()
    }

    /// An error when no ray of any wavelength arrived: a PSF of such a field is not a zero kernel but no
    /// answer (callers that map a whole sensor may accept dark fields; a single-field PSF may not).
    pub fn require_arrivals(&self, field_deg: f64, hits: &[FieldHits]) -> PsfResult<()> {
        if hits.iter().all(|h| h.offsets_um.is_empty()) {
            return Err(PsfError::FieldVignetted {
                field_deg,
                rays_traced: self.pupil.len() * hits.len(),
            });
        }
        Ok(())
    }

    /// Kernel size (odd, pixels) holding `energy_fraction` of this field's hits, before the cap.
    pub fn kernel_size_for(&self, hits: &[FieldHits]) -> usize {
        hits.iter()
            .map(|h| {
                size_for_fraction(
                    &h.offsets_um,
                    &vec![1.0; h.offsets_um.len()],
                    self.settings.pixel_um,
                    self.settings.energy_fraction,
                )
            })
            .max()
            .unwrap_or(1)
    }

    /// R, G, B kernels of `size` pixels (or a single kernel when `monochromatic`).
    pub fn field_psf(&self, field_deg: f64, size: usize, monochromatic: bool) -> PsfResult<FieldPsf> {
        self.field_psf_at([0.0, field_deg], size, monochromatic)
    }

    /// `field_psf` of a 2D field (x, y angles): what a lens that is not rotationally symmetric needs,
    /// where the PSF at one azimuth does not give the others by rotation. The result's `field_deg` is
    /// the y angle, its `field_x_deg` the x angle.
    pub fn field_psf_at(&self, field_deg: [f64; 2], size: usize, monochromatic: bool) -> PsfResult<FieldPsf> {
        let reference_mm = self.reference.point_mm_at(field_deg)?;
        let hits = self.hits_at(field_deg, reference_mm)?;
        let psf = self.kernels_from_hits(field_deg[1], reference_mm, &hits, size, monochromatic);
        Ok(FieldPsf {
            field_x_deg: field_deg[0],
            ..psf
        })
    }

    pub fn kernels_from_hits(
        &self,
        field_deg: f64,
        reference_mm: [f64; 2],
        hits: &[FieldHits],
        size: usize,
        monochromatic: bool,
    ) -> FieldPsf {
        let size = size.min(self.settings.max_kernel_px) | 1;
        let channels = if monochromatic { 1 } else { 3 };
        let traced = self.pupil.len();
        let mut rasteriser = Rasteriser::new(size, self.settings.pixel_um, self.settings.oversample);
        let per_wavelength: Vec<Kernel> = hits
            .iter()
            .map(|h| {
                let weight = 1.0 / traced as f32;
                rasteriser.rasterise(&h.offsets_um, &vec![weight; h.offsets_um.len()])
            })
            .collect();
        let arrived: Vec<f64> = hits
            .iter()
            .map(|h| h.offsets_um.len() as f64 / traced as f64)
            .collect();
        let kernel_refs: Vec<&Kernel> = per_wavelength.iter().collect();
        let (kernels, energy_cut, transmission) =
            combine_channels(&kernel_refs, &arrived, &self.weights, channels);
        FieldPsf {
            field_deg,
            field_x_deg: 0.0,
            reference_mm,
            kernels,
            transmission,
            energy_cut,
            rays_traced: traced * hits.len(),
        }
    }
}
