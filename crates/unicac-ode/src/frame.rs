//! The sensor a lens is graded on when a frame is named (`unicac ode --frame`, `unicac dataset build`):
//! one rule, so the grade a dataset records for a lens is the grade `unicac ode` prints with the
//! dataset's settings.

use serde::Serialize;
use unicac_optics::spec::SensorSpec;
use unicac_optics::Lens;
use unicac_trace::InvalidParameter;

use crate::OdeSettings;

/// Largest pixel pitch (um) a frame may name (a stated limit; 1 mm pixels are already far outside any
/// camera).
pub const MAX_PIXEL_UM: f64 = 1000.0;

/// A pixel pitch a frame may have: finite, in (0, MAX_PIXEL_UM].
pub fn check_pixel_um(pixel_um: f64) -> Result<(), InvalidParameter> {
    if pixel_um.is_finite() && pixel_um > 0.0 && pixel_um <= MAX_PIXEL_UM {
        return Ok(());
    }
    Err(InvalidParameter::new(
        "pixel_um",
        format!("{pixel_um}: must be in (0, {MAX_PIXEL_UM}]"),
    ))
}

/// A `frame_px` frame, with the lens's largest field on its half-diagonal (`pixel_um` None) or with a
/// given pitch. It replaces the lens file's own sensor, so the ODE and anything rendered on the frame
/// see the same pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FrameSensor {
    pub frame_px: [usize; 2],
    pub pixel_um: Option<f64>,
}

impl FrameSensor {
    /// A frame with at least one pixel per side and, when given, a finite pitch in (0, MAX_PIXEL_UM].
    pub fn check(&self) -> Result<(), InvalidParameter> {
        if self.frame_px.contains(&0) {
            return Err(InvalidParameter::new(
                "frame_px",
                format!("{:?}: each side must be at least 1 px", self.frame_px),
            ));
        }
        self.pixel_um.map_or(Ok(()), check_pixel_um)
    }

    /// The lens as graded and rendered: its sensor replaced by this one.
    pub fn apply(&self, lens: &Lens) -> Lens {
        let mut lens = lens.clone();
        lens.sensor = self.pixel_um.map(|p| SensorSpec {
            width_mm: self.frame_px[0] as f64 * p * 1e-3,
            height_mm: self.frame_px[1] as f64 * p * 1e-3,
            pixel_um: p,
        });
        lens
    }

    /// The default ODE settings on this frame (without a pitch, the ODE fits the lens's largest field
    /// to the frame's half-diagonal: `OdeSettings::default_frame_px`).
    pub fn ode_settings(&self) -> OdeSettings {
        OdeSettings {
            default_frame_px: self.frame_px,
            ..OdeSettings::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pitch_gives_the_lens_a_sensor_of_the_frame_and_none_drops_the_files_sensor() {
        let lens = unicac_optics::builtin::lens("cooke_triplet").unwrap();
        let pitched = FrameSensor {
            frame_px: [640, 480],
            pixel_um: Some(5.0),
        }
        .apply(&lens);
        let sensor = pitched.sensor.unwrap();
        assert!((sensor.width_mm - 3.2).abs() < 1e-12 && (sensor.height_mm - 2.4).abs() < 1e-12);
        assert_eq!(sensor.pixel_um, 5.0);
        let fitted = FrameSensor {
            frame_px: [640, 480],
            pixel_um: None,
        };
        assert_eq!(fitted.apply(&pitched).sensor, None);
        assert_eq!(fitted.ode_settings().default_frame_px, [640, 480]);
    }

    #[test]
    fn out_of_range_frames_and_pitches_are_refused_by_name() {
        let bad = |frame_px, pixel_um| FrameSensor { frame_px, pixel_um }.check().unwrap_err().field;
        assert_eq!(bad([0, 10], None), "frame_px");
        assert_eq!(bad([10, 10], Some(0.0)), "pixel_um");
        assert_eq!(bad([10, 10], Some(f64::NAN)), "pixel_um");
        assert_eq!(bad([10, 10], Some(1000.5)), "pixel_um");
        assert!(FrameSensor {
            frame_px: [1, 1],
            pixel_um: Some(1000.0)
        }
        .check()
        .is_ok());
    }
}
