//! The quality check of docs/design.md: design for the Cooke triplet's specification (3 elements, F/5,
//! half field 20 deg, f = 50 mm, stop in the middle) within a time budget, and compare the best design's
//! mean polychromatic RMS spot radius with the classic Cooke triplet's (lenses/cooke_triplet.json) at
//! the same fields, wavelengths, aperture and pupil sampling.
//!
//! cargo run --release -p unicac-design --example cooke_comparison -- BUDGET_S OUT_DIR [exact|fd] [COUNT]

use std::path::PathBuf;
use unicac_design::library::Library;
use unicac_design::local::Gradient;
use unicac_design::run::{run_specs, Event, RunSettings};
use unicac_design::verify::polychromatic_rms;
use unicac_design::{DesignSpec, StopPosition};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let budget: f64 = args.get(1).map_or(Ok(60.0), |a| a.parse())?;
    let out = PathBuf::from(args.get(2).cloned().unwrap_or_else(|| "/tmp/cooke_design".into()));
    let fd = args.get(3).is_some_and(|a| a == "fd");
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../lenses/cooke_triplet.json");
    let (cooke, _) = unicac_optics::load_lens(std::path::Path::new(root))?;
    let fields = [0.0, 14.0, 20.0];
    let (classic, _, _) = polychromatic_rms(&cooke, &fields)?;
    let classic_mean = classic.iter().sum::<f64>() / 3.0;
    println!("classic Cooke triplet: rms per field {classic:.2?} um, mean {classic_mean:.3} um");

    let spec = DesignSpec::new(3, 20.0, 5.0, StopPosition::Middle, 50.0)?;
    let count: usize = args.get(4).map_or(Ok(10_000), |a| a.parse())?;
    let mut settings = RunSettings::new(count, 1);
    settings.time_budget_s = Some(budget);
    settings.rounds = 100;
    if fd {
        settings.gradient = Gradient::FiniteDifference;
    }
    let mut library = Library::open(&out)?;
    let start = std::time::Instant::now();
    let events = |e: Event| match e {
        Event::Generation { progress, .. } => eprintln!(
            "{:7.1}s generation {} best merit {:.2} archive {}",
            start.elapsed().as_secs_f64(),
            progress.generation,
            progress.best_merit,
            progress.archived
        ),
        Event::Accepted { id, rms_mean_um, .. } => {
            eprintln!(
                "{:7.1}s accepted {id}: mean rms {rms_mean_um:.3} um",
                start.elapsed().as_secs_f64()
            )
        }
        Event::Rejected { reasons, .. } => {
            eprintln!("{:7.1}s rejected: {reasons:?}", start.elapsed().as_secs_f64())
        }
        _ => {}
    };
    let summaries = run_specs(&[spec], &settings, &mut library, &events)?;
    println!("{summaries:?}");
    let mut best = f64::INFINITY;
    for row in &library.rows {
        let (lens, _) = unicac_optics::load_lens(&out.join(&row.json))?;
        let (rms, _, _) = polychromatic_rms(&lens, &fields)?;
        let mean = rms.iter().sum::<f64>() / 3.0;
        println!(
            "{}: rms at 0/14/20 deg {rms:.2?} um, mean {mean:.3} um, glasses {}",
            row.id, row.glasses
        );
        best = best.min(mean);
    }
    println!(
        "best designed mean rms {best:.3} um vs classic {classic_mean:.3} um ({} lenses)",
        library.rows.len()
    );
    Ok(())
}
