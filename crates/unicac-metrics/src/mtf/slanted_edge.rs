//! ISO 12233 slanted-edge MTF (the e-SFR method of ISO 12233:2014/2017, as in Burns' `sfrmat3`), on one
//! channel of a region that holds one straight edge slanted a few degrees (2-10 deg recommended) from
//! the pixel columns or rows:
//!
//! 1. Orientation: the axis with the larger summed absolute gradient is across the edge; near-horizontal
//!    edges are transposed so the rest of the method always sees a near-vertical edge. The polarity (dark
//!    to bright or bright to dark along +x) is normalised by a sign flip, which leaves the MTF unchanged.
//! 2. Edge location: per row, the centroid of the first difference; a least-squares line through the
//!    centroids; then once more with each row's difference weighted by a Hamming window centred on the
//!    fitted line (as `sfrmat3` does), and a second fit.
//! 3. Projection: every pixel centre is projected onto the edge normal (signed distance from the fitted
//!    line) and averaged into bins of 1/`oversampling` px (0.25 px by default) over the distance range
//!    that every row covers: the oversampled edge spread function (ESF). Empty bins are interpolated.
//! 4. LSF: first difference of the ESF, Hamming window centred on the LSF centroid, zero padding, FFT
//!    (`rustfft`), modulus normalised to DC.
//! 5. The first difference attenuates frequency f by sinc(f / oversampling); the MTF is divided by it
//!    (ISO 12233 derivative correction). Averaging the samples of a bin is a box filter of the bin width
//!    as well, with the same transfer function; unicac divides by it a second time by default
//!    (`correct_bin_averaging`; not part of ISO 12233, as in e.g. MTF Mapper). On an analytically
//!    rendered unblurred edge this brings the error against the pixel-aperture sinc at Nyquist from
//!    about 0.02 to below 0.005 (see `tests/slanted_edge.rs`).
//!
//! Frequencies are in cycles per pixel measured along the edge normal (for a 5 deg slant they differ from
//! cycles per pixel along x by cos 5 deg = 0.996). The curve is reported up to 1 cy/px (twice Nyquist).

use rustfft::{num_complex::Complex, FftPlanner};
use serde::{Deserialize, Serialize};
use unicac_image::Planar;

use super::{sinc, summarize, Mtf50Kind, MtfSummary};
use crate::error::{MetricsError, Result};

/// A rectangle of an image, in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Roi {
    pub x: usize,
    pub y: usize,
    pub width: usize,
    pub height: usize,
}

/// Settings of the slanted-edge method; `Default` gives the ISO 12233 choices.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SlantedEdgeOptions {
    /// ESF bins per pixel (4 in ISO 12233).
    pub oversampling: usize,
    /// Divide by sinc(f / oversampling) to undo the first difference (ISO 12233; default true).
    pub correct_derivative: bool,
    /// Divide by sinc(f / oversampling) once more to undo the averaging within 1/oversampling px bins
    /// (beyond ISO 12233; default true). Set false for the plain ISO 12233 result.
    pub correct_bin_averaging: bool,
    /// Highest frequency reported, cy/px (default 1.0; never above oversampling / 2).
    pub max_frequency_cy_per_px: f64,
}

impl Default for SlantedEdgeOptions {
    fn default() -> Self {
        SlantedEdgeOptions {
            oversampling: 4,
            correct_derivative: true,
            correct_bin_averaging: true,
            max_frequency_cy_per_px: 1.0,
        }
    }
}

/// Which pixel axis the edge runs along (within 45 deg).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EdgeOrientation {
    /// The edge runs along the columns; the MTF is measured along x (roughly).
    NearVertical,
    /// The edge runs along the rows; the MTF is measured along y (roughly).
    NearHorizontal,
}

/// Whether the image gets brighter or darker across the edge, going towards +x (near-vertical edge) or
/// +y (near-horizontal edge).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EdgePolarity {
    Rising,
    Falling,
}

