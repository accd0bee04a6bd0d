//! `unicac design`: automatic lens design into a lens library (crates/unicac-design, docs/design.md).

use crate::args::DesignArgs;
use crate::progress_display::ProgressDisplay;
use anyhow::{bail, Result};
use std::sync::Mutex;
use unicac_design::library::Library;
use unicac_design::run::{run_specs, Event, RunSettings, StopReason};
use unicac_design::{DesignError, DesignSpec, FocalLength, Grid};
use unicac_io::progress::Progress;

fn focal_length(args: &DesignArgs) -> FocalLength {
    match (args.sensor, args.focal_length_mm) {
        (Some(sensor), _) => FocalLength::FillsSensor(sensor),
        (None, Some(focal_length_mm)) => FocalLength::Fixed { focal_length_mm },
        (None, None) => FocalLength::DEFAULT,
    }
}

fn specs(args: &DesignArgs) -> Result<Vec<DesignSpec>> {
    if args.grid {
        let grid = Grid {
            elements: args.grid_elements.clone(),
            half_fovs_deg: args.grid_half_fov_deg.clone(),
            f_numbers: args.grid_f_numbers.clone(),
            stops: args.grid_stops.clone(),
        };
        return grid
            .specs(focal_length(args), args.aspheric)
            .map_err(|e| flag_error(e, args));
    }
    let (Some(elements), Some(half_fov_deg), Some(f_number), Some(stop)) =
        (args.elements, args.half_fov_deg, args.f_number, args.stop)
    else {
        bail!("give --elements, --half-fov-deg, --f-number and --stop (or --grid)");
    };
    let focal_length_mm = focal_length(args).for_half_fov_deg(half_fov_deg);
    let mut spec = DesignSpec::new(elements, half_fov_deg, f_number, stop, focal_length_mm)
        .map_err(|e| flag_error(e, args))?;
    spec.aspheric = args.aspheric;
    Ok(vec![spec])
}

/// One line of `--list-specs`: the slug, and the `--grid-*` values that select exactly this spec.
fn spec_line(spec: &DesignSpec) -> serde_json::Value {
    serde_json::json!({
        "slug": spec.slug(),
        "grid_elements": spec.elements,
        "grid_half_fov_deg": spec.half_fov_deg,
        "grid_f_numbers": spec.f_number,
        "grid_stops": spec.stop.name(),
        "focal_length_mm": spec.focal_length_mm,
        "aspheric": spec.aspheric,
    })
}

/// The edge-thickness flags applied to every spec, each spec checked again with them.
fn with_edge_limits(mut specs: Vec<DesignSpec>, args: &DesignArgs) -> Result<Vec<DesignSpec>> {
    for spec in &mut specs {
        if let Some(v) = args.min_air_edge_mm {
            spec.constraints.air_edge_min_mm = v;
        }
        if let Some(v) = args.min_glass_edge_mm {
            spec.constraints.glass_edge_min_mm = v;
        }
        spec.validate().map_err(|e| flag_error(e, args))?;
    }
    Ok(specs)
}

/// The design library's setting error in this face's words: the flag for the library's field.
fn flag_error(error: DesignError, args: &DesignArgs) -> anyhow::Error {
    let DesignError::InvalidSpec { field, message } = &error else {
        return error.into();
    };
    let flag = match (field.as_str(), args.grid) {
        ("focal_length_mm", _) if args.sensor.is_some() => "--sensor (the focal length it gives)".to_string(),
        ("constraints.air_edge_min_mm", _) => "--min-air-edge-mm".into(),
        ("constraints.glass_edge_min_mm", _) => "--min-glass-edge-mm".into(),
        ("elements", true) => "--grid-elements".into(),
        ("half_fov_deg", true) => "--grid-half-fov-deg".into(),
        ("f_number", true) => "--grid-f-numbers".into(),
        ("stop", true) => "--grid-stops".into(),
        (field, _) => format!("--{}", field.replace('_', "-")),
    };
    anyhow::anyhow!("{flag}: {message}")
}

/// Every setting, checked before the library folder is opened (or made).
fn settings(args: &DesignArgs) -> Result<RunSettings> {
    let mut settings = RunSettings::new(args.count, args.seed);
    settings.first_acceptable = args.first_acceptable;
    settings.curriculum = !args.no_curriculum;
    settings.time_budget_s = args.time_budget_s;
    settings.evaluations_per_spec = args.evaluations_per_spec;
    settings.max_rms_um = args.max_rms_um;
    settings.gradient = args.gradient;
    if args.time_budget_s.is_some() || args.evaluations_per_spec.is_some() {
        // With a budget, keep searching (new rounds) until the lenses are found or it is spent.
        settings.rounds = usize::MAX;
    }
    settings.validate().map_err(|e| flag_error(e, args))?;
    Ok(settings)
}

