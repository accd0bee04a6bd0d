//! The figures of docs/performance.md ("Design"): for 2-, 4- and 6-element specs, the time to the first
//! acceptable design and accepted designs per hour; and merit reached against time for the same search
//! driven by exact (dual-number) and by finite-difference gradients, as CSV and a convergence plot.
//!
//! cargo run --release -p unicac-design --example design_speed -- speed BUDGET_S OUT_DIR
//! cargo run --release -p unicac-design --example design_speed -- convergence BUDGET_S OUT_DIR
//! cargo run --release -p unicac-design --example design_speed -- jacobian
//! cargo run --release -p unicac-design --example design_speed -- local ITERATIONS OUT_DIR

use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;
use unicac_design::library::Library;
use unicac_design::local::Gradient;
use unicac_design::run::{run_specs, Event, RunSettings};
use unicac_design::{DesignSpec, StopPosition};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).map_or("speed", |s| s.as_str());
    let budget: f64 = args.get(2).map_or(Ok(60.0), |a| a.parse())?;
    let out = PathBuf::from(args.get(3).cloned().unwrap_or_else(|| "/tmp/design_speed".into()));
    std::fs::create_dir_all(&out)?;
    match mode {
        "speed" => speed(budget, &out),
        "jacobian" => jacobian(),
        "local" => local(budget, &out),
        _ => convergence(budget, &out),
    }
}

fn speed(budget: f64, out: &Path) -> Result<(), Box<dyn std::error::Error>> {
    println!("elements,spec,budget_s,first_accepted_s,accepted,designs_per_hour,best_rms_um,median_rms_um");
    for elements in [2, 4, 6] {
        let spec = DesignSpec::new(elements, 30.0, 3.0, StopPosition::Middle, 50.0)?;
        let dir = out.join(spec.slug());
        let _ = std::fs::remove_dir_all(&dir);
        let mut library = Library::open(&dir)?;
        let mut settings = RunSettings::new(100_000, 1);
        settings.time_budget_s = Some(budget);
        settings.rounds = usize::MAX;
        let summary = run_specs(std::slice::from_ref(&spec), &settings, &mut library, &|_| {})?;
        let mut rms: Vec<f64> = library.rows.iter().map(|r| r.rms_mean_um).collect();
        rms.sort_by(f64::total_cmp);
        let s = &summary[0];
        println!(
            "{elements},{},{budget},{},{},{:.0},{:.2},{:.2}",
            s.slug,
            s.first_accepted_s.map_or("-".into(), |t| format!("{t:.2}")),
            s.accepted,
            s.accepted as f64 * 3600.0 / s.elapsed_s,
            rms.first().copied().unwrap_or(f64::NAN),
            rms.get(rms.len() / 2).copied().unwrap_or(f64::NAN)
        );
    }
    Ok(())
}

/// Time of one merit value, one exact Jacobian and one finite-difference Jacobian (fine sampling).
fn jacobian() -> Result<(), Box<dyn std::error::Error>> {
    use unicac_design::local::linearise;
    use unicac_design::merit::{Merit, Sampling};
    use unicac_design::params::Parameterization;
    println!(
        "elements,variables,residuals,merit_ms,exact_jacobian_ms,fd_jacobian_ms,max_abs_difference_relative"
    );
    for elements in [2, 4, 6] {
        let spec = DesignSpec::new(elements, 20.0, 4.0, StopPosition::Middle, 50.0)?;
        let merit = Merit::new(&spec, Sampling::FINE);
        let params = Parameterization::spherical(&spec);
        let x: Vec<f64> = (0..params.len()).map(|i| 0.45 + 0.01 * (i % 5) as f64).collect();
        let time = |f: &dyn Fn()| {
            let start = Instant::now();
            let mut n = 0;
            while start.elapsed().as_secs_f64() < 1.0 {
                f();
                n += 1;
            }
            start.elapsed().as_secs_f64() * 1e3 / n as f64
        };
        let value_ms = time(&|| {
            std::hint::black_box(merit.value(&params, &x));
        });
        let exact_ms = time(&|| {
            std::hint::black_box(linearise(&merit, &params, &x, Gradient::Exact));
        });
        let fd_ms = time(&|| {
            std::hint::black_box(linearise(&merit, &params, &x, Gradient::FiniteDifference));
        });
        let a = linearise(&merit, &params, &x, Gradient::Exact).ok_or("singular")?;
        let b = linearise(&merit, &params, &x, Gradient::FiniteDifference).ok_or("singular")?;
        let scale = a.jacobian.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = a
            .jacobian
            .iter()
            .zip(&b.jacobian)
            .fold(0.0f64, |m, (u, v)| m.max((u - v).abs()));
        println!(
            "{elements},{},{},{value_ms:.3},{exact_ms:.3},{fd_ms:.3},{:.1e}",
            params.len(),
            a.residuals.len(),
            diff / scale
        );
    }
    Ok(())
}

