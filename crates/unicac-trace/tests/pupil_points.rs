//! Pupil points made one by one (`PupilSampling::indexed_point`, what `SpotTracer::spot` makes chunk by
//! chunk) are the points of `points()`, bit for bit, and a spot does not depend on which way it got
//! them.

use unicac_optics::builtin;
use unicac_trace::{Aiming, PupilSampling, SpotTracer};

#[test]
fn indexed_points_are_the_points_bit_for_bit() {
    for pattern in ["fibonacci:3001", "random:3001", "random:77:12345"] {
        let sampling: PupilSampling = pattern.parse().unwrap();
        let points = sampling.points();
        assert_eq!(points.len(), sampling.point_count(), "{pattern}");
        for (i, point) in points.iter().enumerate() {
            assert_eq!(sampling.indexed_point(i), Some(*point), "{pattern} point {i}");
        }
    }
    for pattern in ["hexapolar:4", "grid:9"] {
        let sampling: PupilSampling = pattern.parse().unwrap();
        assert_eq!(sampling.indexed_point(0), None, "{pattern}");
    }
}

/// The spot's arrivals, written chunk by chunk in place and closed up where rays were lost, are the
/// arrivals of the whole pupil traced at once, in pupil order: for points made by index and for listed
/// patterns, at a field where every ray arrives and at one (28 deg, beyond the lens's 20) where the
/// apertures clip about 45% of them in every chunk.
#[test]
fn a_spot_of_a_pupil_made_in_chunks_keeps_every_point_in_order() {
    let lens = builtin::lens("cooke_triplet").unwrap();
    let tracer = SpotTracer::new(&lens, lens.primary_wavelength_um(), Aiming::Paraxial).unwrap();
    // More points than one chunk, not a multiple of it.
    for sampling in [
        PupilSampling::Random { n: 5000, seed: 3 },
        PupilSampling::Hexapolar { rings: 41 },
    ] {
        for field_deg in [20.0, 28.0] {
            let spot = tracer.spot(field_deg, &sampling);
            let pupil = sampling.points();
            assert_eq!(spot.rays_traced, pupil.len());
            let (mut rays, not_aimed) = tracer.aimed_rays(field_deg, &pupil);
            assert_eq!(not_aimed, 0);
            let statuses = unicac_trace::trace_rays(&tracer.system, &mut rays);
            let expected: Vec<[f64; 2]> = rays
                .iter()
                .zip(&statuses)
                .filter(|(_, s)| s.is_ok())
                .map(|(r, _)| [r.position_mm[0], r.position_mm[1]])
                .collect();
            let lost = pupil.len() - expected.len();
            assert_eq!(
                lost > pupil.len() / 4,
                field_deg > 20.0,
                "{sampling:?} {field_deg}: {lost} lost"
            );
            assert_eq!(spot.rays_ok, expected.len());
            assert_eq!(spot.points_mm, expected, "{sampling:?} {field_deg}");
        }
    }
}
