//! The design's lens in a form the generic tracer reads: surfaces with scalar-valued shape, spacing and
//! media, so that the same code runs in f64 (merit values) and in dual numbers (exact gradients).
//!
//! Layout: element e has surfaces 2e and 2e + 1 (plus one if the stop plane comes before it); the stop is
//! a plane in air; the last surface's thickness is the image distance. The image surface is a plane.

use crate::scalar::Scalar;
use std::sync::Arc;
use unicac_optics::material::{Glass, LINE_C_UM, LINE_D_UM, LINE_F_UM};

/// Number of even-asphere terms the design uses: r^4, r^6, r^8, r^10 (no r^2: it would duplicate the
/// curvature, as in usual photographic-lens practice).
pub const ASPHERE_TERMS: usize = 4;

/// The medium after a surface.
#[derive(Debug, Clone)]
pub enum Material<S> {
    Air,
    /// A model glass (nd, Vd) with the Cauchy dispersion of `unicac_optics::material::model_glass_index`.
    Model {
        nd: S,
        vd: S,
    },
    /// A catalogue glass: its indices are constants.
    Catalog(Arc<Glass>),
}

impl<S: Scalar> Material<S> {
    /// Refractive index at `wavelength_um`. The model-glass branch is `model_glass_index` written over
    /// `Scalar` (a test checks that both agree to rounding).
    pub fn index(&self, wavelength_um: f64) -> S {
        match self {
            Material::Air => S::cst(1.0),
            Material::Model { nd, vd } => {
                let span = 1.0 / (LINE_F_UM * LINE_F_UM) - 1.0 / (LINE_C_UM * LINE_C_UM);
                let b = (*nd - 1.0) / (*vd * span);
                let a = *nd - b / (LINE_D_UM * LINE_D_UM);
                a + b / (wavelength_um * wavelength_um)
            }
            Material::Catalog(glass) => S::cst(glass.index(wavelength_um)),
        }
    }

    pub fn is_air(&self) -> bool {
        matches!(self, Material::Air)
    }
}

/// One surface of the design.
#[derive(Debug, Clone)]
pub struct Surf<S> {
    pub curvature: S,
    pub conic: S,
    /// Coefficients of r^4, r^6, r^8, r^10.
    pub asphere: [S; ASPHERE_TERMS],
    pub is_asphere: bool,
    /// Vertex to the next surface's vertex (the image plane for the last surface).
    pub thickness: S,
    pub after: Material<S>,
    pub is_stop: bool,
}

impl<S: Scalar> Surf<S> {
    /// Sag z(rho) and dz/drho, rho = r^2 (the same form as `unicac_optics::Profile`). `None` outside the
    /// conic's domain.
    #[inline]
    pub fn sag_and_slope(&self, rho: S) -> Option<(S, S)> {
        let c = self.curvature;
        let radicand = S::cst(1.0) - (self.conic + 1.0) * c * c * rho;
        if !(radicand.re() > 0.0) {
            return None;
        }
        let root = radicand.sqrt();
        let mut sag = c * rho / (root + 1.0);
        let mut slope = c / (root * 2.0);
        if self.is_asphere {
            // sum a_j rho^(j+2) and its rho-derivative by Horner's rule.
            let mut value = S::cst(0.0);
            let mut derivative = S::cst(0.0);
            for j in (0..ASPHERE_TERMS).rev() {
                derivative = derivative * rho + self.asphere[j] * (j as f64 + 2.0);
                value = value * rho + self.asphere[j];
            }
            sag = sag + value * rho * rho;
            slope = slope + derivative * rho;
        }
        Some((sag, slope))
    }
}

/// A whole design: surfaces in order (the image plane follows the last one).
#[derive(Debug, Clone)]
pub struct Prescription<S> {
    pub surfaces: Vec<Surf<S>>,
}

impl<S: Scalar> Prescription<S> {
    pub fn stop_index(&self) -> usize {
        self.surfaces.iter().position(|s| s.is_stop).unwrap_or(0)
    }

    /// Vertex z of every surface and, last, of the image plane.
    pub fn vertex_z(&self) -> Vec<S> {
        let mut z = Vec::with_capacity(self.surfaces.len() + 1);
        let mut at = S::cst(0.0);
        z.push(at);
        for s in &self.surfaces {
            at = at + s.thickness;
            z.push(at);
        }
        z
    }

    /// Indices of the media: entry 0 is object space, entry i + 1 the medium after surface i.
    pub fn indices(&self, wavelength_um: f64) -> Vec<S> {
        std::iter::once(S::cst(1.0))
            .chain(self.surfaces.iter().map(|s| s.after.index(wavelength_um)))
            .collect()
    }

    /// Indices of the surfaces that bound glass: (front, back) per element.
    pub fn elements(&self) -> Vec<(usize, usize)> {
        (0..self.surfaces.len())
            .filter(|&i| !self.surfaces[i].after.is_air())
            .map(|i| (i, i + 1))
            .collect()
    }
}

impl Prescription<f64> {
    /// The same prescription with constant scalars.
    pub fn lift<S: Scalar>(&self) -> Prescription<S> {
        Prescription {
            surfaces: self
                .surfaces
                .iter()
                .map(|s| Surf {
                    curvature: S::cst(s.curvature),
                    conic: S::cst(s.conic),
                    asphere: s.asphere.map(S::cst),
                    is_asphere: s.is_asphere,
                    thickness: S::cst(s.thickness),
                    after: match &s.after {
                        Material::Air => Material::Air,
                        Material::Model { nd, vd } => Material::Model {
                            nd: S::cst(*nd),
                            vd: S::cst(*vd),
                        },
                        Material::Catalog(g) => Material::Catalog(g.clone()),
                    },
                    is_stop: s.is_stop,
                })
                .collect(),
        }
    }
}

/// The real part of a scalar prescription.
pub fn values<S: Scalar>(p: &Prescription<S>) -> Prescription<f64> {
    Prescription {
        surfaces: p
            .surfaces
            .iter()
            .map(|s| Surf {
                curvature: s.curvature.re(),
                conic: s.conic.re(),
                asphere: s.asphere.map(|a| a.re()),
                is_asphere: s.is_asphere,
                thickness: s.thickness.re(),
                after: match &s.after {
                    Material::Air => Material::Air,
                    Material::Model { nd, vd } => Material::Model {
                        nd: nd.re(),
                        vd: vd.re(),
                    },
                    Material::Catalog(g) => Material::Catalog(g.clone()),
                },
                is_stop: s.is_stop,
            })
            .collect(),
    }
}
