//! Meridional ray fans of a lens as paths through its surfaces: what a layout drawing shows
//! (`unicac layout`, the design library's layout pictures). Traced here so that the plot crate only draws
//! the paths it is given.

use crate::aim::{Aimer, Aiming};
use crate::error::TraceResult;
use crate::ray::{Ray, RayStatus};
use crate::system::{Clipping, TraceSystem};
use crate::InvalidParameter;
use unicac_optics::Lens;

/// Traced rays of one field: each path is the list of points from `TraceSystem::trace_path` (start,
/// then one point per surface reached, global mm).
#[derive(Debug, Clone, PartialEq)]
pub struct RayBundle {
    pub field_deg: f64,
    pub paths: Vec<Vec<[f64; 3]>>,
}

/// Most rays drawn per field: more would only blacken the picture (and each ray's path is kept).
pub const MAX_LAYOUT_RAYS: usize = 1000;

/// `rays_per_field` lies in 1..=`MAX_LAYOUT_RAYS`.
pub fn check_rays_per_field(rays_per_field: usize) -> Result<(), InvalidParameter> {
    if (1..=MAX_LAYOUT_RAYS).contains(&rays_per_field) {
        return Ok(());
    }
    Err(InvalidParameter::new(
        "rays_per_field",
        format!("{rays_per_field}: must lie between 1 and {MAX_LAYOUT_RAYS} (MAX_LAYOUT_RAYS)"),
    ))
}

/// Meridional fans for a layout drawing: for every field angle of the lens (first-order data),
/// `rays_per_field` rays with px = 0 and py evenly from -1 to 1 (just the chief ray for 1), aimed at the
/// primary wavelength (`Aiming::Auto`) and traced with clipping at the clear semi-diameters. A ray that
/// fails (clipped, missed, totally reflected) ends at the surface where it stopped. Each ray starts on
/// the plane z = min(entrance pupil z, 0) - 0.2 total track (or at the object, if nearer), so it is seen
/// entering the lens.
pub fn layout_bundles(lens: &Lens, rays_per_field: usize) -> TraceResult<Vec<RayBundle>> {
    check_rays_per_field(rays_per_field)?;
    let first = lens.first_order()?;
    let wavelength = lens.primary_wavelength_um();
    let aimer = Aimer::new(lens, wavelength, Aiming::Auto)?;
    let system = TraceSystem::new(lens, wavelength, Clipping::Apertures)?;
    let mut start_z = first.entrance_pupil_z_mm.min(0.0) - 0.2 * lens.total_track_mm().abs();
    if let Some(distance) = lens.object_distance_mm {
        start_z = start_z.max(-distance);
    }
    first
        .field_angles_deg
        .iter()
        .map(|&field_deg| {
            let paths = (0..rays_per_field)
                .map(|i| {
                    let py = if rays_per_field > 1 {
                        -1.0 + 2.0 * i as f64 / (rays_per_field - 1) as f64
                    } else {
                        0.0
                    };
                    let ray = moved_to(aimer.ray(field_deg, 0.0, py)?, start_z);
                    let (mut points, status) = system.trace_path(ray);
                    if let Some(surface) = failed_at(status) {
                        points.extend(to_surface(lens, surface, &points, ray.direction));
                    }
                    Ok(points)
                })
                .collect::<TraceResult<_>>()?;
            Ok(RayBundle { field_deg, paths })
        })
        .collect()
}

/// The surface where a ray's trace stopped, if it failed at one.
fn failed_at(status: RayStatus) -> Option<usize> {
    match status {
        RayStatus::Missed { surface }
        | RayStatus::Tir { surface }
        | RayStatus::Clipped { surface }
        | RayStatus::NoConvergence { surface } => Some(surface as usize),
        RayStatus::Ok | RayStatus::InvalidInput => None,
    }
}

/// Where a failed ray's last straight segment meets (approximately) surface `index` extended beyond its
/// edge, so the drawing shows it stopped there: the point on the vertex plane, moved once to the sag at
/// that height. `first_direction` is the ray's direction when the path holds only its start.
fn to_surface(lens: &Lens, index: usize, points: &[[f64; 3]], first_direction: [f64; 3]) -> Option<[f64; 3]> {
    let last = *points.last()?;
    let d = match points {
        [.., before, last] => [0, 1, 2].map(|k| last[k] - before[k]),
        _ => first_direction,
    };
    let surface = &lens.surfaces[index];
    let at_z = |z: f64| (d[2] != 0.0).then(|| [0, 1, 2].map(|k| last[k] + (z - last[2]) / d[2] * d[k]));
    let on_plane = at_z(surface.z_mm)?;
    let rho = (on_plane[0] * on_plane[0] + on_plane[1] * on_plane[1]).min(surface.profile.conic_rho_limit());
    at_z(surface.z_mm + surface.profile.sag(rho)).filter(|p| p.iter().all(|v| v.is_finite()))
}

/// The same ray, its start moved along it to the plane z = `z` (unchanged if it runs parallel to it).
fn moved_to(ray: Ray, z: f64) -> Ray {
    let [l, m, n] = ray.direction;
    if n == 0.0 {
        return ray;
    }
    let t = (z - ray.position_mm[2]) / n;
    let p = ray.position_mm;
    Ray {
        position_mm: [p[0] + t * l, p[1] + t * m, z],
        direction: ray.direction,
    }
}
