//! The reference lenses of `lenses/`, embedded at compile time so that the CLI (`builtin:NAME`), tests,
//! benches and demos all use the same files without needing the repository at run time.

use crate::error::{OpticsError, Result};
use crate::format::json;
use crate::lens::Lens;
use crate::spec::LensSpec;
use std::path::Path;

/// (name, JSON text) of every bundled lens.
pub const LENSES: &[(&str, &str)] = &[
    ("singlet", include_str!("../../../lenses/singlet.json")),
    ("achromat", include_str!("../../../lenses/achromat.json")),
    (
        "cooke_triplet",
        include_str!("../../../lenses/cooke_triplet.json"),
    ),
    ("double_gauss", include_str!("../../../lenses/double_gauss.json")),
    ("petzval", include_str!("../../../lenses/petzval.json")),
    ("wide_angle", include_str!("../../../lenses/wide_angle.json")),
    (
        "phone_asphere",
        include_str!("../../../lenses/phone_asphere.json"),
    ),
];

/// How a LENS argument names a bundled lens: `builtin:NAME`.
pub const BUILTIN_PREFIX: &str = "builtin:";

/// A LENS argument as every face takes it: `builtin:NAME` (a bundled lens) or the path of a `.json` /
/// `.zmx` file, read into its spec with the reader's warnings (which the face shows).
pub fn resolve_spec(argument: &Path) -> Result<crate::format::LoadedSpec> {
    if let Some(name) = argument.to_str().and_then(|a| a.strip_prefix(BUILTIN_PREFIX)) {
        return Ok(crate::format::LoadedSpec {
            spec: spec(name)?,
            warnings: Vec::new(),
        });
    }
    crate::format::read_spec(argument)
}

/// Whether a LENS argument names a bundled lens rather than a file.
pub fn is_builtin(argument: &str) -> bool {
    argument.starts_with(BUILTIN_PREFIX)
}

pub fn names() -> impl Iterator<Item = &'static str> {
    LENSES.iter().map(|(name, _)| *name)
}

/// The spec of a bundled lens.
pub fn spec(name: &str) -> Result<LensSpec> {
    let (_, text) = LENSES.iter().find(|(n, _)| *n == name).ok_or_else(|| {
        OpticsError::invalid(
            "builtin",
            format!(
                "no bundled lens '{name}' (have: {})",
                names().collect::<Vec<_>>().join(", ")
            ),
        )
    })?;
    json::parse(text.as_bytes(), Path::new(&format!("builtin:{name}")))
}

/// A bundled lens, validated.
pub fn lens(name: &str) -> Result<Lens> {
    Lens::from_spec(&spec(name)?)
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_bundled_lens_is_valid() {
        for name in super::names() {
            let lens = super::lens(name).unwrap_or_else(|e| panic!("{name}: {e}"));
            let first = lens.first_order().unwrap();
            assert!(first.efl_mm.is_finite() && first.efl_mm > 0.0, "{name}");
        }
    }
}
