//! Geometric encircled energy: the weighted fraction of the rays (N x N pupil grid, every wavelength of
//! the spectrum, each wavelength's rays sharing its weight) that land within radius r of their
//! weighted centroid, per field.

use crate::error::AnalysisResult;
use crate::pupil::Channel;
use crate::setup::{check_fields, check_pupil_grid, check_samples, linspace, vignetted, Spectrum};
use serde::Serialize;
use unicac_optics::Lens;

#[derive(Debug, Clone, Serialize)]
pub struct FieldEncircledEnergy {
    pub field_deg: f64,
    pub radii_um: Vec<f64>,
    pub energy: Vec<f64>,
    /// Smallest radii holding 50% and 80% of the energy.
    pub radius_50_um: f64,
    pub radius_80_um: f64,
    pub centroid_mm: [f64; 2],
}

#[derive(Debug, Clone, Serialize)]
pub struct EncircledEnergy {
    pub pupil_grid: usize,
    pub spectrum: Spectrum,
    pub fields: Vec<FieldEncircledEnergy>,
}

/// Ray distances from the centroid in um with their share of the energy, sorted by distance.
type WeightedDistances = Vec<(f64, f64)>;

/// Weighted distances from the weighted centroid, sorted, with the centroid.
fn weighted_distances(
    lens: &Lens,
    spectrum: &Spectrum,
    field_deg: f64,
    pupil_grid: usize,
) -> AnalysisResult<(WeightedDistances, [f64; 2])> {
    let mut rays: Vec<(f64, [f64; 2])> = Vec::new();
    for (&wavelength, &weight) in spectrum.wavelengths_um.iter().zip(&spectrum.weights) {
        let (points, _) = Channel::new(lens, wavelength)?.grid_rays(field_deg, pupil_grid);
        if weight > 0.0 && !points.is_empty() {
            let w = weight / points.len() as f64;
            rays.extend(points.into_iter().map(|p| (w, p)));
        }
    }
    let total: f64 = rays.iter().map(|r| r.0).sum();
    if rays.is_empty() || total <= 0.0 {
        return Err(vignetted(field_deg));
    }
    let centroid = rays.iter().fold([0.0; 2], |c, (w, p)| {
        [c[0] + w * p[0] / total, c[1] + w * p[1] / total]
    });
    let mut distances: Vec<(f64, f64)> = rays
        .iter()
        .map(|(w, p)| ((p[0] - centroid[0]).hypot(p[1] - centroid[1]) * 1e3, w / total))
        .collect();
    distances.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok((distances, centroid))
}

/// Encircled energy at `radii_um` (None: 101 radii from 0 to the largest ray distance of each field).
pub fn encircled_energy(
    lens: &Lens,
    spectrum: &Spectrum,
    fields_deg: &[f64],
    radii_um: Option<&[f64]>,
    pupil_grid: usize,
) -> AnalysisResult<EncircledEnergy> {
    check_fields(lens, fields_deg)?;
    spectrum.check()?;
    check_pupil_grid(pupil_grid)?;
    if let Some(radii) = radii_um {
        check_samples("radii_um", radii, true)?;
    }
    let mut fields = Vec::new();
    for &field_deg in fields_deg {
        let (distances, centroid_mm) = weighted_distances(lens, spectrum, field_deg, pupil_grid)?;
        let largest = distances.last().map_or(0.0, |d| d.0);
        let radii = radii_um.map_or_else(|| linspace(0.0, largest, 101), <[f64]>::to_vec);
        let cumulative: Vec<f64> = distances
            .iter()
            .scan(0.0, |sum, d| {
                *sum += d.1;
                Some(*sum)
            })
            .collect();
        let energy_within = |r: f64| -> f64 {
            let count = distances.partition_point(|d| d.0 <= r);
            if count == 0 {
                0.0
            } else {
                cumulative[count - 1].min(1.0)
            }
        };
        let radius_holding = |fraction: f64| -> f64 {
            let k = cumulative.partition_point(|&c| c < fraction - 1e-12);
            distances[k.min(distances.len() - 1)].0
        };
        fields.push(FieldEncircledEnergy {
            field_deg,
            energy: radii.iter().map(|&r| energy_within(r)).collect(),
            radii_um: radii,
            radius_50_um: radius_holding(0.5),
            radius_80_um: radius_holding(0.8),
            centroid_mm,
        });
    }
    Ok(EncircledEnergy {
        pupil_grid,
        spectrum: spectrum.clone(),
        fields,
    })
}
