//! Wave-optics (diffraction) PSFs: the exit-pupil wavefront from traced optical path lengths, and its
//! Fraunhofer diffraction pattern at the sensor, in the same `Kernel` form as the geometric PSFs.
//!
//! # Method
//!
//! 1. **Pupil grid.** For one field angle and wavelength, an N x N square grid of cell centres
//!    (px, py) = -1 + (i + 1/2) 2/N over the entrance pupil is traced with paraxial aiming (Zemax "ray
//!    aiming off", as the geometric PSF) and with its optical path length (`trace_with_opl`). Points
//!    outside the unit disc, and rays that fail (clipped, missed, TIR...), get amplitude 0. A square
//!    grid is what both Fourier transforms below need; uniform entrance-pupil points carry equal power,
//!    so the amplitude of an arriving ray is 1 (no apodisation). For an object at infinity the rays
//!    start on the tilted entrance-pupil plane, not on one incoming wavefront, so each ray's OPL gets
//!    n0 (start . d) added: the path from a common plane wavefront through the origin.
//! 2. **Reference sphere.** Centred on the image point P (`reference_mm` on the image surface: the
//!    primary-wavelength real chief ray's intercept, exactly as the geometric PSF is centred), passing
//!    through the paraxial exit-pupil centre E (on the axis at `exit_pupil_z_mm`, primary wavelength);
//!    radius R = |P - E|. Each ray is stepped back from its image-surface intercept Q along its
//!    direction d to the sphere, |Q - s d - P| = R, root s = w.d + sqrt((w.d)^2 - |w|^2 + R^2)
//!    (w = Q - P; the root near +R, or near -R with the other sign when the exit pupil lies behind the
//!    image), and n' s is subtracted from its OPL. The OPD is that minus the same quantity for the
//!    chief ray of this wavelength (pupil centre, traced explicitly and without clipping; if even that
//!    fails, the mean over the pupil is used: piston does not change the PSF). W = OPD / lambda waves.
//!    Sign: W > 0 where a ray has travelled a longer optical path to the sphere, i.e. where the wavefront
//!    lags the reference sphere; an image plane a distance dz behind a perfect focus gives
//!    W = -dz (1 - cos theta) < 0 at the pupil edge (theta the image-space ray angle).
//!    Why a sphere on the reference point: a wavefront converging on P is then flat (W = 0), so the
//!    pupil function is smooth and needs few samples; the lateral colour of other wavelengths and any
//!    offset from P appear as tilt, i.e. as a shifted PSF, which is what the kernel must show.
//! 3. **Pupil function** P = A exp(2 pi i W) at exit-pupil coordinates xi = (px, py) R_xp, R_xp the
//!    paraxial exit-pupil radius: the paraxial pupil mapping, as Zemax's FFT PSF uses (pupil distortion
//!    and the real exit pupil's shape are ignored; the sign of the pupil magnification is taken from the
//!    traced rays' sphere points, +1 in any ordinary lens).
//! 4. **Diffraction.** U(x, y) = sum P(xi, eta) exp(-2 pi i (xi x + eta y) / (lambda' R)) with
//!    lambda' = lambda / n' the wavelength in image space, x, y the offset from P on the image plane
//!    (treated as perpendicular to the axis; no obliquity factor, as in Zemax's FFT PSF). PSF = |U|^2.
//!    It is evaluated at K x K points (K = kernel size x `oversample`) at pitch delta = pixel /
//!    `oversample`, the sub-cell centres of the kernel's pixels, centred on P. Two evaluations:
//!    - the **matrix Fourier transform** (MFT): U = A_y P A_x^T with A_x[k][i] =
//!      exp(-2 pi i xi_i x_k / (lambda' R)), i.e. a direct (chirp-z / Huygens-style) evaluation at exactly
//!      the points wanted, at any pitch, for N^2 K + K^2 N complex multiply-adds;
//!    - the **FFT** (rustfft), zero-padded to M >= 2N: its natural sampling is lambda' R / (M dxi)
//!      (dxi = 2 R_xp / N), so it only serves when that equals delta; it is used when M = lambda' R /
//!      (dxi delta) is an integer to 1e-9 relative (and M >= K), otherwise the MFT is. With the
//!      half-sample offset of the kernel grid folded into a linear phase on the pupil, both give the
//!      same numbers (tested to 1e-6).
//!
//!    The kernel's pixel (box aperture, as the geometric rasteriser) sums its `oversample^2` sub-cell
//!    samples (midpoint rule). Orientation as the geometric kernels: columns = sensor +x, rows run
//!    towards sensor -y.
//! 5. **Energy.** By Parseval, the discrete U has energy (lambda' R / dxi)^2 sum |P|^2 over one period;
//!    each wavelength's kernel is scaled so that the whole plane would hold the fraction of pupil rays
//!    that arrived (the transmission, as the geometric kernels), so the kernel's sum before
//!    normalisation is transmission x fraction inside the window, and `energy_cut` is comparable to the
//!    geometric one.
//! 6. **Sampling.** The discrete pupil makes the PSF periodic with period lambda' R / dxi = lambda' N_w N
//!    (N_w the working F/#): the alias-free window. A wavefront step of |dW| between neighbouring pupil
//!    samples corresponds to a ray landing |dW| periods from P, so max |dW| > 0.5 wave means part of
//!    the light would land outside the window and fold back (aliasing): the wavefront is reported as
//!    `undersampled`, and so is a kernel wider than the period. The default N = 128 (`DEFAULT_PUPIL_GRID`)
//!    resolves tilts and aberrations up to 32 waves across the pupil radius, gives a window of
//!    lambda' N_w 128 (e.g. 376 um at F/5, 0.59 um: a 75-pixel kernel at 5 um), and costs 12,900 rays
//!    and about 6 M complex multiply-adds per wavelength for a 41 px kernel at oversample 4; the flags
//!    say when a lens needs more.
//! 7. **Spectrum.** As `PsfTracer::kernels_from_hits`: one kernel per wavelength of `SpectralWeights`,
//!    summed with the channel weights into R, G, B (or one kernel when monochromatic), each normalised
//!    to sum 1.