pub fn run(args: &DesignArgs) -> Result<()> {
    let settings = settings(args)?;
    let specs = specs(args).map_err(|e| match e.downcast::<DesignError>() {
        Ok(design) => flag_error(design, args),
        Err(other) => other,
    })?;
    let specs = with_edge_limits(specs, args)?;
    if args.list_specs {
        for spec in &specs {
            println!("{}", spec_line(spec));
        }
        return Ok(());
    }
    let mut library = Library::open(&args.out)?;
    let display = ProgressDisplay::new("design");
    display.stage("designs kept", specs.len() * args.count);
    // Kept designs per specification; the bar shows their sum, each capped at --count (a design
    // replaced by a better one is accepted first, then dropped).
    let kept: std::collections::BTreeMap<String, usize> = specs
        .iter()
        .map(|s| {
            let slug = s.slug();
            let count = library.rows_for(&slug).filter(|r| !r.aspheric).count();
            (slug, count)
        })
        .collect();
    let capped = |kept: &std::collections::BTreeMap<String, usize>| -> usize {
        kept.values().map(|&n| n.min(args.count)).sum()
    };
    display.advance(capped(&kept));
    let kept = Mutex::new(kept);
    let change_kept = |slug: &str, added: bool| {
        let mut kept = kept.lock().unwrap_or_else(|e| e.into_inner());
        let before = capped(&kept);
        let n = kept.entry(slug.to_string()).or_insert(0);
        *n = if added { *n + 1 } else { n.saturating_sub(1) };
        let after = capped(&kept);
        if after > before {
            display.advance(after - before);
        }
    };
    let rejected = Mutex::new(0usize);
    let events = |event: Event| match event {
        Event::SpecStarted { slug, index, total } => {
            display.status(&format!("{slug} ({}/{total})", index + 1))
        }
        Event::Generation { slug, progress } => display.status(&format!(
            "{slug} gen {} best merit {:.1}",
            progress.generation, progress.best_merit
        )),
        Event::Accepted {
            slug,
            id,
            aspheric,
            rms_mean_um,
        } => {
            if !aspheric {
                change_kept(&slug, true);
            }
            display.note(&format!("accepted {id}: mean RMS spot {rms_mean_um:.2} um"));
        }
        Event::Rejected { .. } => *rejected.lock().unwrap_or_else(|e| e.into_inner()) += 1,
        Event::Replaced {
            slug,
            id,
            rms_mean_um,
        } => {
            change_kept(&slug, false);
            display.note(&format!(
                "replaced {id} (mean RMS spot {rms_mean_um:.2} um) by a better design"
            ));
        }
        Event::Note { message, .. } => display.note(&format!("warning: {message}")),
        Event::SpecDone { .. } => {}
    };
    let summaries = run_specs(&specs, &settings, &mut library, &events)?;
    display.finish();
    let written = library.rows.len();
    for s in &summaries {
        let best = s.best_rms_mean_um.map_or(String::new(), |rms| {
            let verdict = if rms <= s.good_rms_um { "good" } else { "poor" };
            format!(
                "; best mean RMS spot {rms:.2} um ({verdict}: the bar is {:.1} um, 10 Airy radii)",
                s.good_rms_um
            )
        });
        eprintln!(
            "{}: {} kept, stopped: {} after {} search round(s), {:.1} s, {} merit evaluations{best}",
            s.slug,
            s.accepted,
            match s.stop_reason {
                StopReason::CountReached => "first acceptable designs found (--first-acceptable)",
                StopReason::Converged => "converged (no better design in the last rounds)",
                StopReason::Budget => "time budget used",
                StopReason::EvaluationBudget => "evaluation budget used (--evaluations-per-spec)",
                StopReason::RoundsDone => "search rounds done",
                StopReason::AlreadyDone => "finished by an earlier run (same seed and library)",
            },
            s.rounds,
            s.elapsed_s,
            s.evaluations
        );
    }
    eprintln!(
        "{written} lenses in {} ({} rejected this run); manifest: {}",
        args.out.display(),
        rejected.into_inner().unwrap_or_else(|e| e.into_inner()),
        args.out.join("manifest.csv").display()
    );
    if args.json {
        let rows: Vec<serde_json::Value> = summaries
            .iter()
            .map(|s| {
                serde_json::json!({
                    "spec": s.slug, "accepted": s.accepted,
                    "first_accepted_s": s.first_accepted_s, "elapsed_s": s.elapsed_s,
                    "stop_reason": s.stop_reason, "rounds": s.rounds,
                    "best_rms_mean_um": s.best_rms_mean_um, "good_rms_um": s.good_rms_um,
                    "evaluations": s.evaluations,
                })
            })
            .collect();
        super::print_json(&serde_json::json!({ "specs": rows, "lenses": library.rows }))?;
    }
    Ok(())
}