/// The fitted edge.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EdgeGeometry {
    pub orientation: EdgeOrientation,
    pub polarity: EdgePolarity,
    /// Angle of the edge from the pixel axis it runs along, degrees (sign: the edge's position across
    /// the axis increases with the position along it).
    pub angle_deg: f64,
    /// Half length of the ESF along the normal, px.
    pub esf_half_width_px: f64,
}

/// The measured MTF of one edge.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EdgeMtf {
    /// Frequencies along the edge normal, cy/px, from 0 up to `max_frequency_cy_per_px`.
    pub frequency_cy_per_px: Vec<f64>,
    /// MTF at those frequencies, 1 at DC.
    pub mtf: Vec<f64>,
    /// See [`MtfSummary`].
    pub mtf50_cy_per_px: f64,
    pub mtf50_kind: Mtf50Kind,
    pub mtf_area: f64,
    pub edge: EdgeGeometry,
}

impl EdgeMtf {
    pub fn summary(&self) -> MtfSummary {
        MtfSummary {
            mtf50_cy_per_px: self.mtf50_cy_per_px,
            mtf50_kind: self.mtf50_kind,
            mtf_area: self.mtf_area,
        }
    }
}

/// Rows shorter than this, or fewer rows than this, are refused.
const MIN_ROI_SIDE: usize = 8;
/// The ESF must extend at least this far (px) on both sides of the edge.
const MIN_ESF_HALF_WIDTH_PX: f64 = 3.0;
/// The FFT is zero-padded to at least this many samples (for a fine frequency grid).
const MIN_FFT_LEN: usize = 1024;

/// Slanted-edge MTF of `channel` of `image` inside `roi`.
pub fn slanted_edge_mtf(
    image: &Planar,
    channel: usize,
    roi: Roi,
    options: &SlantedEdgeOptions,
) -> Result<EdgeMtf> {
    crate::input::check_finite_region(image, channel, [roi.x, roi.y, roi.width, roi.height])?;
    let (region, orientation) = oriented_region(image, channel, roi)?;
    let Region {
        width: w,
        height: h,
        mut data,
    } = region;
    let polarity = if (0..h).map(|y| data[y * w + w - 1] - data[y * w]).sum::<f64>() >= 0.0 {
        EdgePolarity::Rising
    } else {
        data.iter_mut().for_each(|v| *v = -*v);
        EdgePolarity::Falling
    };
    let region = Region {
        width: w,
        height: h,
        data,
    };
    let line = fit_edge(&region)?;
    let (esf, half_width) = binned_esf(&region, line, options.oversampling)?;
    let (frequency, mtf) = esf_to_mtf(&esf, options);
    let summary = summarize(&frequency, &mtf)?;
    let edge = EdgeGeometry {
        orientation,
        polarity,
        angle_deg: line.slope.atan().to_degrees(),
        esf_half_width_px: half_width,
    };
    Ok(EdgeMtf {
        frequency_cy_per_px: frequency,
        mtf,
        mtf50_cy_per_px: summary.mtf50_cy_per_px,
        mtf50_kind: summary.mtf50_kind,
        mtf_area: summary.mtf_area,
        edge,
    })
}

/// A row-major f64 region.
struct Region {
    width: usize,
    height: usize,
    data: Vec<f64>,
}

/// The edge x = slope * y + offset, in pixel-edge coordinates (pixel (x, y) has its centre at
/// (x + 0.5, y + 0.5)).
#[derive(Clone, Copy)]
struct EdgeLine {
    slope: f64,
    offset: f64,
}

impl EdgeLine {
    fn x_at(&self, y: f64) -> f64 {
        self.slope * y + self.offset
    }
}

