//! `Kernel`: a square, odd-sized PSF sampled at the sensor pitch, centred on its middle pixel, and the
//! rasteriser that turns ray hits into one.
//!
//! Rasterising: each hit is splatted bilinearly onto a grid `oversample` times finer than the pixels
//! (sub-pixel accurate positions), and each pixel then sums its `oversample^2` sub-cells, which
//! integrates the PSF over the pixel area (a box pixel aperture).

use serde::{Deserialize, Serialize};

/// A square PSF kernel; sample (x, y) sits at offset ((x - half) * pitch, (y - half) * pitch) from the
/// reference point, +x right, +y down the rows... see `docs/conventions.md` ("PSF kernels").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Kernel {
    pub size: usize,
    pub pitch_um: f64,
    /// Row-major samples; not in JSON (images carry them: EXR stacks, the PSF cache).
    #[serde(skip)]
    pub data: Vec<f32>,
}

impl Kernel {
    pub fn zeros(size: usize, pitch_um: f64) -> Kernel {
        assert!(size % 2 == 1, "kernels have odd sizes");
        Kernel {
            size,
            pitch_um,
            data: written_zeros(size * size),
        }
    }

    /// A kernel from caller-supplied samples (row-major, `size` x `size`), scaled to unit sum: the
    /// checked way in for data from outside (a Python array, a file). The side must be odd, the pitch
    /// positive, and the samples' sum finite and positive.
    pub fn normalised_from(
        size: usize,
        pitch_um: f64,
        samples: &[f32],
    ) -> Result<Kernel, unicac_trace::InvalidParameter> {
        use unicac_trace::InvalidParameter;
        if size % 2 != 1 || samples.len() != size * size {
            return Err(InvalidParameter::new(
                "kernel",
                format!(
                    "expected a square kernel of odd size, got {size} x {}",
                    samples.len().checked_div(size).unwrap_or(0)
                ),
            ));
        }
        unicac_trace::check_positive("pitch_um", pitch_um)?;
        let sum: f64 = samples.iter().map(|&v| f64::from(v)).sum();
        if !(sum.is_finite() && sum > 0.0) {
            return Err(InvalidParameter::new(
                "kernel",
                "samples must be finite with a positive sum",
            ));
        }
        Ok(Kernel {
            size,
            pitch_um,
            data: samples.iter().map(|&v| (f64::from(v) / sum) as f32).collect(),
        })
    }

    pub fn half(&self) -> usize {
        self.size / 2
    }

    pub fn sum(&self) -> f64 {
        self.data.iter().map(|&v| v as f64).sum()
    }

    /// Scales to unit sum (a zero kernel stays zero).
    pub fn normalise(&mut self) {
        let sum = self.sum();
        if sum > 0.0 {
            let scale = (1.0 / sum) as f32;
            self.data.iter_mut().for_each(|v| *v *= scale);
        }
    }

    #[inline]
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.data[y * self.size + x]
    }

    /// The kernel turned by `quarters` quarter turns, each taking sensor +y to +x (as
    /// `unicac_sim::psf_map::rotate` turns by a positive angle): in image coordinates (x right, y down)
    /// one turn moves the offset (x, y) to (-y, x). Exact (a permutation of the samples).
    pub fn quarter_turned(&self, quarters: i32) -> Kernel {
        let k = self.size;
        let h = (k / 2) as isize;
        let mut out = self.clone();
        for _ in 0..quarters.rem_euclid(4) {
            let source = out.data.clone();
            for row in 0..k {
                for column in 0..k {
                    let (x, y) = (column as isize - h, row as isize - h);
                    let (nx, ny) = (-y + h, x + h);
                    out.data[ny as usize * k + nx as usize] = source[row * k + column];
                }
            }
        }
        out
    }

    /// Adds `weight * other` (same size and pitch).
    pub fn add_scaled(&mut self, other: &Kernel, weight: f32) {
        debug_assert_eq!(self.size, other.size);
        self.data
            .iter_mut()
            .zip(&other.data)
            .for_each(|(a, b)| *a += weight * b);
    }

    /// First moments (centroid) in micrometres relative to the kernel centre, rows as +y.
    pub fn centroid_um(&self) -> [f64; 2] {
        let half = self.half() as f64;
        let (mut sx, mut sy, mut s) = (0.0, 0.0, 0.0);
        for y in 0..self.size {
            for x in 0..self.size {
                let v = self.at(x, y) as f64;
                sx += v * (x as f64 - half);
                sy += v * (y as f64 - half);
                s += v;
            }
        }
        if s == 0.0 {
            [0.0, 0.0]
        } else {
            [sx / s * self.pitch_um, sy / s * self.pitch_um]
        }
    }
}

