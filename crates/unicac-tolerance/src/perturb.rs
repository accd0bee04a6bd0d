//! One built unit: the errors drawn for it (`Change`s) and the lens they make.
//!
//! Draws come from `unicac_io::counter_random`: trial t of seed s, error kind k and item i draw from
//! the stream (s, t, k) at counter i, so a trial is reproducible on its own (a resumed run redraws
//! nothing), and turning one kind on or off leaves the other kinds' draws as they were.

use crate::spec::{Distribution, ToleranceSpec};
use serde::{Deserialize, Serialize};
use unicac_io::counter_random::{counter_hash, derive_seed, unit_interval};
use unicac_optics::placement::rotate;
use unicac_optics::{Lens, Medium, Placement};

/// What one error changes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ChangeKind {
    /// Relative radius error e (R -> R (1 + e)).
    Radius,
    /// Thickness error (mm) after the surface.
    Thickness,
    SurfaceDecentreX,
    SurfaceDecentreY,
    SurfaceTiltX,
    SurfaceTiltY,
    ElementDecentreX,
    ElementDecentreY,
    ElementTiltX,
    ElementTiltY,
    /// Index error of the glass after the surface.
    Index,
}

impl ChangeKind {
    const ALL: [ChangeKind; 11] = [
        ChangeKind::Radius,
        ChangeKind::Thickness,
        ChangeKind::SurfaceDecentreX,
        ChangeKind::SurfaceDecentreY,
        ChangeKind::SurfaceTiltX,
        ChangeKind::SurfaceTiltY,
        ChangeKind::ElementDecentreX,
        ChangeKind::ElementDecentreY,
        ChangeKind::ElementTiltX,
        ChangeKind::ElementTiltY,
        ChangeKind::Index,
    ];

    fn limit(self, spec: &ToleranceSpec) -> f64 {
        match self {
            ChangeKind::Radius => spec.radius_fraction,
            ChangeKind::Thickness => spec.thickness_mm,
            ChangeKind::SurfaceDecentreX | ChangeKind::SurfaceDecentreY => spec.surface_decentre_mm,
            ChangeKind::SurfaceTiltX | ChangeKind::SurfaceTiltY => spec.surface_tilt_deg,
            ChangeKind::ElementDecentreX | ChangeKind::ElementDecentreY => spec.element_decentre_mm,
            ChangeKind::ElementTiltX | ChangeKind::ElementTiltY => spec.element_tilt_deg,
            ChangeKind::Index => spec.index,
        }
    }
}

/// One drawn error: its kind, the surfaces it applies to (1-based, first and last: one surface, or an
/// element's first and last) and its value (mm, deg, relative, or index units by kind).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Change {
    pub kind: ChangeKind,
    pub surfaces: [usize; 2],
    pub value: f64,
}

/// The surfaces (0-based, first and last) of each element: a run from a surface entering glass to
/// the surface that leaves it for air (a cemented group is one element).
pub fn elements(lens: &Lens) -> Vec<[usize; 2]> {
    let mut out = Vec::new();
    let mut first = None;
    for (i, s) in lens.surfaces[..lens.image_index()].iter().enumerate() {
        match (first, s.medium_after.is_air()) {
            (None, false) => first = Some(i),
            (Some(f), true) => {
                out.push([f, i]);
                first = None;
            }
            _ => {}
        }
    }
    out
}

/// The items each kind applies to, 0-based `[first, last]` surfaces.
fn items(lens: &Lens, kind: ChangeKind) -> Vec<[usize; 2]> {
    let optical = 0..lens.image_index();
    let single =
        |keep: &dyn Fn(usize) -> bool| optical.clone().filter(|&i| keep(i)).map(|i| [i, i]).collect();
    match kind {
        ChangeKind::Radius => single(&|i| lens.surfaces[i].profile.curvature_per_mm != 0.0),
        // The last gap is the back focus: the compensator's, not a part's.
        ChangeKind::Thickness => single(&|i| i + 1 < lens.image_index()),
        ChangeKind::SurfaceDecentreX
        | ChangeKind::SurfaceDecentreY
        | ChangeKind::SurfaceTiltX
        | ChangeKind::SurfaceTiltY => single(&|_| true),
        ChangeKind::ElementDecentreX
        | ChangeKind::ElementDecentreY
        | ChangeKind::ElementTiltX
        | ChangeKind::ElementTiltY => elements(lens),
        ChangeKind::Index => single(&|i| !lens.surfaces[i].medium_after.is_air()),
    }
}

/// The errors of trial `trial` of a run seeded `seed`.
pub fn draw(lens: &Lens, spec: &ToleranceSpec, seed: u64, trial: u64) -> Vec<Change> {
    let trial_seed = derive_seed(seed, trial);
    let mut changes = Vec::new();
    for (k, kind) in ChangeKind::ALL.into_iter().enumerate() {
        let limit = kind.limit(spec);
        if limit == 0.0 {
            continue;
        }
        let stream = derive_seed(trial_seed, k as u64);
        for (i, [first, last]) in items(lens, kind).into_iter().enumerate() {
            changes.push(Change {
                kind,
                surfaces: [first + 1, last + 1],
                value: limit * unit_draw(spec.distribution, stream, i as u64),
            });
        }
    }
    changes
}

/// Draw attempts per truncated normal value (each fails with p = 0.046): a bound, never reached.
const MAX_ATTEMPTS: u64 = 64;