/// The ROI of one channel as f64, transposed when the edge is near-horizontal.
fn oriented_region(image: &Planar, channel: usize, roi: Roi) -> Result<(Region, EdgeOrientation)> {
    if channel >= image.channels {
        return Err(MetricsError::NoSuchChannel {
            channel,
            channels: image.channels,
        });
    }
    if roi.x + roi.width > image.width || roi.y + roi.height > image.height {
        return Err(MetricsError::RegionOutside {
            x: roi.x,
            y: roi.y,
            width: roi.width,
            height: roi.height,
            image_width: image.width,
            image_height: image.height,
        });
    }
    if roi.width < MIN_ROI_SIDE || roi.height < MIN_ROI_SIDE {
        return Err(MetricsError::TooSmall {
            width: roi.width,
            height: roi.height,
            what: format!("a slanted-edge region needs at least {MIN_ROI_SIDE} px per side"),
        });
    }
    let (w, h) = (roi.width, roi.height);
    let at = |x: usize, y: usize| image.get(channel, roi.x + x, roi.y + y) as f64;
    let mut gx = 0.0;
    let mut gy = 0.0;
    for y in 0..h - 1 {
        for x in 0..w - 1 {
            gx += (at(x + 1, y) - at(x, y)).abs();
            gy += (at(x, y + 1) - at(x, y)).abs();
        }
    }
    if gx >= gy {
        let data = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| at(x, y))
            .collect();
        Ok((
            Region {
                width: w,
                height: h,
                data,
            },
            EdgeOrientation::NearVertical,
        ))
    } else {
        let data = (0..w)
            .flat_map(|x| (0..h).map(move |y| (x, y)))
            .map(|(x, y)| at(x, y))
            .collect();
        Ok((
            Region {
                width: h,
                height: w,
                data,
            },
            EdgeOrientation::NearHorizontal,
        ))
    }
}

/// Hamming window of half length `half` centred on `centre`, 0 beyond.
fn hamming(position: f64, centre: f64, half: f64) -> f64 {
    let u = (position - centre) / half;
    if u.abs() > 1.0 {
        0.0
    } else {
        0.54 + 0.46 * (std::f64::consts::PI * u).cos()
    }
}

/// Two-pass centroid line fit (ISO 12233 / sfrmat3).
fn fit_edge(region: &Region) -> Result<EdgeLine> {
    let first = fit_centroids(region, None)?;
    fit_centroids(region, Some(first))
}

/// Least-squares line through the per-row centroids of the first difference, each row's difference
/// weighted by a Hamming window centred on `previous` when given.
fn fit_centroids(region: &Region, previous: Option<EdgeLine>) -> Result<EdgeLine> {
    let w = region.width;
    let half = w as f64 / 2.0;
    let mut points = Vec::with_capacity(region.height);
    for y in 0..region.height {
        let row = &region.data[y * w..(y + 1) * w];
        let yc = y as f64 + 0.5;
        let (mut sum, mut moment) = (0.0, 0.0);
        for x in 0..w - 1 {
            // The difference of pixels x and x + 1 sits between their centres, at x + 1.
            let difference = row[x + 1] - row[x];
            if difference == 0.0 {
                // Adds exactly nothing (the flat sides of an edge patch are most of its pixels), so
                // the window's cosine is not worth computing.
                continue;
            }
            let position = x as f64 + 1.0;
            let weight = previous.map_or(1.0, |line| hamming(position, line.x_at(yc), half));
            let d = difference * weight;
            sum += d;
            moment += d * position;
        }
        if sum > 0.0 {
            points.push((yc, moment / sum));
        }
    }
    if points.len() < MIN_ROI_SIDE / 2 {
        return Err(MetricsError::NoEdge(format!(
            "only {} of {} rows show a step from dark to bright (need {}): the image holds no edge \
             running across it; give an image of one straight edge slanted 2 to 10 deg from the pixel \
             rows or columns (e.g. `unicac chart slanted-edge`)",
            points.len(),
            region.height,
            MIN_ROI_SIDE / 2
        )));
    }
    let n = points.len() as f64;
    let (my, mx) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (y, x)| (a + y / n, b + x / n));
    let (sxy, syy) = points.iter().fold((0.0, 0.0), |(a, b), (y, x)| {
        (a + (y - my) * (x - mx), b + (y - my) * (y - my))
    });
    let slope = sxy / syy;
    Ok(EdgeLine {
        slope,
        offset: mx - slope * my,
    })
}

