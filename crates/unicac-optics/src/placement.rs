//! Where a surface sits when it is not on the axis: decentre and tilt (docs/lens-format.md, "Decentres
//! and tilts").
//!
//! Semantics (those of optiland's per-surface `dx, dy, rx, ry`, and of a Zemax surface whose
//! tilt/decenter is followed by "reverse"): the surface's vertex moves from its nominal place
//! (0, 0, z) to (decentre_x, decentre_y, z); its axes are then turned by R = Ry(tilt_y) Rx(tilt_x)
//! (right-handed rotations about the global x axis first, then the global y axis; in Zemax coordinate
//! break terms: decentre, tilt about y, then tilt about the new x). The following surfaces do not see
//! it: the next vertex is at z + thickness on the nominal axis.

use serde::Serialize;

/// Largest tilt accepted (deg): at 90 the surface would lie along the axis.
pub const MAX_TILT_DEG: f64 = 89.0;

/// A rigid displacement of one surface from its nominal place. All zero: centred.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Placement {
    pub decentre_x_mm: f64,
    pub decentre_y_mm: f64,
    pub tilt_x_deg: f64,
    pub tilt_y_deg: f64,
}

/// A rotation matrix, rows first: `m[r][c]`. Column c is local axis c in global coordinates.
pub type Rotation = [[f64; 3]; 3];

/// `rotation` applied to the vector `v` (local to global for a placement's rotation).
#[inline]
pub fn rotate(rotation: &Rotation, v: [f64; 3]) -> [f64; 3] {
    rotation.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
}

impl Placement {
    pub fn is_centred(&self) -> bool {
        *self == Placement::default()
    }

    /// R = Ry(tilt_y) Rx(tilt_x): local vectors to global ones (`global = origin + R local`).
    pub fn rotation(&self) -> Rotation {
        let (sx, cx) = self.tilt_x_deg.to_radians().sin_cos();
        let (sy, cy) = self.tilt_y_deg.to_radians().sin_cos();
        [[cy, sy * sx, sy * cx], [0.0, cx, -sx], [-sy, cy * sx, cy * cx]]
    }

    /// The placement whose vertex is at `origin` (its z is returned beside it: the vertex's global z)
    /// and whose local z axis is `axis` (unit). A turn about the surface's own axis changes nothing for
    /// a rotationally symmetric surface, so only the axis matters.
    pub fn from_frame(origin: [f64; 3], axis: [f64; 3]) -> (Placement, f64) {
        // axis = R e_z = (sin ty cos tx, -sin tx, cos ty cos tx).
        let tilt_x = (-axis[1]).atan2(axis[0].hypot(axis[2]));
        let tilt_y = axis[0].atan2(axis[2]);
        (
            Placement {
                decentre_x_mm: origin[0],
                decentre_y_mm: origin[1],
                tilt_x_deg: tilt_x.to_degrees(),
                tilt_y_deg: tilt_y.to_degrees(),
            },
            origin[2],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rotation_is_orthonormal_and_turns_the_axis_as_stated() {
        let p = Placement {
            tilt_x_deg: 3.0,
            tilt_y_deg: -2.0,
            ..Placement::default()
        };
        let r = p.rotation();
        for a in 0..3 {
            for b in 0..3 {
                let dot: f64 = (0..3).map(|k| r[k][a] * r[k][b]).sum();
                assert!((dot - f64::from(u8::from(a == b))).abs() < 1e-15);
            }
        }
        // A positive tilt about x turns the local z axis towards -y (right-handed).
        let tilt_x = Placement {
            tilt_x_deg: 10.0,
            ..Placement::default()
        };
        assert!(tilt_x.rotation()[1][2] < 0.0);
        let axis = [r[0][2], r[1][2], r[2][2]];
        let (back, z) = Placement::from_frame([0.5, -0.25, 7.0], axis);
        assert_eq!(z, 7.0);
        assert_eq!((back.decentre_x_mm, back.decentre_y_mm), (0.5, -0.25));
        assert!((back.tilt_x_deg - 3.0).abs() < 1e-13 && (back.tilt_y_deg + 2.0).abs() < 1e-13);
    }
}
