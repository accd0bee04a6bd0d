//! From continuous model glasses to real ones: each element's (nd, Vd) goes to the nearest catalogue
//! glass in the normalised glass map (nd / 0.1, Vd / 10), the glass variables are dropped, and the
//! caller re-optimises the rest (the EFL and focus solves absorb the index change at once).

use crate::merit::{design_glasses, GLASS_MAP_SCALE};
use crate::params::{Parameterization, Target};
use crate::system::Material;
use std::sync::Arc;
use unicac_optics::material::Glass;

/// The catalogue glass nearest to (nd, Vd).
pub fn nearest_glass(nd: f64, vd: f64, glasses: &[Arc<Glass>]) -> Option<Arc<Glass>> {
    let distance = |g: &Arc<Glass>| {
        let (gn, gv) = (g.nd.unwrap_or(f64::NAN), g.vd.unwrap_or(f64::NAN));
        ((nd - gn) / GLASS_MAP_SCALE[0]).powi(2) + ((vd - gv) / GLASS_MAP_SCALE[1]).powi(2)
    };
    glasses
        .iter()
        .filter(|g| distance(g).is_finite())
        .min_by(|a, b| distance(a).total_cmp(&distance(b)))
        .cloned()
}

/// Snaps every model glass of the design at x; returns the parameterisation without glass variables
/// and the x that reproduces the snapped prescription.
pub fn snap(params: &Parameterization, x: &[f64]) -> Option<(Parameterization, Vec<f64>)> {
    let mut p = params.decode(x)?;
    let glasses = design_glasses();
    for s in &mut p.surfaces {
        if let Material::Model { nd, vd } = s.after {
            s.after = Material::Catalog(nearest_glass(nd, vd, &glasses)?);
        }
    }
    let snapped = params.restricted(p.clone(), |v| !matches!(v.target, Target::Nd(_) | Target::Vd(_)));
    let x = snapped.encode(&p);
    Some((snapped, x))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn n_bk7_coordinates_snap_to_a_bk7_type_glass() {
        let glass = nearest_glass(1.5168, 64.17, &design_glasses()).unwrap();
        assert!(
            (glass.nd.unwrap() - 1.5168).abs() < 2e-3,
            "{}",
            glass.qualified_name()
        );
        assert!(
            (glass.vd.unwrap() - 64.17).abs() < 0.5,
            "{}",
            glass.qualified_name()
        );
    }

    /// A library lens must be gradable by the ODE and the simulator (400-700 nm): every design glass
    /// gives an index at both ends of that band, and a glass whose data start at 435.8 nm (it made a
    /// `reproduce.sh` dataset build refuse a designed lens) is not offered.
    #[test]
    fn design_glasses_cover_the_simulated_band() {
        use unicac_optics::material::{Medium, VISIBLE_BAND_UM};
        let glasses = design_glasses();
        assert!(glasses.len() > 100, "{} glasses", glasses.len());
        for glass in &glasses {
            let medium = Medium::Catalog(glass.clone());
            for wavelength in VISIBLE_BAND_UM {
                assert!(
                    medium.index(wavelength).is_ok(),
                    "{} at {wavelength} um",
                    glass.qualified_name()
                );
            }
        }
        assert!(glasses.iter().all(|g| g.qualified_name() != "CDGM:D-ZF93-25"));
        let excluded = unicac_optics::material::find_glass("CDGM:D-ZF93-25", &[]);
        assert!(
            excluded.is_ok(),
            "the glass exists in the catalogue: {excluded:?}"
        );
    }
}
