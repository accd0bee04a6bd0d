//! Properties of the analyses that need no reference tool: the polychromatic weighting, the diffraction
//! limit as an upper bound, the limits checked before any work.

use unicac_analysis::{
    check_fields, encircled_energy, linspace, mtf, through_focus, MtfMethod, MtfSettings, Spectrum,
};
use unicac_optics::builtin;

fn settings(method: MtfMethod) -> MtfSettings {
    MtfSettings {
        method,
        pupil_grid: 64,
        scale_by_diffraction_limit: true,
    }
}

/// The polychromatic OTF is the weighted mean of complex OTFs: one wavelength listed twice gives the
/// monochromatic MTF exactly, and by the triangle inequality the polychromatic MTF never exceeds the
/// weighted mean of the monochromatic ones (equal weights and, without vignetting, equal transmission).
#[test]
fn polychromatic_mtf_is_the_weighted_mean_of_complex_otfs() {
    let lens = builtin::lens("cooke_triplet").unwrap();
    let frequencies = linspace(0.0, 150.0, 16);
    let run = |spectrum: &Spectrum| {
        mtf(
            &lens,
            spectrum,
            &[14.0],
            &frequencies,
            settings(MtfMethod::Diffraction),
        )
        .unwrap()
        .fields
        .remove(0)
    };
    let wavelengths = lens.wavelengths_um();
    let single = run(&Spectrum::equal(&wavelengths[1..2]).unwrap());
    let twice = run(&Spectrum::equal(&[wavelengths[1], wavelengths[1]]).unwrap());
    for (a, b) in single.tangential.iter().zip(&twice.tangential) {
        assert!((a - b).abs() < 1e-12);
    }
    let mono: Vec<_> = wavelengths
        .iter()
        .map(|&w| run(&Spectrum::equal(&[w]).unwrap()))
        .collect();
    let poly = run(&Spectrum::equal(&wavelengths).unwrap());
    for k in 0..frequencies.len() {
        for (values, pick) in [
            (
                &poly.tangential,
                (|m: &unicac_analysis::FieldMtf, k: usize| m.tangential[k]) as fn(_, _) -> f64,
            ),
            (&poly.sagittal, |m: &unicac_analysis::FieldMtf, k: usize| {
                m.sagittal[k]
            }),
        ] {
            let mean = mono.iter().map(|m| pick(m, k)).sum::<f64>() / 3.0;
            assert!(
                values[k] <= mean + 1e-12,
                "{} > {mean} at {} cy/mm",
                values[k],
                frequencies[k]
            );
        }
    }
    assert!((poly.tangential[0] - 1.0).abs() < 1e-12);
}

/// Aberrations only lose contrast: the diffraction MTF and the scaled geometric MTF stay at or below
/// the diffraction limit of the same pupil.
#[test]
fn mtfs_stay_below_the_diffraction_limit() {
    let lens = builtin::lens("phone_asphere").unwrap();
    let spectrum = Spectrum::of_lens(&lens);
    let frequencies = linspace(0.0, 400.0, 21);
    for method in [MtfMethod::Diffraction, MtfMethod::Geometric] {
        let report = mtf(
            &lens,
            &spectrum,
            &[0.0, 19.6, 28.0],
            &frequencies,
            settings(method),
        )
        .unwrap();
        for field in &report.fields {
            for (m, l) in field.tangential.iter().zip(&field.diffraction_limit.tangential) {
                assert!(*m <= l + 1e-9, "{method:?} {} deg: {m} > {l}", field.field_deg);
            }
            for (m, l) in field.sagittal.iter().zip(&field.diffraction_limit.sagittal) {
                assert!(*m <= l + 1e-9, "{method:?} {} deg: {m} > {l}", field.field_deg);
            }
            assert!(field.cutoff_cy_mm.tangential > 0.0 && !field.undersampled);
        }
    }
}

#[test]
fn requests_out_of_range_are_refused_with_the_parameter_named() {
    let lens = builtin::lens("cooke_triplet").unwrap();
    let spectrum = Spectrum::of_lens(&lens);
    let field = |e: unicac_analysis::AnalysisError| match e {
        unicac_analysis::AnalysisError::InvalidParameter(p) => p.field,
        other => panic!("{other}"),
    };
    assert_eq!(field(check_fields(&lens, &[f64::NAN]).unwrap_err()), "field_deg");
    assert_eq!(field(check_fields(&lens, &[20.5]).unwrap_err()), "field_deg");
    assert!(check_fields(&lens, &[-20.0, 0.0, 20.0]).is_ok());
    let bad_grid = MtfSettings {
        pupil_grid: 4096,
        ..MtfSettings::default()
    };
    assert_eq!(
        field(mtf(&lens, &spectrum, &[0.0], &[10.0], bad_grid).unwrap_err()),
        "pupil_grid"
    );
    assert_eq!(
        field(mtf(&lens, &spectrum, &[0.0], &[-1.0], MtfSettings::default()).unwrap_err()),
        "frequencies_cy_mm"
    );
    assert_eq!(
        field(
            through_focus(
                &lens,
                &spectrum,
                &[0.0],
                10.0,
                &[f64::INFINITY],
                MtfSettings::default()
            )
            .unwrap_err()
        ),
        "focus_shifts_mm"
    );
    assert_eq!(field(Spectrum::equal(&[]).unwrap_err()), "wavelength_um");
    assert_eq!(
        field(encircled_energy(&lens, &spectrum, &[0.0], Some(&[f64::NAN]), 64).unwrap_err()),
        "radii_um"
    );
}