/// A value in [-1, 1]: uniform, or a normal of sigma 1/2 truncated at +-1 (by rejection).
fn unit_draw(distribution: Distribution, stream: u64, item: u64) -> f64 {
    let uniform = |n: u64| unit_interval(counter_hash(stream, item * 2 * MAX_ATTEMPTS + n));
    match distribution {
        Distribution::Uniform => 2.0 * uniform(0) - 1.0,
        Distribution::Normal => (0..MAX_ATTEMPTS)
            .map(|attempt| {
                // Box-Muller; 1 - u lies in (0, 1], so the logarithm is finite.
                let radius = (-2.0 * (1.0 - uniform(2 * attempt)).ln()).sqrt();
                0.5 * radius * (std::f64::consts::TAU * uniform(2 * attempt + 1)).cos()
            })
            .find(|z| z.abs() <= 1.0)
            .unwrap_or(0.0),
    }
}

/// The lens as built with `changes` (see docs/tolerancing.md for each kind's meaning). The image
/// surface stays where the nominal lens has it.
pub fn apply(nominal: &Lens, changes: &[Change]) -> Lens {
    let mut lens = nominal.clone();
    let image = lens.image_index();
    let mut thickness: Vec<f64> = lens.surfaces.iter().map(|s| s.thickness_mm).collect();
    for change in changes {
        let [first, last] = [change.surfaces[0] - 1, change.surfaces[1] - 1];
        let surface = &mut lens.surfaces[first];
        let v = change.value;
        match change.kind {
            ChangeKind::Radius => surface.profile.curvature_per_mm /= 1.0 + v,
            ChangeKind::Thickness => thickness[first] += v,
            ChangeKind::SurfaceDecentreX => surface.placement.decentre_x_mm += v,
            ChangeKind::SurfaceDecentreY => surface.placement.decentre_y_mm += v,
            ChangeKind::SurfaceTiltX => surface.placement.tilt_x_deg += v,
            ChangeKind::SurfaceTiltY => surface.placement.tilt_y_deg += v,
            ChangeKind::Index => {
                let base = Box::new(surface.medium_after.clone());
                surface.medium_after = Medium::Offset { base, delta_n: v };
            }
            ChangeKind::ElementDecentreX
            | ChangeKind::ElementDecentreY
            | ChangeKind::ElementTiltX
            | ChangeKind::ElementTiltY => {} // after the axial stack below
        }
        debug_assert!(first <= last && last < image);
    }
    // The axial stack: each vertex after a thickness error moves with it, the image stays.
    let mut z_mm = 0.0;
    for (i, s) in lens.surfaces[..image].iter_mut().enumerate() {
        s.z_mm = z_mm;
        z_mm += thickness[i];
    }
    for [first, last] in elements(&lens) {
        let motion = |kind: ChangeKind| {
            changes
                .iter()
                .filter(|c| c.kind == kind && c.surfaces == [first + 1, last + 1])
                .map(|c| c.value)
                .sum::<f64>()
        };
        let rigid = Placement {
            decentre_x_mm: motion(ChangeKind::ElementDecentreX),
            decentre_y_mm: motion(ChangeKind::ElementDecentreY),
            tilt_x_deg: motion(ChangeKind::ElementTiltX),
            tilt_y_deg: motion(ChangeKind::ElementTiltY),
        };
        if !rigid.is_centred() {
            move_rigidly(&mut lens, first, last, rigid);
        }
    }
    let image_z = lens.surfaces[image].z_mm;
    for i in 0..image {
        let next = if i + 1 == image {
            image_z
        } else {
            lens.surfaces[i + 1].z_mm
        };
        lens.surfaces[i].thickness_mm = next - lens.surfaces[i].z_mm;
    }
    lens
}

/// Turns surfaces `first..=last` by `rigid`'s tilts about the first vertex, then shifts them by its
/// decentres: each vertex and axis moves with the body.
fn move_rigidly(lens: &mut Lens, first: usize, last: usize, rigid: Placement) {
    let pivot = [0.0, 0.0, lens.surfaces[first].z_mm];
    let turn = rigid.rotation();
    for s in &mut lens.surfaces[first..=last] {
        let own = s.placement.rotation();
        let vertex = [s.placement.decentre_x_mm, s.placement.decentre_y_mm, s.z_mm];
        let arm = [0, 1, 2].map(|k| vertex[k] - pivot[k]);
        let turned = rotate(&turn, arm);
        let origin = [
            pivot[0] + turned[0] + rigid.decentre_x_mm,
            pivot[1] + turned[1] + rigid.decentre_y_mm,
            pivot[2] + turned[2],
        ];
        let axis = rotate(&turn, [own[0][2], own[1][2], own[2][2]]);
        let (placement, z_mm) = Placement::from_frame(origin, axis);
        s.placement = placement;
        s.z_mm = z_mm;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truncated_normal_draws_have_the_stated_spread() {
        let values: Vec<f64> = (0..20_000)
            .map(|i| unit_draw(Distribution::Normal, 7, i))
            .collect();
        assert!(values.iter().all(|v| v.abs() <= 1.0));
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let variance = values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64;
        // sigma 1/2 truncated at 2 sigma: variance (1/4)(1 - 4 phi(2) / (2 Phi(2) - 1)) = 0.19344.
        assert!(mean.abs() < 0.01, "{mean}");
        assert!((variance - 0.19344).abs() < 0.005, "{variance}");
        let uniform: Vec<f64> = (0..20_000)
            .map(|i| unit_draw(Distribution::Uniform, 7, i))
            .collect();
        let variance = uniform.iter().map(|v| v * v).sum::<f64>() / uniform.len() as f64;
        assert!((variance - 1.0 / 3.0).abs() < 0.01, "{variance}");
    }
}