/// The same damped-least-squares refinements from the same 16 starting designs (a 4- and a 6-element
/// spec, the global stage's archive), once with exact and once with finite-difference Jacobians, one
/// after the other on one thread: the summed merit of the 16 (each at its best so far) against time.
fn local(iterations: f64, out: &Path) -> Result<(), Box<dyn std::error::Error>> {
    use unicac_design::global::{search, GlobalSettings};
    use unicac_design::local::{refine, LocalSettings};
    use unicac_design::merit::{Merit, Sampling};
    use unicac_design::params::Parameterization;
    let mut csv = String::from("elements,gradient,time_s,summed_merit\n");
    for elements in [4, 6] {
        let spec = DesignSpec::new(elements, 20.0, 4.0, StopPosition::Middle, 50.0)?;
        let params = Parameterization::spherical(&spec);
        let coarse = Merit::new(&spec, Sampling::COARSE);
        let starts: Vec<Vec<f64>> = search(&coarse, &params, &GlobalSettings::new(3), &|_| {})
            .archive
            .into_iter()
            .take(16)
            .map(|c| c.x)
            .collect();
        let merit = Merit::new(&spec, Sampling::FINE);
        let mut curves = Vec::new();
        let mut horizon = 0.0f64;
        for gradient in [Gradient::Exact, Gradient::FiniteDifference] {
            let name = if gradient == Gradient::Exact {
                "exact"
            } else {
                "fd"
            };
            let mut current: Vec<f64> = starts
                .iter()
                .map(|x| merit.value(&params, x).unwrap_or(0.0))
                .collect();
            let start = Instant::now();
            let mut trace = vec![(0.0, current.iter().sum::<f64>(), 0.0)];
            for (k, x) in starts.iter().enumerate() {
                let settings = LocalSettings::new(iterations as usize, gradient);
                refine(&merit, &params, x, &settings, |m| {
                    current[k] = m;
                    trace.push((start.elapsed().as_secs_f64(), current.iter().sum::<f64>(), 0.0));
                });
            }
            let elapsed = start.elapsed().as_secs_f64();
            horizon = horizon.max(elapsed);
            println!(
                "{elements} elements, {name}: {} refinements of {iterations} iterations in {elapsed:.2} s, summed merit {:.1} -> {:.1}",
                starts.len(),
                trace[0].1,
                trace.last().map_or(f64::NAN, |p| p.1)
            );
            for (t, m, _) in &trace {
                csv.push_str(&format!("{elements},{name},{t:.4},{m:.4}\n"));
            }
            curves.push((name, trace));
        }
        plot(
            &curves,
            horizon,
            &format!("Local refinement of 16 designs ({elements} elements, F/4, 20 deg), one thread"),
            "summed merit of the 16",
            &out.join(format!("convergence_local_e{elements}.svg")),
        )?;
    }
    unicac_optics::io::write_atomically(&out.join("convergence_local.csv"), csv.as_bytes())?;
    Ok(())
}

/// Best merit of the global stage so far (over rounds) and best accepted RMS against time.
fn convergence(budget: f64, out: &Path) -> Result<(), Box<dyn std::error::Error>> {
    let spec = DesignSpec::new(4, 20.0, 4.0, StopPosition::Middle, 50.0)?;
    let mut csv = String::from("gradient,time_s,best_merit,best_rms_um\n");
    let mut curves = Vec::new();
    for gradient in [Gradient::Exact, Gradient::FiniteDifference] {
        let name = match gradient {
            Gradient::Exact => "exact",
            Gradient::FiniteDifference => "fd",
        };
        let dir = out.join(format!("convergence_{name}"));
        let _ = std::fs::remove_dir_all(&dir);
        let mut library = Library::open(&dir)?;
        let mut settings = RunSettings::new(100_000, 7);
        settings.time_budget_s = Some(budget);
        settings.rounds = usize::MAX;
        settings.gradient = gradient;
        let start = Instant::now();
        let points = Mutex::new((f64::INFINITY, f64::INFINITY, Vec::<(f64, f64, f64)>::new()));
        let events = |e: Event| {
            let mut state = points.lock().unwrap_or_else(|e| e.into_inner());
            match e {
                Event::Generation { progress, .. } => state.0 = state.0.min(progress.best_merit),
                Event::Accepted {
                    rms_mean_um,
                    aspheric: false,
                    ..
                } => state.1 = state.1.min(rms_mean_um),
                _ => return,
            }
            let (m, r) = (state.0, state.1);
            state.2.push((start.elapsed().as_secs_f64(), m, r));
        };
        let summary = run_specs(std::slice::from_ref(&spec), &settings, &mut library, &events)?;
        let (_, _, trace) = points.into_inner().unwrap_or_else(|e| e.into_inner());
        for (t, m, r) in &trace {
            csv.push_str(&format!("{name},{t:.3},{m:.4},{r:.4}\n"));
        }
        println!(
            "{name}: accepted {} in {:.1} s, best global merit {:.3}, best rms {:.3} um",
            summary[0].accepted,
            summary[0].elapsed_s,
            trace.last().map_or(f64::NAN, |p| p.1),
            trace.last().map_or(f64::NAN, |p| p.2)
        );
        curves.push((name, trace));
    }
    unicac_optics::io::write_atomically(&out.join("convergence.csv"), csv.as_bytes())?;
    plot(
        &curves,
        budget,
        "Whole search: best global-stage merit against time (4 elements, F/4, 20 deg)",
        "best merit (sum of squares)",
        &out.join("convergence_search.svg"),
    )?;
    Ok(())
}

type Trace = Vec<(f64, f64, f64)>;

fn plot(
    curves: &[(&str, Trace)],
    budget: f64,
    title: &str,
    y_label: &str,
    path: &Path,
) -> Result<(), Box<dyn std::error::Error>> {
    let finite = curves
        .iter()
        .flat_map(|(_, t)| t.iter().map(|p| p.1))
        .filter(|v| v.is_finite());
    let (lo, hi) = finite.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    let root = SVGBackend::new(path, (900, 540)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..budget, (lo * 0.8..hi * 1.2).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("time (s), 2 cores")
        .y_desc(y_label)
        .draw()?;
    for ((name, trace), colour) in curves.iter().zip([BLUE, RED]) {
        let label = if *name == "exact" {
            "exact gradients (dual numbers)"
        } else {
            "finite differences"
        };
        chart
            .draw_series(LineSeries::new(
                trace.iter().filter(|p| p.1.is_finite()).map(|p| (p.0, p.1)),
                colour.stroke_width(2),
            ))?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE)
        .draw()?;
    root.present()?;
    Ok(())
}
