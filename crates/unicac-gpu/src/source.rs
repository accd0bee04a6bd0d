//! Where a kernel's rays come from: the host (any aiming, uploaded in chunks) or the device's own pupil
//! sampling with paraxial aiming (nothing uploaded: the path for huge ray counts).

use crate::device::{GpuError, GpuResult};
use crate::layout::{pattern, Params};
use crate::real::Real;
use unicac_optics::Lens;
use unicac_trace::{PupilSampling, Ray};

/// Paraxial aiming of one field, as `unicac_trace::Aimer` with `Aiming::Paraxial`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParaxialAim {
    pub pupil_radius_mm: f64,
    pub pupil_z_mm: f64,
    pub field_deg: f64,
    /// Finite object: (object point y, z distance from it to the pupil plane).
    pub object: Option<(f64, f64)>,
}

impl ParaxialAim {
    pub fn new(lens: &Lens, field_deg: f64) -> GpuResult<ParaxialAim> {
        let first_order = lens.first_order()?;
        let z_ep = first_order.entrance_pupil_z_mm;
        let object = lens.object_distance_mm.map(|distance| {
            let (sin_f, cos_f) = field_deg.to_radians().sin_cos();
            (-(sin_f / cos_f) * (z_ep + distance), z_ep + distance)
        });
        Ok(ParaxialAim {
            pupil_radius_mm: first_order.epd_mm / 2.0,
            pupil_z_mm: z_ep,
            field_deg,
            object,
        })
    }
}

/// Rays sampled and aimed on the device.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PupilSource {
    pub sampling: PupilSampling,
    pub aim: ParaxialAim,
}

impl PupilSource {
    /// Pattern slots (grid: n^2 cells, of which those inside the disc are rays).
    pub fn slots(&self) -> GpuResult<u64> {
        let slots = match self.sampling {
            PupilSampling::Hexapolar { rings } => 1 + 3 * rings as u64 * (rings as u64 + 1),
            PupilSampling::Grid { n } => n as u64 * n as u64,
            PupilSampling::Fibonacci { n } | PupilSampling::Random { n, .. } => n as u64,
        };
        if matches!(self.sampling, PupilSampling::Grid { n } if n > 32767) {
            // The kernel's exact disc test squares cell indices in i32.
            return Err(GpuError::Unsupported(
                "grid pupil sampling: at most 32767 per side".into(),
            ));
        }
        if slots > u32::MAX as u64 {
            return Err(GpuError::Unsupported(format!(
                "{slots} pupil samples: the device indexes at most 2^32 - 1"
            )));
        }
        Ok(slots)
    }

    /// The pattern and aiming fields of the kernel parameters.
    pub(crate) fn fill<R: Real>(&self, params: &mut Params<R>) {
        let (code, n, seed) = match self.sampling {
            PupilSampling::Hexapolar { rings } => (pattern::HEXAPOLAR, rings, 0),
            PupilSampling::Grid { n } => (pattern::GRID, n, 0),
            PupilSampling::Fibonacci { n } => (pattern::FIBONACCI, n, 0),
            PupilSampling::Random { n, seed } => (pattern::RANDOM, n, seed),
        };
        let (sin_f, cos_f) = self.aim.field_deg.to_radians().sin_cos();
        params.pattern = code;
        params.pattern_n = n as u32;
        params.seed_lo = seed as u32;
        params.seed_hi = (seed >> 32) as u32;
        params.pupil_radius_mm = R::from_f64(self.aim.pupil_radius_mm);
        params.pupil_z_mm = R::from_f64(self.aim.pupil_z_mm);
        params.sin_field = R::from_f64(sin_f);
        params.cos_field = R::from_f64(cos_f);
        if let Some((object_y, to_pupil)) = self.aim.object {
            params.finite_object = 1;
            params.object_y_mm = R::from_f64(object_y);
            params.object_to_pupil_mm = R::from_f64(to_pupil);
        }
    }
}

/// The rays of one kernel run.
#[derive(Debug, Clone, Copy)]
pub enum RaySource<'a> {
    /// Rays in global coordinates (surface 1's vertex at the origin), e.g. aimed by the CPU.
    Host(&'a [Ray]),
    Pupil(PupilSource),
}

impl RaySource<'_> {
    pub fn slots(&self) -> GpuResult<u64> {
        match self {
            RaySource::Host(rays) => Ok(rays.len() as u64),
            RaySource::Pupil(pupil) => pupil.slots(),
        }
    }
}
