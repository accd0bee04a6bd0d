//! Zemax coordinate breaks (COORDBRK) to and from the per-surface decentre and tilt of the lens model
//! (`crate::placement`).
//!
//! A coordinate break moves the frame of every following surface: PARM 1, 2 decentre x, y; PARM 3, 4, 5
//! tilt about x, y, z (deg, right-handed turns of the frame about its current axes); PARM 6 the order
//! (0: decentre, then tilt about x, y, z; otherwise tilt about z, y, x, then decentre); its DISZ then
//! moves along the new z axis. Reading follows the frame through the file and gives each real surface
//! the placement of the frame it sits in. A break that exactly undoes the last one still open (every
//! parameter negated, and the opposite order or a single move) closes it without arithmetic, so a lens
//! written by `around` reads back with its centred surfaces and thicknesses bit for bit.

use crate::placement::{rotate, Placement, Rotation};
use crate::spec::SurfaceSpec;

/// Parameters of one coordinate break.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Break {
    decentre_mm: [f64; 2],
    tilt_deg: [f64; 3],
    /// 0: decentre then tilt x, y, z; otherwise tilt z, y, x then decentre.
    order: f64,
}

impl Break {
    /// From the PARM entries of a COORDBRK surface (absent ones are 0).
    pub(crate) fn from_parms(parms: &[(usize, f64)]) -> Break {
        let value = |n: usize| parms.iter().rev().find(|(i, _)| *i == n).map_or(0.0, |p| p.1);
        Break {
            decentre_mm: [value(1), value(2)],
            tilt_deg: [value(3), value(4), value(5)],
            order: value(6),
        }
    }

    /// PARM 1..6.
    pub(crate) fn parms(&self) -> [f64; 6] {
        let [dx, dy] = self.decentre_mm;
        let [tx, ty, tz] = self.tilt_deg;
        [dx, dy, tx, ty, tz, self.order]
    }

    /// How many of decentre, tilt x, tilt y and tilt z this break moves.
    fn moves(&self) -> usize {
        usize::from(self.decentre_mm != [0.0, 0.0]) + self.tilt_deg.iter().filter(|t| **t != 0.0).count()
    }

    /// The break that undoes this one: every parameter negated, the order reversed.
    fn inverse(&self) -> Break {
        Break {
            decentre_mm: self.decentre_mm.map(|v| -v),
            tilt_deg: self.tilt_deg.map(|v| -v),
            order: if self.order == 0.0 { 1.0 } else { 0.0 },
        }
    }

    /// True when `self` exactly undoes `open`.
    fn undoes(&self, open: &Break) -> bool {
        let negated =
            self.decentre_mm == open.decentre_mm.map(|v| -v) && self.tilt_deg == open.tilt_deg.map(|v| -v);
        negated && ((self.order == 0.0) != (open.order == 0.0) || open.moves() <= 1)
    }

    /// Applies the break to a frame (origin, rotation with the local axes as columns).
    fn apply(&self, origin: &mut [f64; 3], rotation: &mut Rotation) {
        let [tx, ty, tz] = self.tilt_deg.map(f64::to_radians);
        let turns = [axis_rotation(0, tx), axis_rotation(1, ty), axis_rotation(2, tz)];
        let decentre = [self.decentre_mm[0], self.decentre_mm[1], 0.0];
        if self.order == 0.0 {
            move_along(origin, rotation, decentre);
            for turn in &turns {
                *rotation = multiply(rotation, turn);
            }
        } else {
            for turn in turns.iter().rev() {
                *rotation = multiply(rotation, turn);
            }
            move_along(origin, rotation, decentre);
        }
    }
}

/// The coordinate breaks written before and after a surface with `placement`: before, decentre and tilt
/// about y, then tilt about the new x (R = Ry Rx, as `Placement::rotation`); after, their inverses in
/// reverse order. Both empty for a centred surface.
pub(crate) fn around(placement: &Placement) -> (Vec<Break>, Vec<Break>) {
    let mut before = Vec::new();
    if placement.decentre_x_mm != 0.0 || placement.decentre_y_mm != 0.0 || placement.tilt_y_deg != 0.0 {
        before.push(Break {
            decentre_mm: [placement.decentre_x_mm, placement.decentre_y_mm],
            tilt_deg: [0.0, placement.tilt_y_deg, 0.0],
            order: 0.0,
        });
    }
    if placement.tilt_x_deg != 0.0 {
        before.push(Break {
            decentre_mm: [0.0, 0.0],
            tilt_deg: [placement.tilt_x_deg, 0.0, 0.0],
            order: 0.0,
        });
    }
    let after = before.iter().rev().map(Break::inverse).collect();
    (before, after)
}