use crate::error::{PsfError, PsfResult};
use crate::geometric::{ChiefReference, FieldPsf};
use crate::kernel::Kernel;
use crate::spectrum::{combine_channels, SpectralWeights};
use rayon::prelude::*;
use rustfft::num_complex::Complex64;
use rustfft::FftPlanner;
use serde::Serialize;
use std::f64::consts::PI;
use unicac_optics::{Lens, Profile};
use unicac_trace::{check_at_least, Aimer, Aiming, Clipping, Ray, RayStatus, StatusCounts, TraceSystem};

/// Default pupil samples per axis (reasons in the module docs, item 6).
pub const DEFAULT_PUPIL_GRID: usize = 128;

/// Largest wavefront step between neighbouring pupil samples (waves) before `undersampled` is set.
pub const MAX_STEP_WAVES: f64 = 0.5;

/// Relative tolerance within which the FFT's natural pitch must equal the requested one.
pub const FFT_PITCH_TOLERANCE: f64 = 1e-9;

/// Largest FFT size the FFT path takes on (beyond, the MFT is cheaper anyway).
pub const MAX_FFT_SIZE: usize = 8192;

/// Which evaluation of the diffraction integral to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Transform {
    /// The FFT when its natural sampling matches the requested pitch, else the MFT.
    #[default]
    Auto,
    /// Always the matrix Fourier transform.
    Mft,
}

/// Fidelity knobs of a wave PSF.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WavePsfSettings {
    /// Pupil samples per axis (N).
    pub pupil_grid: usize,
    /// Diffraction-pattern samples per pixel and axis (the pixel integration's sub-cells).
    pub oversample: usize,
    /// Sensor pixel pitch.
    pub pixel_um: f64,
    pub transform: Transform,
}

impl WavePsfSettings {
    pub fn new(pixel_um: f64) -> WavePsfSettings {
        WavePsfSettings {
            pupil_grid: DEFAULT_PUPIL_GRID,
            oversample: 4,
            pixel_um,
            transform: Transform::Auto,
        }
    }
}

