//! `unicac design`: automatic lens design into a lens library (crates/unicac-design, docs/design.md).

use crate::args::DesignArgs;
use anyhow::{bail, Result};
use std::sync::Mutex;
use unicac_design::library::Library;
use unicac_design::local::Gradient;
use unicac_design::run::{run_specs, Event, RunSettings, StopReason};
use unicac_design::spec::{
    focal_length_for_sensor, paper_grid, GRID_ELEMENTS, GRID_F_NUMBERS, GRID_HALF_FOV_DEG, GRID_STOPS,
};
use unicac_design::{DesignError, DesignSpec};

fn focal_length(args: &DesignArgs, half_fov_deg: f64) -> Result<f64> {
    match (&args.sensor, args.focal_length_mm) {
        (Some(sensor), _) => {
            let parts: Vec<f64> = sensor
                .split('x')
                .map(|p| p.trim().parse::<f64>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| anyhow::anyhow!("--sensor {sensor}: expected WIDTHxHEIGHT in mm, e.g. 36x24"))?;
            let [w, h] = parts[..] else {
                bail!("--sensor {sensor}: expected WIDTHxHEIGHT in mm, e.g. 36x24");
            };
            if !(w > 0.0 && h > 0.0) {
                bail!("--sensor {sensor}: width and height must be positive");
            }
            Ok(focal_length_for_sensor(0.5 * w.hypot(h), half_fov_deg))
        }
        (None, Some(f)) => Ok(f),
        (None, None) => Ok(50.0),
    }
}

fn specs(args: &DesignArgs) -> Result<Vec<DesignSpec>> {
    if args.grid {
        let or = |given: &Vec<f64>, default: &[f64]| {
            if given.is_empty() {
                default.to_vec()
            } else {
                given.clone()
            }
        };
        let elements = if args.grid_elements.is_empty() {
            GRID_ELEMENTS.to_vec()
        } else {
            args.grid_elements.clone()
        };
        let stops = if args.grid_stops.is_empty() {
            GRID_STOPS.to_vec()
        } else {
            args.grid_stops.clone()
        };
        let mut all = Vec::new();
        // With --sensor the focal length follows each half field.
        for h in or(&args.grid_half_fov_deg, &GRID_HALF_FOV_DEG) {
            all.extend(paper_grid(
                &elements,
                &[h],
                &or(&args.grid_f_numbers, &GRID_F_NUMBERS),
                &stops,
                focal_length(args, h)?,
                args.aspheric,
            )?);
        }
        all.sort_by_key(|s| s.elements);
        return Ok(all);
    }
    let (Some(elements), Some(half_fov_deg), Some(f_number), Some(stop)) =
        (args.elements, args.half_fov_deg, args.f_number, args.stop)
    else {
        bail!("give --elements, --half-fov-deg, --f-number and --stop (or --grid)");
    };
    let mut spec = DesignSpec::new(
        elements,
        half_fov_deg,
        f_number,
        stop,
        focal_length(args, half_fov_deg)?,
    )?;
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
    settings.time_budget_s = args.time_budget_s;
    settings.max_rms_um = args.max_rms_um;
    settings.gradient = if args.gradient == "fd" {
        Gradient::FiniteDifference
    } else {
        Gradient::Exact
    };
    if args.time_budget_s.is_some() {
        // With a budget, keep searching (new rounds) until the lenses are found or time is up.
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
    let bar = super::progress(specs.len() * args.count, "design");
    let initial: usize = specs
        .iter()
        .map(|s| {
            library
                .rows_for(&s.slug())
                .filter(|r| !r.aspheric)
                .count()
                .min(args.count)
        })
        .sum();
    bar.set_position(initial as u64);
    let rejected = Mutex::new(0usize);
    let events = |event: Event| match event {
        Event::SpecStarted { slug, index, total } => {
            bar.set_message(format!("{slug} ({}/{total})", index + 1))
        }
        Event::Generation { slug, progress } => bar.set_message(format!(
            "{slug} gen {} best merit {:.1}",
            progress.generation, progress.best_merit
        )),
        Event::Accepted {
            id,
            aspheric,
            rms_mean_um,
            ..
        } => {
            if !aspheric {
                bar.inc(1);
            }
            bar.println(format!("accepted {id}: mean RMS spot {rms_mean_um:.2} um"));
        }
        Event::Rejected { .. } => *rejected.lock().unwrap_or_else(|e| e.into_inner()) += 1,
        Event::Replaced { id, rms_mean_um, .. } => {
            bar.dec(1);
            bar.println(format!(
                "replaced {id} (mean RMS spot {rms_mean_um:.2} um) by a better design"
            ));
        }
        Event::Note { message, .. } => bar.println(format!("warning: {message}")),
        Event::SpecDone { .. } => {}
    };
    let summaries = run_specs(&specs, &settings, &mut library, &events)?;
    bar.finish_and_clear();
    let written = library.rows.len();
    for s in &summaries {
        eprintln!(
            "{}: {} kept, stopped: {} after {} search round(s), {:.1} s",
            s.slug,
            s.accepted,
            match s.stop_reason {
                StopReason::CountReached => "first acceptable designs found (--first-acceptable)",
                StopReason::Converged => "converged (no better design in the last rounds)",
                StopReason::Budget => "time budget used",
                StopReason::RoundsDone => "search rounds done",
                StopReason::AlreadyDone => "finished by an earlier run (same seed and library)",
            },
            s.rounds,
            s.elapsed_s
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
                })
            })
            .collect();
        super::print_json(&serde_json::json!({ "specs": rows, "lenses": library.rows }))?;
    }
    Ok(())
}
