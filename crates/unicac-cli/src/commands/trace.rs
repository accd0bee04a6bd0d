//! `unicac trace`: one explicit or aimed ray.

use super::print_json;
use crate::args::TraceArgs;
use crate::lens_input::load_lens;
use anyhow::{bail, Result};
use serde::Serialize;
use unicac_trace::{Aimer, Clipping, Ray, RayStatus, TraceSystem};

#[derive(Serialize)]
struct TraceReport {
    /// "ok", "missed", "tir", "clipped", "no_convergence" or "invalid_input".
    status: &'static str,
    /// 1-based surface where the ray stopped (null when it arrived).
    failed_at_surface: Option<u32>,
    message: String,
    /// Intercept on the image surface (null when the ray did not arrive).
    x_mm: Option<f64>,
    y_mm: Option<f64>,
    z_mm: Option<f64>,
    /// Direction cosines at the image surface.
    direction: Option<[f64; 3]>,
    wavelength_um: f64,
    start_mm: [f64; 3],
    start_direction: [f64; 3],
    /// The stop surface (1-based) and where the ray crosses it, in the stop's own frame (null if it
    /// stops before): with `--aim real` the ray of pupil (px, py) crosses at (px, py) R_stop (docs/conventions.md).
    stop_surface: usize,
    stop_xy_mm: Option<[f64; 2]>,
    /// With --path: the start point, then the point on surface 1, 2, ...: `path_mm[k]` is on surface k.
    #[serde(skip_serializing_if = "Option::is_none")]
    path_mm: Option<Vec<[f64; 3]>>,
}

pub fn run(args: &TraceArgs) -> Result<()> {
    let lens = load_lens(&args.lens.lens)?;
    let wavelength_um =
        unicac_trace::check_wavelength_um(args.wavelength_um.unwrap_or_else(|| lens.primary_wavelength_um()))
            .map_err(super::flag_error)?;
    let ray = match (args.ray, args.field_deg, args.pupil) {
        (Some(r), _, _) => Ray::new([r[0], r[1], r[2]], [r[3], r[4], r[5]]),
        (None, Some(field), Some([px, py])) => {
            Aimer::new(&lens, wavelength_um, args.aim)?.ray(field, px, py)?
        }
        _ => bail!("give either --ray=X,Y,Z,L,M,N or --field-deg F with --pupil PX,PY"),
    };
    let system = TraceSystem::new(&lens, wavelength_um, Clipping::Apertures)?;
    // A ray given by the user starts where it says; an aimed ray starts on the entrance-pupil plane.
    let (path, status) = if args.ray.is_some() {
        system.trace_path_from_start(ray)
    } else {
        system.trace_path(ray)
    };
    // path[0] is the start point, path[k] the point on surface k (1-based).
    // In the stop's own frame (the frame real aiming targets; the global x, y for a centred stop).
    let stop_xy_mm = path.get(lens.stop_index + 1).map(|p| {
        let local = system.to_surface_frame(lens.stop_index, *p);
        [local[0], local[1]]
    });
    let arrived = status.is_ok();
    let end = path.last().copied().filter(|_| arrived);
    let mut end_ray = ray;
    let end_direction = arrived.then(|| {
        system.trace(&mut end_ray);
        end_ray.direction
    });
    let report = TraceReport {
        status: status.kind(),
        failed_at_surface: failed_surface(status),
        message: status.to_string(),
        x_mm: end.map(|p| p[0]),
        y_mm: end.map(|p| p[1]),
        z_mm: end.map(|p| p[2]),
        direction: end_direction,
        wavelength_um,
        start_mm: ray.position_mm,
        start_direction: ray.direction,
        stop_surface: lens.stop_index + 1,
        stop_xy_mm,
        path_mm: args.path.then_some(path),
    };
    if args.json {
        return print_json(&report);
    }
    match (report.x_mm, report.y_mm) {
        (Some(x), Some(y)) => println!("ok: x = {x:.9} mm, y = {y:.9} mm on the image surface"),
        _ => println!("{}", report.message),
    }
    Ok(())
}

fn failed_surface(status: RayStatus) -> Option<u32> {
    match status {
        RayStatus::Missed { surface }
        | RayStatus::Tir { surface }
        | RayStatus::Clipped { surface }
        | RayStatus::NoConvergence { surface } => Some(surface + 1),
        RayStatus::Ok | RayStatus::InvalidInput => None,
    }
}