/// The exit-pupil wavefront of one field at one wavelength, on the N x N pupil grid.
#[derive(Debug, Clone, Serialize)]
pub struct Wavefront {
    pub field_deg: f64,
    pub wavelength_um: f64,
    /// Samples per axis (N).
    pub grid: usize,
    /// OPD in waves, row-major `[iy * grid + ix]`, at pupil point (`coordinate(ix)`, `coordinate(iy)`)
    /// (+y up, as the pupil). 0 where `amplitude` is 0; never NaN.
    #[serde(skip)]
    pub opd_waves: Vec<f64>,
    /// 1 where a ray inside the unit disc arrived, else 0.
    #[serde(skip)]
    pub amplitude: Vec<f64>,
    /// RMS of the OPD about its mean (piston removed; tilt kept, as it is relative to the reference
    /// point), over the arriving rays.
    pub rms_waves: f64,
    pub pv_waves: f64,
    /// Largest |W| difference between horizontally or vertically neighbouring arriving samples.
    pub max_step_waves: f64,
    /// `max_step_waves > MAX_STEP_WAVES`: the grid is too coarse for this wavefront (module docs, 6).
    pub undersampled: bool,
    /// Outcomes of the rays inside the unit disc (the chief ray is not counted).
    pub counts: StatusCounts,
    /// Fraction of the rays inside the disc that arrived.
    pub transmission: f64,
    /// Whether the chief ray arrived (else the OPD is relative to the pupil mean).
    pub chief_ok: bool,
    /// Reference-sphere radius, signed: positive when the image lies after the exit pupil.
    pub reference_radius_mm: f64,
    /// Paraxial exit-pupil radius (the pupil mapping's scale).
    pub exit_pupil_radius_mm: f64,
    /// Sign of the pupil magnification (+1 unless the exit pupil is an inverted image).
    pub pupil_sign: f64,
    /// Refractive index of image space.
    pub image_index: f64,
    /// Period of the sampled PSF, lambda' |R| / dxi: the alias-free window (um).
    pub period_um: f64,
}

impl Wavefront {
    /// Normalised pupil coordinate of grid index `i`.
    pub fn coordinate(&self, i: usize) -> f64 {
        grid_coordinate(i, self.grid)
    }

    pub fn at(&self, ix: usize, iy: usize) -> f64 {
        self.opd_waves[iy * self.grid + ix]
    }

    /// Exit-pupil sample spacing dxi (mm).
    fn spacing_mm(&self) -> f64 {
        2.0 * self.exit_pupil_radius_mm / self.grid as f64
    }

    /// lambda' |R| (um x mm): the Fourier kernel's scale.
    fn scale(&self) -> f64 {
        self.wavelength_um / self.image_index * self.reference_radius_mm.abs()
    }
}

fn grid_coordinate(i: usize, n: usize) -> f64 {
    -1.0 + (i as f64 + 0.5) * 2.0 / n as f64
}

/// How one wavelength's kernel was sampled.
#[derive(Debug, Clone, Serialize)]
pub struct WaveSampling {
    pub wavelength_um: f64,
    pub rms_waves: f64,
    pub pv_waves: f64,
    pub max_step_waves: f64,
    /// The wavefront is undersampled or the kernel is wider than the period (aliasing either way).
    pub undersampled: bool,
    pub transmission: f64,
    pub period_um: f64,
    /// Kernel width (size x pixel pitch).
    pub window_um: f64,
    /// The FFT size whose natural pitch equals the requested sub-pixel pitch (usually not an integer).
    pub fft_size_for_pitch: f64,
    /// The FFT's natural pitch lambda' R / (M dxi) at `fft_size` (the next power of two >= 2N and >= K).
    pub fft_natural_pitch_um: f64,
    pub fft_size: usize,
    /// Whether this kernel came from the FFT (else the MFT).
    pub fft_used: bool,
    /// Fraction of the arriving energy inside the kernel window.
    pub energy_in_window: f64,
}

/// Wave-optics R, G, B kernels of one field, with the sampling report of every wavelength.
#[derive(Debug, Clone, Serialize)]
pub struct WaveFieldPsf {
    pub psf: FieldPsf,
    pub sampling: Vec<WaveSampling>,
    /// Any wavelength undersampled (raise `pupil_grid`).
    pub undersampled: bool,
}