/// `n` zeros, written now. `vec![0.0; n]` asks the allocator for zeroed memory, which the kernel maps
/// as its shared zero page until the first write; kernels and grids are then accumulated into (read,
/// then written), so every page faults twice and the second fault flushes the page from the other
/// threads' TLBs (an inter-processor interrupt, costly in a VM: with SSIM's filter, ~14% of a whole `unicac ode` process).
/// Writing the zeros up front takes one ordinary fault per page.
pub fn written_zeros(n: usize) -> Vec<f32> {
    let mut zeros = Vec::with_capacity(n);
    zeros.resize(n, 0.0);
    zeros
}

/// Splats weighted hits (offsets from the reference point, um; x right, y along kernel rows) into a
/// kernel of `size` pixels at `pitch_um`, supersampled `oversample` times per axis. Hits outside the
/// kernel are dropped; the returned kernel is not normalised.
pub fn rasterise(
    offsets_um: &[[f64; 2]],
    weights: &[f32],
    size: usize,
    pitch_um: f64,
    oversample: usize,
) -> Kernel {
    Rasteriser::new(size, pitch_um, oversample).rasterise(offsets_um, weights)
}

/// `rasterise` for many hit sets of one kernel size (a field's wavelengths): the fine grid is kept
/// between calls, and only the pixels that some hit reached are summed and cleared. A PSF of 2048 rays
/// touches a few thousand of a 127 px kernel's 16,129 pixels and 258,064 sub-cells; summing and zeroing the
/// whole grid per wavelength was most of the rasteriser's time (and its fresh 1 MB grids page faults).
/// Every pixel sums its sub-cells as before, so the kernels are bit for bit those of a whole-grid pass.
pub struct Rasteriser {
    size: usize,
    pitch_um: f64,
    oversample: usize,
    /// The fine grid, all zero between calls.
    grid: Vec<f32>,
    /// Per pixel: did a hit reach one of its sub-cells in this call.
    touched: Vec<bool>,
    /// The touched pixels' indices, in the order first reached.
    touched_pixels: Vec<usize>,
}

impl Rasteriser {
    pub fn new(size: usize, pitch_um: f64, oversample: usize) -> Rasteriser {
        let fine = size * oversample;
        Rasteriser {
            size,
            pitch_um,
            oversample,
            grid: written_zeros(fine * fine),
            touched: vec![false; size * size],
            touched_pixels: Vec::new(),
        }
    }

    pub fn rasterise(&mut self, offsets_um: &[[f64; 2]], weights: &[f32]) -> Kernel {
        let (size, oversample) = (self.size, self.oversample);
        let mut kernel = Kernel::zeros(size, self.pitch_um);
        let fine = size * oversample;
        let (grid, touched, touched_pixels) = (&mut self.grid, &mut self.touched, &mut self.touched_pixels);
        splat(
            offsets_um,
            weights,
            fine,
            self.pitch_um / oversample as f64,
            |x, y, value| {
                grid[y * fine + x] += value;
                let pixel = (y / oversample) * size + x / oversample;
                if !touched[pixel] {
                    touched[pixel] = true;
                    touched_pixels.push(pixel);
                }
            },
        );
        // Untouched pixels sum only zeros: they stay 0.
        for pixel in self.touched_pixels.drain(..) {
            let (x, y) = (pixel % size, pixel / size);
            let mut sum = 0.0f32;
            for sy in 0..oversample {
                let row = (y * oversample + sy) * fine + x * oversample;
                let cells = &mut self.grid[row..row + oversample];
                sum += cells.iter().sum::<f32>();
                cells.fill(0.0);
            }
            kernel.data[pixel] = sum;
            self.touched[pixel] = false;
        }
        kernel
    }
}

/// Each hit's bilinear shares over the four nearest cells of a `fine` x `fine` grid of `sub_pitch_um`
/// cells centred on the kernel centre, as `add(x, y, share)` in hit order; cells off the grid are dropped.
fn splat(
    offsets_um: &[[f64; 2]],
    weights: &[f32],
    fine: usize,
    sub_pitch_um: f64,
    mut add: impl FnMut(usize, usize, f32),
) {
    // Fine-grid coordinates: cell centres at integer + 0.5; the kernel centre is fine / 2.
    let centre = fine as f64 / 2.0;
    for (offset, &w) in offsets_um.iter().zip(weights) {
        let fx = offset[0] / sub_pitch_um + centre - 0.5;
        let fy = offset[1] / sub_pitch_um + centre - 0.5;
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = ((fx - x0) as f32, (fy - y0) as f32);
        for (dy, wy) in [(0, 1.0 - ty), (1, ty)] {
            for (dx, wx) in [(0, 1.0 - tx), (1, tx)] {
                let (x, y) = (x0 as i64 + dx, y0 as i64 + dy);
                if x >= 0 && y >= 0 && (x as usize) < fine && (y as usize) < fine {
                    add(x as usize, y as usize, w * wx * wy);
                }
            }
        }
    }
}