/// The oversampled ESF along the edge normal and its half width in px.
fn binned_esf(region: &Region, line: EdgeLine, oversampling: usize) -> Result<(Vec<f64>, f64)> {
    if oversampling == 0 {
        return Err(MetricsError::InvalidInput(
            "oversampling must be at least 1".into(),
        ));
    }
    let (w, h) = (region.width, region.height);
    let cos = line.slope.atan().cos();
    // Distance (along the normal) from the edge to the outermost pixel centres that every row reaches.
    let half_width = (0..h)
        .map(|y| {
            let edge = line.x_at(y as f64 + 0.5);
            (edge - 0.5).min(w as f64 - 0.5 - edge)
        })
        .fold(f64::INFINITY, f64::min)
        * cos;
    if !(half_width >= 0.0) {
        // The line through the rows' edge positions leaves the region: those positions do not lie on one
        // straight edge (texture, several edges, a curved edge).
        return Err(MetricsError::NoEdge(
            "the image does not hold one straight edge: the line fitted through the edge position of \
             each row runs out of the image, as it does for textures (e.g. dead leaves), several edges \
             or a curved edge; give an image of one straight edge slanted 2 to 10 deg from the pixel rows or \
             columns (e.g. `unicac chart slanted-edge`)"
                .into(),
        ));
    }
    if !(half_width >= MIN_ESF_HALF_WIDTH_PX) {
        return Err(MetricsError::NoEdge(format!(
            "the edge is too close to the image border: it leaves only {half_width:.2} px on one side \
             (need {MIN_ESF_HALF_WIDTH_PX}); crop the image so that the edge runs near its middle"
        )));
    }
    let os = oversampling as f64;
    let bins = (2.0 * half_width * os).floor() as usize;
    let (mut sums, mut counts) = (vec![0.0; bins], vec![0usize; bins]);
    for y in 0..h {
        let edge = line.x_at(y as f64 + 0.5);
        for x in 0..w {
            let distance = (x as f64 + 0.5 - edge) * cos;
            let position = (distance + half_width) * os;
            // For a position >= 0 the integer conversion is its floor (without the libm call of
            // `f64::floor` on x86-64's baseline); negative and NaN positions fall outside every bin.
            if position >= 0.0 {
                let bin = position as usize;
                if bin < bins {
                    sums[bin] += region.data[y * w + x];
                    counts[bin] += 1;
                }
            }
        }
    }
    let empty = counts.iter().filter(|&&c| c == 0).count();
    if empty * 4 > bins {
        return Err(MetricsError::NoEdge(format!(
            "{empty} of {bins} ESF bins are empty: the edge is too close to a pixel axis or the region too short"
        )));
    }
    let filled: Vec<Option<f64>> = sums
        .iter()
        .zip(&counts)
        .map(|(s, &c)| (c > 0).then(|| s / c as f64))
        .collect();
    Ok((fill_gaps(&filled), half_width))
}

/// Linear interpolation over missing samples; missing ends copy the nearest present sample.
fn fill_gaps(samples: &[Option<f64>]) -> Vec<f64> {
    let present: Vec<(usize, f64)> = samples
        .iter()
        .enumerate()
        .filter_map(|(i, v)| v.map(|v| (i, v)))
        .collect();
    let mut k = 0;
    (0..samples.len())
        .map(|i| {
            while k + 1 < present.len() && present[k + 1].0 <= i {
                k += 1;
            }
            let (i0, v0) = present[k];
            match present.get(k + 1) {
                Some(&(i1, v1)) if i > i0 => v0 + (v1 - v0) * (i - i0) as f64 / (i1 - i0) as f64,
                _ => v0,
            }
        })
        .collect()
}

