//! The aspheric stage: chosen surfaces of a finished spherical design become even aspheres (conic and
//! r^4 .. r^10) and the design is re-optimised. The merit's `asphere_departure` (from the best-fit
//! sphere) and `surface_slope` checks keep the shapes manufacturable.
//!
//! Which surfaces: the lens surface nearest the stop (where all field beams overlap: spherical
//! aberration) and the one farthest from it (where the field beams separate: astigmatism, distortion),
//! as designers place aspheres in photographic lenses.

use crate::params::Parameterization;
use crate::system::Prescription;

/// The lens surfaces to make aspheric (distinct, at most two).
pub fn choose_surfaces(p: &Prescription<f64>) -> Vec<usize> {
    let stop = p.stop_index() as i64;
    let lens: Vec<usize> = (0..p.surfaces.len())
        .filter(|&i| !p.surfaces[i].is_stop)
        .collect();
    let by_distance = |i: &&usize| (**i as i64 - stop).abs();
    let nearest = lens.iter().min_by_key(by_distance).copied();
    let farthest = lens.iter().max_by_key(by_distance).copied();
    let mut chosen: Vec<usize> = nearest.into_iter().chain(farthest).collect();
    chosen.dedup();
    chosen
}

/// The aspheric parameterisation of the design at x and the x that reproduces it (polynomials zero).
pub fn asphericize(
    params: &Parameterization,
    x: &[f64],
    semi_diameters_mm: &[f64],
    departure_mm: f64,
) -> Option<(Parameterization, Vec<f64>)> {
    let p = params.decode(x)?;
    let surfaces: Vec<(usize, f64)> = choose_surfaces(&p)
        .into_iter()
        .map(|i| (i, semi_diameters_mm.get(i).copied().unwrap_or(1.0)))
        .collect();
    let aspheric = params.with_aspheres(p.clone(), &surfaces, departure_mm);
    let mut p = p;
    for &(i, _) in &surfaces {
        p.surfaces[i].is_asphere = true;
    }
    let x = aspheric.encode(&p);
    Some((aspheric, x))
}