/// The smallest odd kernel size (pixels) whose square holds `fraction` of the weighted hits, plus one
/// pixel of margin for the splat footprint.
pub fn size_for_fraction(offsets_um: &[[f64; 2]], weights: &[f32], pitch_um: f64, fraction: f64) -> usize {
    let total: f64 = weights.iter().map(|&w| w as f64).sum();
    if total <= 0.0 {
        return 1;
    }
    // Chebyshev radius (half-width of the square) of each hit, in pixels, sorted.
    let mut radii: Vec<(f64, f64)> = offsets_um
        .iter()
        .zip(weights)
        .map(|(o, &w)| (o[0].abs().max(o[1].abs()) / pitch_um, w as f64))
        .collect();
    radii.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut accumulated = 0.0;
    let mut radius_px = 0.0;
    for (r, w) in radii {
        accumulated += w;
        radius_px = r;
        if accumulated >= fraction * total {
            break;
        }
    }
    // Saturating: a pitch tiny against the spot gives a radius past any kernel, which the caller caps.
    (radius_px.ceil() as usize)
        .saturating_add(1)
        .saturating_mul(2)
        .saturating_add(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The whole-grid pass the sparse rasteriser replaced: splat every hit, then sum every pixel of the grid.
    fn rasterise_whole_grid(
        offsets_um: &[[f64; 2]],
        weight: f32,
        size: usize,
        pitch_um: f64,
        oversample: usize,
    ) -> Vec<f32> {
        let fine = size * oversample;
        let mut grid = vec![0.0f32; fine * fine];
        splat(
            offsets_um,
            &vec![weight; offsets_um.len()],
            fine,
            pitch_um / oversample as f64,
            |x, y, value| grid[y * fine + x] += value,
        );
        (0..size * size)
            .map(|pixel| {
                let (x, y) = (pixel % size, pixel / size);
                let mut sum = 0.0f32;
                for sy in 0..oversample {
                    let row = (y * oversample + sy) * fine + x * oversample;
                    sum += grid[row..row + oversample].iter().sum::<f32>();
                }
                sum
            })
            .collect()
    }

    #[test]
    fn the_sparse_rasteriser_equals_the_whole_grid_pass_bit_for_bit_across_reuses() {
        // Pseudo-random hits, many piling on the same sub-cells, some outside the kernel; one rasteriser
        // reused over several hit sets (a field's wavelengths) must leave nothing behind between them.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for (size, oversample) in [(1, 4), (11, 4), (31, 3), (127, 4)] {
            let pitch_um = 1.5;
            let mut rasteriser = Rasteriser::new(size, pitch_um, oversample);
            for set in 0..4 {
                let spread_um = pitch_um * size as f64 * [0.2, 0.6, 1.3, 3.0][set];
                let hits: Vec<[f64; 2]> = (0..2000)
                    .map(|i| {
                        let r = spread_um * next().powi(2 + i % 2);
                        let a = std::f64::consts::TAU * next();
                        [r * a.cos(), r * a.sin()]
                    })
                    .collect();
                let weight = 1.0 / hits.len() as f32;
                let sparse = rasteriser.rasterise(&hits, &vec![weight; hits.len()]);
                let whole = rasterise_whole_grid(&hits, weight, size, pitch_um, oversample);
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
                assert_eq!(bits(&sparse.data), bits(&whole), "size {size}, set {set}");
            }
        }
    }

    #[test]
    fn a_centred_hit_lands_in_the_middle_pixel_and_energy_is_conserved() {
        let k = rasterise(&[[0.0, 0.0]], &[1.0], 5, 2.0, 4);
        assert!((k.at(2, 2) - 1.0).abs() < 1e-6);
        assert!((k.sum() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn sub_pixel_offsets_of_an_extended_spot_move_the_centroid() {
        // A uniform 4 x 4 px square of hits, shifted by a fraction of a pixel: pixel integration keeps
        // its mean position (exactly, for a square spanning whole pixels' worth of width).
        for offset in [0.3, -0.77, 1.25] {
            let hits: Vec<[f64; 2]> = (0..200)
                .flat_map(|i| {
                    (0..200).map(move |j| {
                        [
                            offset - 2.0 + (i as f64 + 0.5) * 0.02,
                            -0.5 * offset - 2.0 + (j as f64 + 0.5) * 0.02,
                        ]
                    })
                })
                .collect();
            let k = rasterise(&hits, &vec![1.0; hits.len()], 11, 1.0, 4);
            let c = k.centroid_um();
            assert!(
                (c[0] - offset).abs() < 1e-3 && (c[1] + 0.5 * offset).abs() < 1e-3,
                "{offset}: {c:?}"
            );
        }
    }

    #[test]
    fn kernel_size_contains_the_requested_fraction() {
        let hits: Vec<[f64; 2]> = (0..100).map(|i| [i as f64 * 0.1, 0.0]).collect();
        let weights = vec![1.0; 100];
        // 95% of hits lie within 9.4 um -> 10 px radius at 1 um pitch, +1 margin -> 23 px.
        assert_eq!(size_for_fraction(&hits, &weights, 1.0, 0.95), 23);
    }
}
