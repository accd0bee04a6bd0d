//! Seconds per stage of the ODE of every bundled lens at the defaults of docs/ode.md (the figures of
//! docs/performance.md), with the ODE values, so that a speed-up can show that they did not move.
//!
//! Run: cargo run --release -p unicac-ode --example ode_timing [REPEATS]

use unicac_ode::evaluate::{evaluate, OdeSettings, StageTimes};
use unicac_optics::builtin;

fn main() {
    let repeats: usize = std::env::args().nth(1).and_then(|r| r.parse().ok()).unwrap_or(3);
    let settings = OdeSettings::default();
    println!("lens | kernel px | chief-ray map | PSF tracing | imaging + scoring | RMS spot | total (best of {repeats}) | ODE | OIQ");
    let mut sum = 0.0;
    for name in builtin::names() {
        let lens = builtin::lens(name).expect("a bundled lens");
        let reports: Vec<_> = (0..repeats)
            .map(|_| evaluate(&lens, &settings).expect("ode"))
            .collect();
        let total =
            |t: &StageTimes| t.chief_ray_map_s + t.psf_tracing_s + t.imaging_and_scoring_s + t.rms_spot_s;
        let best = reports
            .iter()
            .min_by(|a, b| total(&a.times).total_cmp(&total(&b.times)))
            .expect("a report");
        let t = &best.times;
        sum += total(t);
        println!(
            "{name} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.6} | {:.6}",
            best.kernel_px,
            t.chief_ray_map_s,
            t.psf_tracing_s,
            t.imaging_and_scoring_s,
            t.rms_spot_s,
            total(t),
            best.scores.ode,
            best.scores.oiq
        );
    }
    println!(
        "mean total {:.3} s per lens",
        sum / builtin::names().count() as f64
    );
}