/// One surface of a .zmx file, in order after the object surface.
pub(crate) enum Step {
    Surface(SurfaceSpec),
    /// A coordinate break, its DISZ, its line in the file and whether it was marked STOP.
    Break(Break, f64, usize, bool),
}

/// A move of the frame that is still open (not undone).
enum Open {
    Break(Break),
    Gap(f64),
}

/// The real surfaces of `steps`, each with the placement of the frame it sits in and the thickness
/// to the next one along the nominal axis. Errors carry the file line.
pub(crate) fn resolve(steps: Vec<Step>) -> Result<Vec<SurfaceSpec>, (usize, String)> {
    let mut open: Vec<Open> = Vec::new();
    let mut surfaces: Vec<SurfaceSpec> = Vec::new();
    // z travelled on the nominal axis since the last real surface, and that surface's z offset from it.
    let mut gap_since_last = 0.0;
    let mut last_offset = 0.0;
    let mut last_break_line = 0;
    for step in steps {
        let thickness = match step {
            Step::Break(b, thickness, line, stop) => {
                if stop {
                    return Err((line, "a coordinate break cannot be the stop".into()));
                }
                last_break_line = line;
                match open.last() {
                    Some(Open::Break(last)) if b.undoes(last) => {
                        open.pop();
                    }
                    _ => open.push(Open::Break(b)),
                }
                thickness
            }
            Step::Surface(mut surface) => {
                let (placement, offset) = frame_placement(&open);
                if surfaces.is_empty() && (gap_since_last != 0.0 || offset != 0.0) {
                    return Err((
                        last_break_line,
                        "coordinate breaks before surface 1 move it along the axis; surface 1's vertex must stay at z = 0".into(),
                    ));
                }
                if let Some(previous) = surfaces.last_mut() {
                    previous.thickness_mm = gap_since_last + (offset - last_offset);
                }
                surface.set_placement(placement);
                let thickness = surface.thickness_mm;
                surfaces.push(surface);
                gap_since_last = 0.0;
                last_offset = offset;
                thickness
            }
        };
        if open.is_empty() {
            gap_since_last += thickness;
        } else if thickness != 0.0 {
            open.push(Open::Gap(thickness));
        }
    }
    if surfaces.len() < 2 {
        return Err((
            last_break_line,
            "need at least one surface and the image surface besides coordinate breaks".into(),
        ));
    }
    Ok(surfaces)
}

/// The placement of the frame left by the `open` moves, relative to the nominal vertex, and its z offset.
fn frame_placement(open: &[Open]) -> (Placement, f64) {
    if open.is_empty() {
        return (Placement::default(), 0.0);
    }
    let mut origin = [0.0; 3];
    let mut rotation: Rotation = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for step in open {
        match step {
            Open::Break(b) => b.apply(&mut origin, &mut rotation),
            Open::Gap(t) => move_along(&mut origin, &rotation, [0.0, 0.0, *t]),
        }
    }
    let axis = [rotation[0][2], rotation[1][2], rotation[2][2]];
    Placement::from_frame(origin, axis)
}

/// origin += rotation * local.
fn move_along(origin: &mut [f64; 3], rotation: &Rotation, local: [f64; 3]) {
    for (o, step) in origin.iter_mut().zip(rotate(rotation, local)) {
        *o += step;
    }
}

/// The right-handed rotation by `angle` (rad) about axis 0 (x), 1 (y) or 2 (z).
fn axis_rotation(axis: usize, angle: f64) -> Rotation {
    let (s, c) = angle.sin_cos();
    match axis {
        0 => [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
        1 => [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
        _ => [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
    }
}

fn multiply(a: &Rotation, b: &Rotation) -> Rotation {
    let mut m = [[0.0; 3]; 3];
    for (r, row) in m.iter_mut().enumerate() {
        for (c, value) in row.iter_mut().enumerate() {
            *value = a[r][0] * b[0][c] + a[r][1] * b[1][c] + a[r][2] * b[2][c];
        }
    }
    m
}
