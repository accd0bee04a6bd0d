//! One lens, one source: the same optical model given twice under different names (a built-in lens and
//! its JSON file, a copy with a trailing newline, its `.zmx` conversion) would get two lens ids and could
//! land in two splits, leaking test lenses into training. Refused before any work, naming both sources.

use super::grading::{model_fingerprint, BuildSensor};
use super::sources::LensSource;
use crate::error::{DatasetError, Result};
use std::collections::HashMap;
use unicac_optics::Lens;

/// Refuses two sources (of different lens ids) whose lenses are the same model on the build sensor.
pub fn refuse_duplicate_models(sources: &[LensSource], lenses: &[Lens], sensor: &BuildSensor) -> Result<()> {
    let mut first_by_model: HashMap<String, &LensSource> = HashMap::new();
    for (source, lens) in sources.iter().zip(lenses) {
        let model = model_fingerprint(&sensor.apply(lens));
        if let Some(first) = first_by_model.insert(model, source) {
            // Named in a stable order (sources are sorted by lens id, which hides the arguments' order).
            let (a, b) = if first.source <= source.source {
                (&first.source, &source.source)
            } else {
                (&source.source, &first.source)
            };
            return Err(DatasetError::setting(
                "lenses",
                format!("{a} and {b} are the same lens (the same optical model on the build's sensor, in files of different bytes or names): it would be graded twice and could land in two splits; give it once"),
            ));
        }
    }
    Ok(())
}