/// One wavelength, prepared: clipped system for the pupil rays, unclipped one for the chief ray.
struct Channel {
    wavelength_um: f64,
    clipped: TraceSystem,
    unclipped: TraceSystem,
    aimer: Aimer,
}

impl Channel {
    fn new(lens: &Lens, wavelength_um: f64) -> PsfResult<Channel> {
        Ok(Channel {
            wavelength_um,
            clipped: TraceSystem::new(lens, wavelength_um, Clipping::Apertures)?,
            unclipped: TraceSystem::new(lens, wavelength_um, Clipping::None)?,
            aimer: Aimer::new(lens, wavelength_um, Aiming::Auto)?,
        })
    }
}

/// Primary-wavelength pupil and image-surface data shared by all wavelengths.
#[derive(Debug, Clone, Copy)]
struct Geometry {
    exit_pupil_z_mm: f64,
    exit_pupil_radius_mm: f64,
    image_z_mm: f64,
    image_profile: Profile,
    infinite_object: bool,
}

/// Traces wave-optics PSFs of one lens: one prepared system per wavelength, built once.
pub struct WavePsfTracer {
    settings: WavePsfSettings,
    weights: SpectralWeights,
    channels: Vec<Channel>,
    reference: ChiefReference,
    geometry: Geometry,
    lens: Lens,
}

impl WavePsfTracer {
    pub fn new(lens: &Lens, weights: SpectralWeights, settings: WavePsfSettings) -> PsfResult<WavePsfTracer> {
        crate::geometric::check_pixel_um(settings.pixel_um)?;
        check_at_least("oversample", settings.oversample, 1)?;
        check_at_least("pupil_grid", settings.pupil_grid, 4)?;
        let first = lens.first_order()?;
        let (Some(exit_pupil_z_mm), Some(diameter)) = (first.exit_pupil_z_mm, first.exit_pupil_diameter_mm)
        else {
            return Err(PsfError::Unsupported(
                "the exit pupil is at infinity (image-space telecentric): wave PSFs need a finite \
                 reference sphere"
                    .into(),
            ));
        };
        if !(diameter > 0.0 && diameter.is_finite() && exit_pupil_z_mm.is_finite()) {
            return Err(PsfError::Unsupported(format!(
                "unusable paraxial exit pupil (diameter {diameter} mm at z = {exit_pupil_z_mm} mm)"
            )));
        }
        let image = lens.surfaces.last().expect("a lens has an image surface");
        let geometry = Geometry {
            exit_pupil_z_mm,
            exit_pupil_radius_mm: diameter / 2.0,
            image_z_mm: image.z_mm,
            image_profile: image.profile,
            infinite_object: lens.object_distance_mm.is_none(),
        };
        let channels = weights
            .wavelengths_um
            .iter()
            .map(|&w| Channel::new(lens, w))
            .collect::<PsfResult<Vec<_>>>()?;
        let reference = ChiefReference::new(lens)?;
        Ok(WavePsfTracer {
            settings,
            weights,
            channels,
            reference,
            geometry,
            lens: lens.clone(),
        })
    }

    pub fn settings(&self) -> &WavePsfSettings {
        &self.settings
    }

    pub fn weights(&self) -> &SpectralWeights {
        &self.weights
    }

    /// The primary-wavelength real chief ray's intercept (as `PsfTracer::reference_point_mm`).
    pub fn reference_point_mm(&self, field_deg: f64) -> PsfResult<[f64; 2]> {
        self.reference.point_mm(field_deg)
    }

    /// The wavefront of field `field_deg` at any wavelength, relative to the sphere on `reference_mm`.
    pub fn wavefront(
        &self,
        field_deg: f64,
        wavelength_um: f64,
        reference_mm: [f64; 2],
    ) -> PsfResult<Wavefront> {
        let channel = match self.channels.iter().find(|c| c.wavelength_um == wavelength_um) {
            Some(c) => return Ok(self.trace_wavefront(c, field_deg, reference_mm)),
            None => Channel::new(&self.lens, wavelength_um)?,
        };
        Ok(self.trace_wavefront(&channel, field_deg, reference_mm))
    }

