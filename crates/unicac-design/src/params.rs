//! The design variables: which prescription values vary, their bounds, and the map between a normalised
//! vector x in [0, 1]^n and a prescription. Two values are solved, not searched (as Zemax solves):
//! - the curvature of the last lens surface sets the EFL to the target (paraxial angle solve);
//! - the image distance is the paraxial back focus plus a `defocus` variable.
//!
//! Both solves run inside `decode`, generic over `Scalar`, so gradients flow through them exactly.

use crate::scalar::Scalar;
use crate::spec::{DesignSpec, StopPosition};
use crate::system::{Material, Prescription, Surf, ASPHERE_TERMS};
use crate::tracer::{paraxial, paraxial_ray};

/// What a variable sets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    Curvature(usize),
    Thickness(usize),
    Conic(usize),
    /// (surface, term): term j multiplies r^(2j + 4).
    Asphere(usize, usize),
    /// Model glass of the element whose front surface is this one.
    Nd(usize),
    Vd(usize),
    Defocus,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Variable {
    pub target: Target,
    pub lo: f64,
    pub hi: f64,
}

impl Variable {
    #[inline]
    pub fn value<S: Scalar>(&self, x: S) -> S {
        x * (self.hi - self.lo) + self.lo
    }

    pub fn normalise(&self, value: f64) -> f64 {
        (value - self.lo) / (self.hi - self.lo)
    }
}

/// Bounds of the model glass (nd, Vd): the optical glasses of the shipped catalogues.
pub const ND_RANGE: [f64; 2] = [1.44, 2.0];
pub const VD_RANGE: [f64; 2] = [18.0, 95.0];

/// The design variables of one spec at one stage (spherical, snapped glasses, aspheric).
#[derive(Debug, Clone)]
pub struct Parameterization {
    pub base: Prescription<f64>,
    pub variables: Vec<Variable>,
    /// The surface whose curvature the EFL solve sets.
    pub efl_surface: usize,
    pub focal_length_mm: f64,
    pub primary_wavelength_um: f64,
}

impl Parameterization {
    /// The spherical stage: every curvature but the solved one, every gap but the image distance, model
    /// glasses, defocus.
    pub fn spherical(spec: &DesignSpec) -> Parameterization {
        let c = &spec.constraints;
        let elements = spec.elements;
        let stop_before = match spec.stop {
            StopPosition::Front => 0,
            StopPosition::Middle => elements / 2,
            StopPosition::Back => elements,
        };
        let air = |is_stop| Surf {
            curvature: 0.0,
            conic: 0.0,
            asphere: [0.0; ASPHERE_TERMS],
            is_asphere: false,
            thickness: c.air_center_mm[0],
            after: Material::Air,
            is_stop,
        };
        let mut surfaces = Vec::new();
        for e in 0..=elements {
            if e == stop_before {
                surfaces.push(air(true));
            }
            if e < elements {
                surfaces.push(Surf {
                    after: Material::Model { nd: 1.6, vd: 50.0 },
                    thickness: c.glass_center_mm[0],
                    ..air(false)
                });
                surfaces.push(air(false));
            }
        }
        let efl_surface = surfaces.iter().rposition(|s| !s.is_stop).unwrap_or(0);
        let c_max = c.curvature_max_times_f / spec.focal_length_mm;
        let last = surfaces.len() - 1;
        let mut variables = Vec::new();
        for (i, s) in surfaces.iter().enumerate() {
            if !s.is_stop && i != efl_surface {
                variables.push(Variable {
                    target: Target::Curvature(i),
                    lo: -c_max,
                    hi: c_max,
                });
            }
            if i != last {
                let [lo, hi] = if s.after.is_air() {
                    c.air_center_mm
                } else {
                    c.glass_center_mm
                };
                variables.push(Variable {
                    target: Target::Thickness(i),
                    lo,
                    hi,
                });
            }
            if !s.after.is_air() {
                variables.push(Variable {
                    target: Target::Nd(i),
                    lo: ND_RANGE[0],
                    hi: ND_RANGE[1],
                });
                variables.push(Variable {
                    target: Target::Vd(i),
                    lo: VD_RANGE[0],
                    hi: VD_RANGE[1],
                });
            }
        }
        let defocus = 0.02 * spec.focal_length_mm;
        variables.push(Variable {
            target: Target::Defocus,
            lo: -defocus,
            hi: defocus,
        });
        Parameterization {
            base: Prescription { surfaces },
            variables,
            efl_surface,
            focal_length_mm: spec.focal_length_mm,
            primary_wavelength_um: spec.primary_wavelength_um(),
        }
    }

    pub fn len(&self) -> usize {
        self.variables.len()
    }

    pub fn is_empty(&self) -> bool {
        self.variables.is_empty()
    }

