//! Clear semi-diameters computed from the traced beams, for surfaces whose file gives none
//! (Zemax's "automatic" semi-diameters): the largest ray height over every field (both signs),
//! every wavelength and a ring of rays round the pupil edge plus the chief ray. Heights are measured
//! from each surface's own axis (a decentred surface's aperture is centred on its vertex).

use crate::aim::{Aimer, Aiming};
use crate::error::TraceResult;
use crate::system::{Clipping, TraceSystem};
use unicac_optics::Lens;

/// Rays round the pupil edge per field and wavelength.
const EDGE_RAYS: usize = 32;

/// One semi-diameter per surface: the given one, or the computed beam envelope.
pub fn clear_semi_diameters(lens: &Lens, aiming: Aiming) -> TraceResult<Vec<f64>> {
    let first = lens.first_order()?;
    let mut envelope = vec![0.0f64; lens.surfaces.len()];
    for wavelength in lens.wavelengths_um() {
        let system = TraceSystem::new(lens, wavelength, Clipping::None)?;
        let aimer = Aimer::new(lens, wavelength, aiming)?;
        for &field in &first.field_angles_deg {
            for signed_field in [field, -field] {
                let pupil = std::iter::once([0.0, 0.0]).chain((0..EDGE_RAYS).map(|k| {
                    let angle = 2.0 * std::f64::consts::PI * k as f64 / EDGE_RAYS as f64;
                    [angle.cos(), angle.sin()]
                }));
                for [px, py] in pupil {
                    let Ok(ray) = aimer.ray(signed_field, px, py) else {
                        continue;
                    };
                    let (points, _) = system.trace_path(ray);
                    for (surface, point) in points.iter().skip(1).enumerate() {
                        // Heights from the surface's own axis (the global axis when centred).
                        let height = match system.surfaces[surface].frame {
                            None => point[0].hypot(point[1]),
                            Some(_) => {
                                let local = system.to_surface_frame(surface, *point);
                                local[0].hypot(local[1])
                            }
                        };
                        envelope[surface] = envelope[surface].max(height);
                    }
                }
            }
        }
    }
    Ok(lens
        .surfaces
        .iter()
        .zip(envelope)
        .map(|(s, computed)| s.semi_diameter_mm.unwrap_or(computed))
        .collect())
}
