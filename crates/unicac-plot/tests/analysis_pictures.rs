//! The analysis pictures (MTF curves, lens comparison bars, PSF kernels) render as PNG and SVG from
//! plain data built here, and bad data fails with a typed error and no file.

mod common;

use common::{check_both_formats, TempDir};
use std::f64::consts::PI;
use unicac_plot::{mtf_curves, ode_bars, psf_panels, Curve, PlotError, PsfPanel};

/// Gaussian blur MTFs exp(-2 pi^2 s^2 f^2) for s = 0.5, 1 and 1.5 pixels as R, G and B, and the
/// exact G curve sampled more finely, 0 to 0.6 cycles/pixel.
fn gaussian_mtfs() -> Vec<Curve> {
    let curve = |label: &str, sigma: f64, steps: usize| {
        let x: Vec<f64> = (0..=steps).map(|i| 0.6 * i as f64 / steps as f64).collect();
        let y = x
            .iter()
            .map(|f| (-2.0 * PI * PI * sigma * sigma * f * f).exp())
            .collect();
        Curve {
            label: label.into(),
            x,
            y,
        }
    };
    vec![
        curve("R", 1.5, 24),
        curve("G", 1.0, 24),
        curve("B", 0.5, 24),
        curve("exact G", 0.95, 120),
    ]
}

fn lens_names(count: usize) -> Vec<String> {
    const NAMES: [&str; 7] = [
        "Cooke triplet 50 mm f/5",
        "Double Gauss 50 mm f/2",
        "Tessar",
        "Petzval portrait",
        "Landscape singlet",
        "Achromatic doublet 100 mm",
        "Wide-angle retrofocus 28 mm",
    ];
    (0..count)
        .map(|i| match NAMES.get(i) {
            Some(name) => name.to_string(),
            None => format!("lens {}", i + 1),
        })
        .collect()
}

/// ODE 0.5 .. 0.9 and RMS radius 2 .. 40 µm for `count` lenses.
fn lens_scores(count: usize) -> (Vec<String>, Vec<f64>, Vec<f64>) {
    let t = |i: usize| i as f64 / (count.max(2) - 1) as f64;
    let ode = (0..count)
        .map(|i| 0.9 - 0.4 * ((3 * i) % count) as f64 / count as f64)
        .collect();
    let rms = (0..count).map(|i| 2.0 + 38.0 * t(i) * t(i)).collect();
    (lens_names(count), ode, rms)
}

/// A `size`×`size` anisotropic Gaussian with widths (sx, sy) pixels, centred `shift` pixels from the
/// middle, rotated by `angle` radians.
fn gaussian_kernel(
    label: &str,
    size: usize,
    (sx, sy): (f64, f64),
    shift: (f64, f64),
    angle: f64,
) -> PsfPanel {
    let centre = (size as f64 - 1.0) / 2.0;
    let (sin, cos) = angle.sin_cos();
    let data = (0..size * size)
        .map(|k| {
            let (x, y) = (
                (k % size) as f64 - centre - shift.0,
                (k / size) as f64 - centre - shift.1,
            );
            let (u, v) = (cos * x + sin * y, -sin * x + cos * y);
            (-(u * u / (2.0 * sx * sx) + v * v / (2.0 * sy * sy))).exp() as f32
        })
        .collect();
    PsfPanel {
        label: label.into(),
        size,
        pitch_um: 1.5,
        data,
    }
}

fn rgb_kernels() -> Vec<PsfPanel> {
    vec![
        gaussian_kernel("R", 31, (3.2, 2.0), (0.8, 0.4), 0.5),
        gaussian_kernel("G", 31, (2.6, 1.7), (0.0, 0.0), 0.4),
        gaussian_kernel("B", 31, (3.6, 2.3), (-0.9, -0.5), 0.3),
    ]
}

#[test]
fn mtf_curves_render_with_nyquist_mtf50_and_legend() {
    let curves = gaussian_mtfs();
    let texts = [
        "MTF of a Gaussian blur",
        "Nyquist",
        "MTF50",
        "exact G",
        "spatial frequency (cycles/pixel)",
    ];
    check_both_formats("mtf", &texts, |path| {
        mtf_curves("MTF of a Gaussian blur", &curves, path)
    });
}

#[test]
fn ode_bars_render_for_one_to_forty_lenses() {
    for count in [1, 7, 40] {
        let (names, ode, rms) = lens_scores(count);
        let texts = [
            "Optical Degradation Evaluator (ODE)",
            "RMS spot radius (µm)",
            names[0].as_str(),
            names[count - 1].as_str(),
        ];
        check_both_formats(&format!("ode-{count}"), &texts, |path| {
            ode_bars(&names, &ode, &rms, path)
        });
    }
}