    /// R, G, B kernels of `size` pixels (or one kernel when `monochromatic`) centred on `reference_mm`.
    pub fn field_psf(
        &self,
        field_deg: f64,
        reference_mm: [f64; 2],
        size: usize,
        monochromatic: bool,
    ) -> PsfResult<FieldPsf> {
        Ok(self
            .field_psf_detailed(field_deg, reference_mm, size, monochromatic)?
            .psf)
    }

    /// `field_psf` with each wavelength's sampling report.
    pub fn field_psf_detailed(
        &self,
        field_deg: f64,
        reference_mm: [f64; 2],
        size: usize,
        monochromatic: bool,
    ) -> PsfResult<WaveFieldPsf> {
        let size = size | 1;
        let per_wavelength: Vec<(Kernel, WaveSampling, usize)> = self
            .channels
            .par_iter()
            .map(|channel| {
                let wavefront = self.trace_wavefront(channel, field_deg, reference_mm);
                let (kernel, sampling) = self.monochromatic_kernel(&wavefront, size);
                (kernel, sampling, wavefront.counts.total() + 1)
            })
            .collect();
        let rays_traced = per_wavelength.iter().map(|p| p.2).sum();
        if per_wavelength.iter().all(|p| p.1.transmission == 0.0) {
            return Err(PsfError::FieldVignetted {
                field_deg,
                rays_traced,
            });
        }
        let channels = if monochromatic { 1 } else { 3 };
        let kernel_refs: Vec<&Kernel> = per_wavelength.iter().map(|p| &p.0).collect();
        let arrived: Vec<f64> = per_wavelength.iter().map(|p| p.1.transmission).collect();
        let (kernels, energy_cut, transmission) =
            combine_channels(&kernel_refs, &arrived, &self.weights, channels);
        let sampling: Vec<WaveSampling> = per_wavelength.into_iter().map(|p| p.1).collect();
        Ok(WaveFieldPsf {
            undersampled: sampling.iter().any(|s| s.undersampled),
            sampling,
            psf: FieldPsf {
                field_deg,
                field_x_deg: 0.0,
                reference_mm,
                kernels,
                transmission,
                energy_cut,
                rays_traced,
            },
        })
    }

