//! Throughput of `unicac dataset build` for docs/performance.md: ODE seconds per lens and pairs per
//! minute at 1 MP (1280 x 800 frames, full-frame test pairs, PSF maps cached per lens), and a
//! paper-sized build extrapolated from them.
//!
//!     cargo run --release -p unicac-dataset --example dataset_speed [-- THREADS]

use std::time::Instant;
use unicac_dataset::builder::{self, BuildSettings, Shard, Silent};

fn main() {
    let threads: usize = std::env::args().nth(1).and_then(|t| t.parse().ok()).unwrap_or(2);
    let lenses: Vec<String> = [
        "singlet",
        "achromat",
        "cooke_triplet",
        "double_gauss",
        "petzval",
        "phone_asphere",
        "wide_angle",
    ]
    .iter()
    .map(|n| format!("builtin:{n}"))
    .collect();
    let test_images = 8;
    let mut settings = BuildSettings::new(
        lenses.clone(),
        "dead-leaves:2".parse().expect("a scene source"),
        format!("dead-leaves:{test_images}")
            .parse()
            .expect("a scene source"),
    );
    settings.frame_px = Some([1280, 800]);
    settings.levels = 5;
    settings.test_lenses_per_level = 1;
    settings.val_lenses = 1;
    settings.pairs_per_lens = 1;
    settings.crop_px = None;
    // ODE per lens, alone, on the build's sensor.
    let sensor = builder::grading::BuildSensor {
        frame_px: [1280, 800],
        pixel_um: None,
    };
    let out = std::env::temp_dir().join(format!("unicac-dataset-speed-{}", std::process::id()));
    let sources = builder::sources::lens_sources(&lenses, &out, false).expect("lenses");
    let start = Instant::now();
    pool_for(threads).install(|| {
        for source in &sources {
            let lens = sensor.apply(&source.load().expect("lens"));
            unicac_ode::evaluate(&lens, &sensor.ode_settings()).expect("ode");
        }
    });
    let ode_s_per_lens = start.elapsed().as_secs_f64() / sources.len() as f64;
    let pool = pool_for(threads);
    let start = Instant::now();
    let report = pool
        .install(|| builder::build(&settings, &out, Shard::ALL, &Silent))
        .expect("build");
    let total_s = start.elapsed().as_secs_f64();
    // The same build again with the ODE and PSF caches warm, the pairs deleted: rendering alone.
    for split in ["train", "val", "test"] {
        let _ = std::fs::remove_dir_all(out.join(split).join("lq"));
        let _ = std::fs::remove_dir_all(out.join(split).join("gt"));
    }
    let _ = std::fs::remove_file(out.join("dataset.json"));
    let start = Instant::now();
    let again = pool
        .install(|| builder::build(&settings, &out, Shard::ALL, &Silent))
        .expect("rebuild");
    let render_s = start.elapsed().as_secs_f64();
    let pairs = again.pairs_rendered as f64;
    let pairs_per_min = 60.0 * pairs / render_s;
    let setup_s_per_lens = (total_s - render_s).max(0.0) / lenses.len() as f64;
    println!(
        "threads {threads}, frame 1280x800 (1.02 MP), {} lenses, {} pairs",
        lenses.len(),
        report.pairs.values().sum::<usize>()
    );
    println!("first build (ODE, PSF maps, edges, pairs): {total_s:.1} s");
    println!("rendering with warm caches: {pairs} pairs in {render_s:.1} s = {pairs_per_min:.0} pairs/min");
    println!("ODE per lens: {ode_s_per_lens:.2} s; first build per lens beyond rendering (ODE, PSF map, edges): {setup_s_per_lens:.2} s");
    // Paper: 1,068 lenses; 120 test lenses x 26 test images; training pairs as configured.
    let paper_pairs = 120.0 * 26.0;
    // Every lens graded; the 195 used lenses also get a PSF map (the setup figure covers both).
    let paper_s = 1068.0 * ode_s_per_lens
        + 195.0 * (setup_s_per_lens - ode_s_per_lens).max(0.0)
        + 60.0 * paper_pairs / pairs_per_min;
    println!(
        "extrapolated paper-sized build (1,068 lenses graded, 195 PSF maps, 120 x 26 = {paper_pairs} test pairs; training pairs add 1 min per {pairs_per_min:.0}): {:.1} h",
        paper_s / 3600.0
    );
    std::fs::remove_dir_all(&out).expect("clean up");
}

fn pool_for(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool")
}
