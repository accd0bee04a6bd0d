//! Where pixels sit on the sensor, and the rectangle of them a job takes (`PixelWindow`). Pixel centres: column c, row r of a W x H image sit at
//! x = (c - (W-1)/2) p, y = -(r - (H-1)/2) p (sensor +y up, rows down), p the pixel pitch.

use crate::chief::ChiefRayMap;
use crate::error::SimResult;
use serde::Serialize;
use unicac_trace::InvalidParameter;

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SensorGrid {
    pub width_px: usize,
    pub height_px: usize,
    pub pitch_um: f64,
}

impl SensorGrid {
    pub fn centre_px(&self) -> [f64; 2] {
        [
            (self.width_px as f64 - 1.0) / 2.0,
            (self.height_px as f64 - 1.0) / 2.0,
        ]
    }

    /// Sensor coordinates (mm) of a (fractional) pixel position.
    pub fn to_mm(&self, column: f64, row: f64) -> [f64; 2] {
        let [cx, cy] = self.centre_px();
        [
            (column - cx) * self.pitch_um * 1e-3,
            -(row - cy) * self.pitch_um * 1e-3,
        ]
    }

    /// Pixel position of sensor coordinates (mm).
    pub fn to_px(&self, mm: [f64; 2]) -> [f64; 2] {
        let [cx, cy] = self.centre_px();
        [cx + mm[0] * 1e3 / self.pitch_um, cy - mm[1] * 1e3 / self.pitch_um]
    }

    /// Half the image diagonal (corner of the pixel area), mm.
    pub fn half_diagonal_mm(&self) -> f64 {
        0.5 * (self.width_px as f64).hypot(self.height_px as f64) * self.pitch_um * 1e-3
    }

    /// The grid on which the lens's largest field fills the image's half-diagonal (the simulator's
    /// default when no pitch is given).
    pub fn filling_field(width_px: usize, height_px: usize, chief: &ChiefRayMap) -> SensorGrid {
        let half_diagonal_px = 0.5 * (width_px as f64).hypot(height_px as f64);
        SensorGrid {
            width_px,
            height_px,
            pitch_um: chief.max_height_mm() * 1e3 / half_diagonal_px,
        }
    }
}

/// A rectangle of frame pixels: columns `x0 .. x0 + width`, rows `y0 .. y0 + height`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PixelWindow {
    pub x0: usize,
    pub y0: usize,
    pub width: usize,
    pub height: usize,
}

impl PixelWindow {
    pub(crate) fn check_inside(&self, width: usize, height: usize) -> SimResult<()> {
        let fits = self.width >= 2
            && self.height >= 2
            && self.x0.checked_add(self.width).is_some_and(|end| end <= width)
            && self.y0.checked_add(self.height).is_some_and(|end| end <= height);
        if !fits {
            return Err(InvalidParameter::new(
                "window",
                format!(
                    "{} x {} px at ({}, {}) does not fit in the {width} x {height} px frame (at least 2 x 2 px)",
                    self.width, self.height, self.x0, self.y0
                ),
            )
            .into());
        }
        Ok(())
    }
}