    /// The prescription at x, with the EFL and focus solves applied; `None` when a solve is singular.
    pub fn decode<S: Scalar>(&self, x: &[S]) -> Option<Prescription<S>> {
        let mut p: Prescription<S> = self.base.lift();
        let mut defocus = S::cst(0.0);
        for (v, &xi) in self.variables.iter().zip(x) {
            let value = v.value(xi);
            match v.target {
                Target::Curvature(i) => p.surfaces[i].curvature = value,
                Target::Thickness(i) => p.surfaces[i].thickness = value,
                Target::Conic(i) => p.surfaces[i].conic = value,
                Target::Asphere(i, j) => p.surfaces[i].asphere[j] = value,
                Target::Nd(i) => {
                    if let Material::Model { nd, .. } = &mut p.surfaces[i].after {
                        *nd = value;
                    }
                }
                Target::Vd(i) => {
                    if let Material::Model { vd, .. } = &mut p.surfaces[i].after {
                        *vd = value;
                    }
                }
                Target::Defocus => defocus = value,
            }
        }
        // EFL solve: the last lens surface bends the (y = 1, nu = 0) ray to nu' = -1 / f. Surfaces after it
        // (a back stop) are planes in air and change nothing.
        let wavelength = self.primary_wavelength_um;
        let indices = p.indices(wavelength);
        let l = self.efl_surface;
        let (y, nu) = paraxial_ray(&p, &indices, S::cst(1.0), S::cst(0.0), l);
        let power_index = indices[l + 1] - indices[l];
        let denominator = y * power_index;
        if denominator.re().abs() < 1e-12 {
            return None;
        }
        p.surfaces[l].curvature = (nu + 1.0 / self.focal_length_mm) / denominator;
        // Focus solve.
        let first = paraxial(&p, wavelength)?;
        let last = p.surfaces.len() - 1;
        p.surfaces[last].thickness = first.bfd + defocus;
        Some(p)
    }

    /// The x that reproduces `p` (for a prescription of the same structure): each variable's current
    /// value, normalised; defocus is the image distance minus the paraxial back focus.
    pub fn encode(&self, p: &Prescription<f64>) -> Vec<f64> {
        self.variables
            .iter()
            .map(|v| {
                let value = match v.target {
                    Target::Curvature(i) => p.surfaces[i].curvature,
                    Target::Thickness(i) => p.surfaces[i].thickness,
                    Target::Conic(i) => p.surfaces[i].conic,
                    Target::Asphere(i, j) => p.surfaces[i].asphere[j],
                    Target::Nd(i) => match p.surfaces[i].after {
                        Material::Model { nd, .. } => nd,
                        _ => 1.6,
                    },
                    Target::Vd(i) => match p.surfaces[i].after {
                        Material::Model { vd, .. } => vd,
                        _ => 50.0,
                    },
                    Target::Defocus => {
                        let last = p.surfaces.len() - 1;
                        paraxial(p, self.primary_wavelength_um)
                            .map_or(0.0, |f| p.surfaces[last].thickness - f.bfd)
                    }
                };
                v.normalise(value)
            })
            .collect()
    }

    /// The same structure with `base` as the prescription and only the variables `keep` accepts.
    pub fn restricted(&self, base: Prescription<f64>, keep: impl Fn(&Variable) -> bool) -> Parameterization {
        Parameterization {
            base,
            variables: self.variables.iter().copied().filter(|v| keep(v)).collect(),
            ..self.clone()
        }
    }

    /// Adds conic and r^4..r^10 variables on `surfaces`; `semi_diameters` (mm) scale the coefficient
    /// bounds so that each term can move the edge sag by about `departure_mm`.
    pub fn with_aspheres(
        &self,
        base: Prescription<f64>,
        surfaces: &[(usize, f64)],
        departure_mm: f64,
    ) -> Parameterization {
        let mut next = self.restricted(base, |_| true);
        for &(i, semi_diameter) in surfaces {
            next.base.surfaces[i].is_asphere = true;
            next.variables.push(Variable {
                target: Target::Conic(i),
                lo: -3.0,
                hi: 3.0,
            });
            for j in 0..ASPHERE_TERMS {
                let bound = 2.0 * departure_mm / semi_diameter.max(1e-6).powi(2 * j as i32 + 4);
                next.variables.push(Variable {
                    target: Target::Asphere(i, j),
                    lo: -bound,
                    hi: bound,
                });
            }
        }
        next
    }
}

/// Distance between two designs in normalised variable space, divided by sqrt(n) (OptiFusion's
/// diversity measure).
pub fn distance(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().max(1) as f64;
    (a.iter().zip(b).map(|(u, v)| (u - v) * (u - v)).sum::<f64>() / n).sqrt()
}
