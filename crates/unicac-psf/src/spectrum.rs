//! Camera spectral sensitivities and the spectral weights that turn per-wavelength PSFs into R, G, B
//! kernels. The default curves ship in `data/camera/` (provenance and licence in its README); users can
//! load their own from CSV (`wavelength_nm,r,g,b`).

use crate::error::{PsfError, PsfResult};
use crate::kernel::Kernel;
use serde::Serialize;
use std::path::Path;

const DEFAULT_RGB_CSV: &str = include_str!("../data/camera/default_rgb.csv");

/// Responses below this fraction of a channel's peak count as zero (the wavelength is skipped when it
/// is below it in every channel).
pub const NEGLIGIBLE_RESPONSE: f64 = 1e-3;

/// Sampled R, G, B sensitivities; linear interpolation between samples, zero outside.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpectralResponse {
    pub wavelengths_nm: Vec<f64>,
    pub rgb: Vec<[f64; 3]>,
}

impl SpectralResponse {
    /// The shipped default camera.
    pub fn default_camera() -> SpectralResponse {
        SpectralResponse::from_csv(DEFAULT_RGB_CSV, Path::new("data/camera/default_rgb.csv"))
            .expect("shipped curves")
    }

    /// Reads `wavelength_nm,r,g,b` rows (a header line is skipped; wavelengths strictly increasing).
    pub fn from_csv(text: &str, path: &Path) -> PsfResult<SpectralResponse> {
        let error = |line: usize, message: String| PsfError::Parse {
            path: path.to_path_buf(),
            line,
            message,
        };
        let mut wavelengths_nm = Vec::new();
        let mut rgb = Vec::new();
        for (index, raw) in text.lines().enumerate() {
            let line = raw.trim();
            if line.is_empty()
                || line.starts_with('#')
                || (index == 0 && line.chars().any(|c| c.is_ascii_alphabetic()))
            {
                continue;
            }
            let values: Vec<f64> = line
                .split(',')
                .map(|v| {
                    v.trim()
                        .parse::<f64>()
                        .map_err(|_| error(index + 1, format!("'{v}' is not a number")))
                })
                .collect::<PsfResult<_>>()?;
            let [w, r, g, b] = values[..] else {
                return Err(error(
                    index + 1,
                    format!("expected 4 columns (wavelength_nm,r,g,b), found {}", values.len()),
                ));
            };
            if [w, r, g, b].iter().any(|v| !v.is_finite()) || r < 0.0 || g < 0.0 || b < 0.0 {
                return Err(error(
                    index + 1,
                    "values must be finite and responses non-negative".into(),
                ));
            }
            if wavelengths_nm.last().is_some_and(|&last| w <= last) {
                return Err(error(index + 1, "wavelengths must increase".into()));
            }
            wavelengths_nm.push(w);
            rgb.push([r, g, b]);
        }
        if wavelengths_nm.len() < 2 {
            return Err(error(0, "need at least two wavelengths".into()));
        }
        Ok(SpectralResponse { wavelengths_nm, rgb })
    }

    pub fn load(path: &Path) -> PsfResult<SpectralResponse> {
        let text = std::fs::read_to_string(path).map_err(|source| PsfError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        SpectralResponse::from_csv(&text, path)
    }

    /// Response at `wavelength_nm` (linear interpolation; zero outside the sampled range).
    pub fn at(&self, wavelength_nm: f64) -> [f64; 3] {
        let w = &self.wavelengths_nm;
        if wavelength_nm < w[0] || wavelength_nm > w[w.len() - 1] {
            return [0.0; 3];
        }
        let i = w.partition_point(|&x| x <= wavelength_nm).clamp(1, w.len() - 1);
        let t = (wavelength_nm - w[i - 1]) / (w[i] - w[i - 1]);
        std::array::from_fn(|c| self.rgb[i - 1][c] * (1.0 - t) + self.rgb[i][c] * t)
    }
}

/// `count` wavelengths evenly spaced from 400 to 700 nm (the paper's range, `VISIBLE_BAND_UM`, which
/// the design library's glasses must cover), in um. Written as 0.4 + 0.3 t rather than from the band's
/// ends: 0.7 - 0.4 is not 0.3 in f64, and the wavelengths are part of every PSF cache key.
pub fn visible_wavelengths_um(count: usize) -> Vec<f64> {
    match count {
        0 => Vec::new(),
        1 => vec![0.55],
        n => (0..n).map(|i| 0.4 + 0.3 * i as f64 / (n - 1) as f64).collect(),
    }
}

/// Per-wavelength weights of each channel (each channel's weights sum to 1), for the wavelengths that
/// matter to at least one channel; the others are dropped so no PSF is traced for them.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpectralWeights {
    pub wavelengths_um: Vec<f64>,
    pub weights: Vec<[f64; 3]>,
    /// Wavelengths dropped because no channel responds there.
    pub skipped_um: Vec<f64>,
}