#[test]
fn ode_bars_grow_with_the_number_of_lenses() {
    let dir = TempDir::new("ode-heights");
    let height = |count: usize| {
        let (names, ode, rms) = lens_scores(count);
        let path = dir.0.join(format!("{count}.svg"));
        ode_bars(&names, &ode, &rms, &path).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        let tag = &svg[..svg.find('>').unwrap()];
        let start = tag.find(" height=\"").unwrap() + 9;
        tag[start..].split('"').next().unwrap().parse::<u32>().unwrap()
    };
    let (one, seven, forty) = (height(1), height(7), height(40));
    assert!(one <= seven && seven < forty, "{one}, {seven}, {forty}");
    assert!(forty >= 40 * 20, "{forty} px for 40 rows");
}

#[test]
fn psf_panels_render_images_and_cross_sections() {
    let kernels = rgb_kernels();
    let texts = [
        "PSF kernels",
        "R   (31×31, 1.5 µm pitch)",
        "B   (31×31",
        "µm",
        "offset (µm)",
        "Central row",
    ];
    check_both_formats("psf", &texts, |path| psf_panels("PSF kernels", &kernels, path));
}

/// Nine 21×21 kernels growing and turning over the field.
fn field_kernels() -> Vec<PsfPanel> {
    (0..9)
        .map(|i| {
            let w = 1.0 + 0.3 * i as f64;
            gaussian_kernel(&format!("field {i}"), 21, (w, 1.2), (0.0, 0.0), 0.2 * i as f64)
        })
        .collect()
}

#[test]
fn psf_panels_make_a_grid_of_many_fields() {
    let kernels = field_kernels();
    check_both_formats("psf-grid", &["field 0", "field 8"], |path| {
        psf_panels("PSF over the field", &kernels, path)
    });
}

#[test]
fn bad_analysis_inputs_are_typed_errors_and_write_nothing() {
    let dir = TempDir::new("bad-analysis");
    let invalid = |result: Result<(), PlotError>| matches!(result, Err(PlotError::InvalidInput(_)));
    for extension in ["png", "svg"] {
        let path = dir.0.join(format!("bad.{extension}"));
        assert!(invalid(mtf_curves("t", &[], &path)));
        let mut ragged = gaussian_mtfs();
        ragged[1].y.pop();
        assert!(invalid(mtf_curves("t", &ragged, &path)));

        let (names, ode, rms) = lens_scores(7);
        assert!(invalid(ode_bars(&[], &[], &[], &path)));
        assert!(invalid(ode_bars(&names, &ode[..6], &rms, &path)));
        assert!(invalid(ode_bars(&names, &ode, &rms[..6], &path)));

        assert!(invalid(psf_panels("t", &[], &path)));
        let mut short = rgb_kernels();
        short[2].data.pop();
        assert!(invalid(psf_panels("t", &short, &path)));
        let mut empty = rgb_kernels();
        empty[0].size = 0;
        empty[0].data.clear();
        assert!(invalid(psf_panels("t", &empty, &path)));
        let mut pitch = rgb_kernels();
        pitch[1].pitch_um = 0.0;
        assert!(invalid(psf_panels("t", &pitch, &path)));
    }
    assert!(dir.files().is_empty(), "left {:?}", dir.files());
}

/// Writes the sample pictures to /tmp/unicac-plot-{mtf,ode,psf}.png for viewing:
/// `cargo test -p unicac-plot --test analysis_pictures -- --ignored`.
#[test]
#[ignore]
fn write_sample_pictures() {
    let out = |name: &str| std::env::temp_dir().join(format!("unicac-plot-{name}.png"));
    mtf_curves(
        "MTF of Gaussian blurs (σ = 0.5, 1, 1.5 px)",
        &gaussian_mtfs(),
        &out("mtf"),
    )
    .unwrap();
    let (names, ode, rms) = lens_scores(7);
    ode_bars(&names, &ode, &rms, &out("ode")).unwrap();
    psf_panels("PSF kernels at 0° (R, G, B)", &rgb_kernels(), &out("psf")).unwrap();
    for count in [1, 40] {
        let (names, ode, rms) = lens_scores(count);
        ode_bars(&names, &ode, &rms, &out(&format!("ode{count}"))).unwrap();
    }
    psf_panels("PSF over the field", &field_kernels(), &out("psf-grid")).unwrap();
}
