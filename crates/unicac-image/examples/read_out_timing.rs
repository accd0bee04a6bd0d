//! Run time of the sensor read-out of a 12 MP mosaic (docs/performance.md), against the generator it
//! replaced (one ChaCha8 stream through `rand_distr`'s Poisson and normal samplers, one thread):
//!
//!     cargo run --release -p unicac-image --example read_out_timing
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Poisson, StandardNormal};
use std::time::Instant;
use unicac_image::isp::{read_out, SensorNoise};
use unicac_image::Planar;

fn main() {
    // Exposures spread over the whole range (0 to ~6,000 photo-electrons at the default sensor).
    let exposure = Planar::from_fn(4000, 3000, 1, |_, x, y| ((x * 13 + y * 7) % 1000) as f32 / 1000.0);
    let sensor = SensorNoise::default();
    let electrons_per_unit = f64::from(sensor.white_level_dn().unwrap() - sensor.black_level_dn)
        / f64::from(sensor.dn_per_electron());
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (mut counter, mut stream) = (Vec::new(), Vec::new());
    for _ in 0..5 {
        let start = Instant::now();
        std::hint::black_box(read_out(&exposure, &sensor, Some(3)).unwrap());
        counter.push(start.elapsed().as_secs_f64());
        let start = Instant::now();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut sum = 0.0;
        for &v in &exposure.data {
            let electrons = f64::from(v) * electrons_per_unit;
            let shot = match Poisson::new(electrons) {
                Ok(poisson) if electrons > 0.0 => rng.sample(poisson),
                _ => 0.0,
            };
            sum += shot + rng.sample::<f64, _>(StandardNormal);
        }
        std::hint::black_box(sum);
        stream.push(start.elapsed().as_secs_f64());
    }
    println!(
        "12 MP read-out, median of 5: counter draws (read_out, {} threads) {:.3} s; one ChaCha8 stream (draws only, 1 thread) {:.3} s",
        rayon::current_num_threads(),
        median(counter),
        median(stream)
    );
}