/// LSF by first difference, Hamming window, FFT, DC normalisation, derivative and bin corrections.
fn esf_to_mtf(esf: &[f64], options: &SlantedEdgeOptions) -> (Vec<f64>, Vec<f64>) {
    let lsf: Vec<f64> = esf.windows(2).map(|p| p[1] - p[0]).collect();
    let n = lsf.len();
    let total: f64 = lsf.iter().sum();
    let centre = lsf.iter().enumerate().map(|(i, v)| i as f64 * v).sum::<f64>() / total;
    let half = centre.max(n as f64 - 1.0 - centre).max(1.0);
    let len = n.next_power_of_two().max(MIN_FFT_LEN);
    let mut buffer: Vec<Complex<f64>> = (0..len)
        .map(|i| {
            let value = if i < n {
                lsf[i] * hamming(i as f64, centre, half)
            } else {
                0.0
            };
            Complex::new(value, 0.0)
        })
        .collect();
    FftPlanner::new().plan_fft_forward(len).process(&mut buffer);
    let os = options.oversampling as f64;
    let df = os / len as f64;
    let f_max = options.max_frequency_cy_per_px.min(os / 2.0);
    let dc = buffer[0].norm();
    let corrections = options.correct_derivative as i32 + options.correct_bin_averaging as i32;
    (0..len / 2 + 1)
        .map(|k| (k as f64 * df, k))
        .take_while(|(f, _)| *f <= f_max + 1e-12)
        .map(|(f, k)| (f, buffer[k].norm() / dc / sinc(f / os).powi(corrections)))
        .unzip()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_texture_is_refused_in_plain_words() {
        // The README tour once measured a simulated dead-leaves chart: the message must say what is
        // wrong with such an image, not quote a negative half width.
        let texture = unicac_image::charts::dead_leaves(256, 192, 1).unwrap();
        let roi = Roi {
            x: 0,
            y: 0,
            width: 256,
            height: 192,
        };
        let error = slanted_edge_mtf(&texture, 1, roi, &SlantedEdgeOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("one straight edge")
                && error.contains("slanted-edge")
                && !error
                    .as_bytes()
                    .windows(2)
                    .any(|w| w[0] == b'-' && w[1].is_ascii_digit()),
            "{error}"
        );
    }

    #[test]
    fn gaps_are_interpolated() {
        let filled = fill_gaps(&[None, Some(1.0), None, None, Some(4.0), None]);
        assert_eq!(filled, vec![1.0, 1.0, 2.0, 3.0, 4.0, 4.0]);
    }

    #[test]
    fn flat_region_has_no_edge() {
        let image = Planar::from_fn(32, 32, 1, |_, _, _| 0.5);
        let roi = Roi {
            x: 0,
            y: 0,
            width: 32,
            height: 32,
        };
        assert!(matches!(
            slanted_edge_mtf(&image, 0, roi, &SlantedEdgeOptions::default()),
            Err(MetricsError::NoEdge(_))
        ));
    }

    #[test]
    fn axis_aligned_edge_is_refused() {
        let image = Planar::from_fn(32, 32, 1, |_, x, _| if x < 16 { 0.1 } else { 0.9 });
        let roi = Roi {
            x: 0,
            y: 0,
            width: 32,
            height: 32,
        };
        assert!(slanted_edge_mtf(&image, 0, roi, &SlantedEdgeOptions::default()).is_err());
    }

    #[test]
    fn region_must_fit() {
        let image = Planar::new(16, 16, 1);
        let roi = Roi {
            x: 8,
            y: 0,
            width: 16,
            height: 16,
        };
        assert!(matches!(
            slanted_edge_mtf(&image, 0, roi, &SlantedEdgeOptions::default()),
            Err(MetricsError::RegionOutside { .. })
        ));
        assert!(matches!(
            slanted_edge_mtf(&image, 1, Roi { x: 0, ..roi }, &SlantedEdgeOptions::default()),
            Err(MetricsError::NoSuchChannel { .. })
        ));
    }
}