    /// Traces the pupil grid and the chief ray of one wavelength (module docs, items 1-2).
    fn trace_wavefront(&self, channel: &Channel, field_deg: f64, reference_mm: [f64; 2]) -> Wavefront {
        let n = self.settings.pupil_grid;
        let g = &self.geometry;
        let system = &channel.clipped;
        let last = system.image_index();
        let image_index = match last {
            0 => system.object_index,
            _ => system.surfaces[last - 1].index_after,
        };
        let sag = g
            .image_profile
            .sag(reference_mm[0] * reference_mm[0] + reference_mm[1] * reference_mm[1]);
        let centre = [
            reference_mm[0],
            reference_mm[1],
            g.image_z_mm + if sag.is_finite() { sag } else { 0.0 },
        ];
        let axial = centre[2] - g.exit_pupil_z_mm;
        let radius = (centre[0] * centre[0] + centre[1] * centre[1] + axial * axial).sqrt();
        let sigma = if axial >= 0.0 { 1.0 } else { -1.0 };
        // Path from the common incoming wavefront to the ray's start (objects at infinity, item 1).
        let object_path = |ray: &Ray| {
            if g.infinite_object {
                system.object_index * dot(ray.position_mm, ray.direction)
            } else {
                0.0
            }
        };
        // Steps back from the image-surface intercept to the reference sphere: (s, transverse point).
        let to_sphere = |ray: &Ray| -> Option<(f64, [f64; 2])> {
            let w = [0, 1, 2].map(|k| ray.position_mm[k] - centre[k]);
            let b = dot(w, ray.direction);
            let discriminant = b * b - dot(w, w) + radius * radius;
            if discriminant.is_nan() || discriminant < 0.0 {
                return None;
            }
            let s = b + sigma * discriminant.sqrt();
            Some((
                s,
                [
                    ray.position_mm[0] - s * ray.direction[0],
                    ray.position_mm[1] - s * ray.direction[1],
                ],
            ))
        };
        // OPL from the incoming wavefront to the reference sphere, if the ray gets there.
        let path_to_sphere = |system: &TraceSystem, aimed: Option<Ray>| -> (RayStatus, f64, [f64; 2]) {
            let Some(mut ray) = aimed else {
                return (RayStatus::InvalidInput, 0.0, [0.0; 2]);
            };
            let start = object_path(&ray);
            let (status, opl) = system.trace_with_opl(&mut ray);
            if !status.is_ok() {
                return (status, 0.0, [0.0; 2]);
            }
            match to_sphere(&ray) {
                Some((s, point)) => (RayStatus::Ok, start + opl - image_index * s, point),
                None => (RayStatus::Missed { surface: last as u32 }, 0.0, [0.0; 2]),
            }
        };

        let mut raw = vec![0.0; n * n];
        let mut amplitude = vec![0.0; n * n];
        let mut counts = StatusCounts::default();
        let mut orientation = 0.0;
        // The grid's points in the disc, aimed together (a real-aimed lens then pays one aiming map, not
        // a Newton solve per point), in the order the loop below takes them.
        let in_disc: Vec<[f64; 2]> = (0..n)
            .flat_map(|iy| (0..n).map(move |ix| [grid_coordinate(ix, n), grid_coordinate(iy, n)]))
            .filter(|[px, py]| px * px + py * py <= 1.0)
            .collect();
        let mut aimed = channel.aimer.rays(field_deg, &in_disc).into_iter();
        for iy in 0..n {
            let py = grid_coordinate(iy, n);
            for ix in 0..n {
                let px = grid_coordinate(ix, n);
                if px * px + py * py > 1.0 {
                    continue;
                }
                let ray = aimed.next().and_then(Result::ok);
                let (status, path, point) = path_to_sphere(system, ray);
                counts.add(status);
                if status.is_ok() && path.is_finite() {
                    raw[iy * n + ix] = path;
                    amplitude[iy * n + ix] = 1.0;
                    orientation += point[0] * px + point[1] * py;
                }
            }
        }
        let arrived = amplitude.iter().filter(|&&a| a > 0.0).count();
        let chief = channel.aimer.ray(field_deg, 0.0, 0.0).ok();
        let (chief_status, chief_path, _) = path_to_sphere(&channel.unclipped, chief);
        let chief_ok = chief_status.is_ok() && chief_path.is_finite();
        let piston = if chief_ok {
            chief_path
        } else if arrived > 0 {
            raw.iter()
                .zip(&amplitude)
                .filter(|(_, &a)| a > 0.0)
                .map(|(r, _)| r)
                .sum::<f64>()
                / arrived as f64
        } else {
            0.0
        };
        let waves_per_mm = 1e3 / channel.wavelength_um;
        let opd_waves: Vec<f64> = raw
            .iter()
            .zip(&amplitude)
            .map(|(r, &a)| if a > 0.0 { (r - piston) * waves_per_mm } else { 0.0 })
            .collect();

        let (mut sum, mut sum2, mut min, mut max) = (0.0, 0.0, f64::INFINITY, f64::NEG_INFINITY);
        let mut max_step: f64 = 0.0;
        for iy in 0..n {
            for ix in 0..n {
                let k = iy * n + ix;
                if amplitude[k] == 0.0 {
                    continue;
                }
                let w = opd_waves[k];
                sum += w;
                sum2 += w * w;
                min = min.min(w);
                max = max.max(w);
                if ix + 1 < n && amplitude[k + 1] > 0.0 {
                    max_step = max_step.max((opd_waves[k + 1] - w).abs());
                }
                if iy + 1 < n && amplitude[k + n] > 0.0 {
                    max_step = max_step.max((opd_waves[k + n] - w).abs());
                }
            }
        }
        let (rms_waves, pv_waves) = if arrived > 0 {
            let mean = sum / arrived as f64;
            ((sum2 / arrived as f64 - mean * mean).max(0.0).sqrt(), max - min)
        } else {
            (0.0, 0.0)
        };
        let inside = counts.total();
        let spacing = 2.0 * g.exit_pupil_radius_mm / n as f64;
        Wavefront {
            field_deg,
            wavelength_um: channel.wavelength_um,
            grid: n,
            opd_waves,
            amplitude,
            rms_waves,
            pv_waves,
            max_step_waves: max_step,
            undersampled: max_step > MAX_STEP_WAVES,
            counts,
            transmission: if inside > 0 {
                arrived as f64 / inside as f64
            } else {
                0.0
            },
            chief_ok,
            reference_radius_mm: sigma * radius,
            exit_pupil_radius_mm: g.exit_pupil_radius_mm,
            pupil_sign: if orientation < 0.0 { -1.0 } else { 1.0 },
            image_index,
            period_um: channel.wavelength_um / image_index * radius / spacing,
        }
    }