impl SpectralWeights {
    /// Equal-energy illuminant times the camera response.
    pub fn new(response: &SpectralResponse, wavelengths_um: &[f64]) -> SpectralWeights {
        let raw: Vec<[f64; 3]> = wavelengths_um.iter().map(|w| response.at(w * 1e3)).collect();
        let peak: [f64; 3] = std::array::from_fn(|c| raw.iter().map(|r| r[c]).fold(0.0, f64::max));
        let mut kept = SpectralWeights {
            wavelengths_um: Vec::new(),
            weights: Vec::new(),
            skipped_um: Vec::new(),
        };
        for (w, r) in wavelengths_um.iter().zip(&raw) {
            if (0..3).any(|c| peak[c] > 0.0 && r[c] > NEGLIGIBLE_RESPONSE * peak[c]) {
                kept.wavelengths_um.push(*w);
                kept.weights.push(*r);
            } else {
                kept.skipped_um.push(*w);
            }
        }
        let sums: [f64; 3] = std::array::from_fn(|c| kept.weights.iter().map(|r| r[c]).sum());
        for r in &mut kept.weights {
            for c in 0..3 {
                r[c] = if sums[c] > 0.0 { r[c] / sums[c] } else { 0.0 };
            }
        }
        kept
    }

    /// A single wavelength with weight 1 in every channel (monochromatic PSFs).
    pub fn monochromatic(wavelength_um: f64) -> SpectralWeights {
        SpectralWeights {
            wavelengths_um: vec![wavelength_um],
            weights: vec![[1.0; 3]],
            skipped_um: Vec::new(),
        }
    }
}

/// Per-channel kernels from per-wavelength kernels (each scaled to the energy that arrived, i.e. not
/// normalised) and the fraction of light that arrived at each wavelength. Returns the kernels, each
/// normalised to unit sum, the energy each channel lost outside the kernel, and the spectrally weighted
/// transmission averaged over the channels. Shared by the geometric and wave-optics paths.
pub fn combine_channels(
    per_wavelength: &[&Kernel],
    arrived_fraction: &[f64],
    weights: &SpectralWeights,
    channels: usize,
) -> (Vec<Kernel>, Vec<f64>, f64) {
    let (size, pitch) = (per_wavelength[0].size, per_wavelength[0].pitch_um);
    let mut kernels = Vec::with_capacity(channels);
    let mut energy_cut = Vec::with_capacity(channels);
    let mut transmission = 0.0;
    for c in 0..channels {
        let mut kernel = Kernel::zeros(size, pitch);
        let mut arrived = 0.0;
        for ((k, fraction), w) in per_wavelength.iter().zip(arrived_fraction).zip(&weights.weights) {
            kernel.add_scaled(k, w[c] as f32);
            arrived += w[c] * fraction;
        }
        let inside = kernel.sum();
        energy_cut.push(if arrived > 0.0 {
            (1.0 - inside / arrived).max(0.0)
        } else {
            0.0
        });
        transmission += arrived / channels as f64;
        kernel.normalise();
        kernels.push(kernel);
    }
    (kernels, energy_cut, transmission)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn visible_wavelengths_span_the_visible_band() {
        let w = visible_wavelengths_um(31);
        assert_eq!([w[0], w[30]], unicac_optics::material::VISIBLE_BAND_UM);
    }

    #[test]
    fn default_curves_peak_in_the_right_order() {
        let response = SpectralResponse::default_camera();
        let peak = |c: usize| {
            (400..=700)
                .step_by(5)
                .map(|nm| (nm, response.at(nm as f64)[c]))
                .fold((0, 0.0), |m, v| if v.1 > m.1 { v } else { m })
                .0
        };
        assert!(
            peak(2) < peak(1) && peak(1) < peak(0),
            "B {} G {} R {}",
            peak(2),
            peak(1),
            peak(0)
        );
    }

    #[test]
    fn weights_sum_to_one_per_channel_and_dead_wavelengths_are_skipped() {
        let response = SpectralResponse::from_csv(
            "wavelength_nm,r,g,b\n400,0,0,1\n500,0,1,1\n600,1,1,0\n700,1,0,0\n",
            Path::new("t.csv"),
        )
        .unwrap();
        let weights = SpectralWeights::new(&response, &[0.38, 0.4, 0.5, 0.6, 0.7, 0.75]);
        assert_eq!(weights.skipped_um, vec![0.38, 0.75]);
        for c in 0..3 {
            let sum: f64 = weights.weights.iter().map(|w| w[c]).sum();
            assert!((sum - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn bad_csv_names_the_line() {
        let err =
            SpectralResponse::from_csv("wavelength_nm,r,g,b\n400,0,0,1\n500,0,x,1\n", Path::new("c.csv"))
                .unwrap_err();
        assert!(err.to_string().starts_with("c.csv:3:"), "{err}");
    }
}