    /// One wavelength's kernel of `size` (odd) pixels from its wavefront, not normalised: its sum is
    /// the transmission times the fraction of the energy inside the window (module docs, items 3-5).
    pub fn monochromatic_kernel(&self, wavefront: &Wavefront, size: usize) -> (Kernel, WaveSampling) {
        let size = size | 1;
        let n = wavefront.grid;
        let oversample = self.settings.oversample;
        let fine = size * oversample;
        let pitch = self.settings.pixel_um / oversample as f64;
        let spacing = wavefront.spacing_mm();
        let scale = wavefront.scale();

        // Pupil function, re-indexed so that the Fourier coordinate increases with the index: the
        // pupil magnification's sign and the sphere's side flip it (module docs, item 3).
        let flip = wavefront.pupil_sign * wavefront.reference_radius_mm.signum() < 0.0;
        let index = |i: usize| if flip { n - 1 - i } else { i };
        let mut pupil = vec![Complex64::new(0.0, 0.0); n * n];
        for j in 0..n {
            for i in 0..n {
                let k = index(j) * n + index(i);
                if wavefront.amplitude[k] > 0.0 {
                    pupil[j * n + i] =
                        Complex64::from_polar(wavefront.amplitude[k], 2.0 * PI * wavefront.opd_waves[k]);
                }
            }
        }

        let fft_size_for_pitch = scale / (spacing * pitch);
        let rounded = fft_size_for_pitch.round();
        let fits = (fft_size_for_pitch - rounded).abs() <= FFT_PITCH_TOLERANCE * fft_size_for_pitch
            && rounded >= (2 * n) as f64
            && rounded >= fine as f64
            && rounded <= MAX_FFT_SIZE as f64;
        let fft_used = fits && self.settings.transform == Transform::Auto;
        let amplitude = if fft_used {
            fft_field(&pupil, n, fine, rounded as usize)
        } else {
            let xi: Vec<f64> = (0..n)
                .map(|i| grid_coordinate(i, n) * wavefront.exit_pupil_radius_mm)
                .collect();
            let x: Vec<f64> = (0..fine)
                .map(|k| (k as f64 + 0.5 - fine as f64 / 2.0) * pitch)
                .collect();
            mft_field(&pupil, n, &xi, &x, scale)
        };

        // Energy normalisation (item 5): sum |U|^2 delta^2 over the plane = (scale / dxi)^2 sum |P|^2.
        let inside = wavefront.counts.total().max(1) as f64;
        let normalisation = (pitch * spacing / scale).powi(2) / inside;
        let mut kernel = Kernel::zeros(size, self.settings.pixel_um);
        for row in 0..size {
            for col in 0..size {
                let mut sum = 0.0;
                for sy in 0..oversample {
                    // Kernel rows run towards -y: fine row t from the top is natural row fine-1-t.
                    let b = fine - 1 - (row * oversample + sy);
                    let line = &amplitude[b * fine + col * oversample..b * fine + (col + 1) * oversample];
                    sum += line.iter().map(|u| u.norm_sqr()).sum::<f64>();
                }
                kernel.data[row * size + col] = (sum * normalisation) as f32;
            }
        }
        let kernel_sum = kernel.sum();
        let window_um = size as f64 * self.settings.pixel_um;
        let fft_size = (2 * n).max(fine).next_power_of_two();
        let sampling = WaveSampling {
            wavelength_um: wavefront.wavelength_um,
            rms_waves: wavefront.rms_waves,
            pv_waves: wavefront.pv_waves,
            max_step_waves: wavefront.max_step_waves,
            undersampled: wavefront.undersampled || window_um > wavefront.period_um,
            transmission: wavefront.transmission,
            period_um: wavefront.period_um,
            window_um,
            fft_size_for_pitch,
            fft_natural_pitch_um: scale / (fft_size as f64 * spacing),
            fft_size,
            fft_used,
            energy_in_window: if wavefront.transmission > 0.0 {
                kernel_sum / wavefront.transmission
            } else {
                0.0
            },
        };
        (kernel, sampling)
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Matrix Fourier transform: U[b][a] = sum_j sum_i P[j][i] exp(-2 pi i (xi_i x_a + xi_j x_b) / scale),
/// evaluated as (A P A^T) with A[a][i] = exp(-2 pi i xi_i x_a / scale). Rows of the result follow +y.
fn mft_field(pupil: &[Complex64], n: usize, xi: &[f64], x: &[f64], scale: f64) -> Vec<Complex64> {
    let k = x.len();
    let zero = Complex64::new(0.0, 0.0);
    let a: Vec<Complex64> = x
        .iter()
        .flat_map(|&xa| {
            xi.iter()
                .map(move |&xii| Complex64::from_polar(1.0, -2.0 * PI * xii * xa / scale))
        })
        .collect();
    // T[j][a] = sum_i P[j][i] A[a][i]; rows of P outside the disc stay zero.
    let mut t = vec![zero; n * k];
    let mut live = vec![false; n];
    t.par_chunks_mut(k)
        .zip(live.par_iter_mut())
        .enumerate()
        .for_each(|(j, (row_t, live))| {
            let row = &pupil[j * n..(j + 1) * n];
            let Some(first) = row.iter().position(|p| *p != zero) else {
                return;
            };
            let end = n - row.iter().rev().position(|p| *p != zero).unwrap_or(0);
            *live = true;
            for (ta, a_row) in row_t.iter_mut().zip(a.chunks_exact(n)) {
                *ta = row[first..end]
                    .iter()
                    .zip(&a_row[first..end])
                    .fold(zero, |acc, (p, w)| acc + p * w);
            }
        });
    // U[b][a] = sum_j A[b][j] T[j][a].
    let mut u = vec![zero; k * k];
    u.par_chunks_mut(k).enumerate().for_each(|(b, row_u)| {
        for j in (0..n).filter(|&j| live[j]) {
            let c = a[b * n + j];
            for (ua, ta) in row_u.iter_mut().zip(&t[j * k..(j + 1) * k]) {
                *ua += c * ta;
            }
        }
    });
    u
}

/// The same field by an M x M FFT whose natural pitch equals the sample pitch: the fine grid starts at
/// x_0 = (1/2 - K/2) delta, folded in as the linear phase exp(-2 pi i (i + j) x_0 / (M delta)) on the
/// pupil (the remaining phase factor has modulus 1 and drops out of |U|^2).
fn fft_field(pupil: &[Complex64], n: usize, k: usize, m: usize) -> Vec<Complex64> {
    let zero = Complex64::new(0.0, 0.0);
    let offset = 0.5 - k as f64 / 2.0;
    let ramp: Vec<Complex64> = (0..n)
        .map(|i| Complex64::from_polar(1.0, -2.0 * PI * i as f64 * offset / m as f64))
        .collect();
    let fft = FftPlanner::new().plan_fft_forward(m);
    // Rows (x) of the n pupil rows; the padded rows are zero and stay zero.
    let mut rows = vec![zero; n * m];
    rows.par_chunks_mut(m).enumerate().for_each(|(j, row)| {
        for i in 0..n {
            row[i] = pupil[j * n + i] * ramp[i] * ramp[j];
        }
        fft.process(row);
    });
    // Columns (y), keeping the first k outputs of each of the first k columns.
    let columns: Vec<Vec<Complex64>> = (0..k)
        .into_par_iter()
        .map(|a| {
            let mut column = vec![zero; m];
            for j in 0..n {
                column[j] = rows[j * m + a];
            }
            fft.process(&mut column);
            column.truncate(k);
            column
        })
        .collect();
    let mut u = vec![zero; k * k];
    for (a, column) in columns.iter().enumerate() {
        for (b, value) in column.iter().enumerate() {
            u[b * k + a] = *value;
        }
    }
    u
}
