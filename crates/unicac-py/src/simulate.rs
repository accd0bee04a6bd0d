//! Image simulation through a lens: `Simulator` (PSFs traced once per lens and image size, then any
//! number of images), `simulate` (one call, as `unicac simulate`), PSF grids and field maps.
//!
//! Images: H x W x 3 numpy arrays, uint8 or uint16 holding sRGB codes, or float32 holding linear light
//! (see `arrays.rs`). Outputs come back in the input's representation, exactly as `unicac simulate`
//! writes them (PNG/TIFF codes for integer input, linear EXR values for float32 input).

use crate::arrays::{check_size, encoded_out, f32_array, f64_array, image_linear, planar_f32, planar_out};
use crate::errors::OrRaise;
use crate::lens::PyLens;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use unicac_image::isp::{Pipeline, SensorNoise};
use unicac_image::Planar;
use unicac_sim::{crop, LensSimulator, PixelWindow, SimulationSettings};

/// The simulator's colour channels (R, G, B), one kernel each.
const CHANNELS: usize = 3;

use unicac_image::isp::DEFAULT_BIT_DEPTH;

// The `#[pyo3(signature)]` defaults below are the literal 10 so that Python's `inspect.signature` (and
// the stub test) shows the value rather than `...`; this keeps them tied to the library default.
const _: () = assert!(DEFAULT_BIT_DEPTH == 10);

/// A lens prepared for images of one size: PSF map, distortion and relative illumination.
#[pyclass(module = "unicac", name = "Simulator", frozen)]
pub struct PySimulator {
    sim: LensSimulator,
}

/// The sensor/ISP chain of `unicac simulate` with its switches and `--sensor-bits`.
fn pipeline(isp: bool, noise: bool, sensor_bits: u8) -> PyResult<Pipeline> {
    let min = unicac_image::isp::MIN_DEFAULT_SENSOR_BITS;
    if !(min..=16).contains(&sensor_bits) {
        return Err(PyValueError::new_err(format!(
            "sensor_bits: {sensor_bits}, expected {min}..=16 (the black level, 64 DN, needs {min} bits)"
        )));
    }
    Ok(Pipeline {
        no_isp: !isp,
        no_noise: !noise,
        sensor: SensorNoise {
            bit_depth: sensor_bits,
            ..SensorNoise::default()
        },
        ..Default::default()
    })
}

impl PySimulator {
    fn check_dims(&self, image: &Planar, name: &str) -> PyResult<()> {
        let (w, h) = (self.sim.grid.width_px, self.sim.grid.height_px);
        if (image.width, image.height) != (w, h) {
            return Err(PyValueError::new_err(format!(
                "{name}: this Simulator is prepared for {h} x {w} (H x W) images, got {} x {}",
                image.height, image.width
            )));
        }
        Ok(())
    }

    /// Kernels of every channel at sensor point (x, y) mm, as (C, K, K) samples.
    fn kernels_at(&self, x_mm: f64, y_mm: f64) -> Vec<f32> {
        (0..CHANNELS)
            .flat_map(|c| self.sim.kernel_at(x_mm, y_mm, c).data)
            .collect()
    }
}

#[pymethods]
impl PySimulator {
    /// Traces the PSFs of `lens` for `width_px` x `height_px` images. `pixel_um`: the sensor pitch;
    /// None makes the lens's largest field fill the image's half-diagonal. `distortion` and
    /// `illumination` switch the geometric warp and the relative illumination. `device`: "cpu", "gpu"
    /// or "auto", who traces the PSF rays and runs the image pass (blur, warp, shading) of every call
    /// (as `unicac simulate --device`; docs/gpu.md). GIL released.
    #[new]
    #[pyo3(signature = (lens, width_px, height_px, pixel_um=None, distortion=true, illumination=true, device="cpu"))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        lens: &PyLens,
        width_px: usize,
        height_px: usize,
        pixel_um: Option<f64>,
        distortion: bool,
        illumination: bool,
        device: &str,
    ) -> PyResult<PySimulator> {
        check_size(width_px, height_px)?;
        let mut settings = SimulationSettings {
            distortion,
            illumination,
            ..Default::default()
        };
        (settings.psf.backend, settings.image) = crate::device::simulator_backends(device)?;
        let backend = settings.psf.backend.clone();
        let sim = crate::pool::detach(py, || {
            LensSimulator::new(&lens.lens, width_px, height_px, pixel_um, settings).or_raise()
        });
        crate::device::warn_notes(py, &backend)?;
        Ok(PySimulator { sim: sim? })
    }

    #[getter]
    fn width_px(&self) -> usize {
        self.sim.grid.width_px
    }
    #[getter]
    fn height_px(&self) -> usize {
        self.sim.grid.height_px
    }
    /// Sensor pixel pitch (um).
    #[getter]
    fn pixel_um(&self) -> f64 {
        self.sim.grid.pitch_um
    }
    /// Side of the PSF kernels (pixels, odd).
    #[getter]
    fn kernel_px(&self) -> usize {
        self.sim.kernel_size()
    }
    /// Distance from the image centre to a corner on the sensor (mm).
    #[getter]
    fn half_diagonal_mm(&self) -> f64 {
        self.sim.grid.half_diagonal_mm()
    }

    /// The optics alone on a linear camera-raw image (float32 H x W x 3): spatially varying blur,
    /// distortion and relative illumination; float32 H x W x 3 out. GIL released.
    fn optics<'py>(&self, py: Python<'py>, raw: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let raw = planar_f32(raw, "raw", 3, &[3])?;
        self.check_dims(&raw, "raw")?;
        let out = crate::pool::detach(py, || self.sim.apply(&raw).or_raise())?;
        crate::device::warn_image_notes(py, &self.sim.settings.image)?;
        planar_out(py, &out, false)
    }

    /// The whole chain on one image, as `unicac simulate` (seed `seed`): inverse white balance, optics,
    /// sensor noise and ISP (`isp=False`: no Bayer mosaic, no ISP randomisation; `noise=False`: no shot
    /// or read noise; both off: no read-out, the optics at full precision). `sensor_bits`: read-out bit
    /// depth (7-16, default 10 as `--sensor-bits`). Returns the degraded image in the input's
    /// representation. GIL released.
    #[pyo3(signature = (image, seed=0, isp=true, noise=true, sensor_bits=10))]
    fn simulate<'py>(
        &self,
        py: Python<'py>,
        image: &Bound<'py, PyAny>,
        seed: u64,
        isp: bool,
        noise: bool,
        sensor_bits: u8,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (linear, kind) = image_linear(image, "image")?;
        self.check_dims(&linear, "image")?;
        let pipeline = pipeline(isp, noise, sensor_bits)?;
        let degraded = crate::pool::detach(py, || self.sim.degrade(&pipeline, linear, seed).or_raise())?;
        crate::device::warn_image_notes(py, &self.sim.settings.image)?;
        encoded_out(py, &degraded, kind)
    }

    /// A training pair from one sharp image: `(degraded, target)`, both float32 H x W x 3 in the ISP's
    /// output encoding (sRGB, values in [0, 1]); the target is the sharp image through the same
    /// encoding (no optics, no noise). Same chain and seed rule as `simulate`. GIL released.
    #[pyo3(signature = (image, seed=0, isp=true, noise=true, sensor_bits=10))]
    fn render_pair<'py>(
        &self,
        py: Python<'py>,
        image: &Bound<'py, PyAny>,
        seed: u64,
        isp: bool,
        noise: bool,
        sensor_bits: u8,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let (linear, _) = image_linear(image, "image")?;
        self.check_dims(&linear, "image")?;
        let pipeline = pipeline(isp, noise, sensor_bits)?;
        // `degrade` (not Pipeline::render_pair) so that optics errors keep their own class.
        let (degraded, target) = crate::pool::detach(py, || -> PyResult<(Planar, Planar)> {
            let degraded = self.sim.degrade(&pipeline, linear.clone(), seed).or_raise()?;
            Ok((degraded, pipeline.finish_reference(&linear).or_raise()?))
        })?;
        crate::device::warn_image_notes(py, &self.sim.settings.image)?;
        Ok((planar_out(py, &degraded, false)?, planar_out(py, &target, false)?))
    }

    /// A training pair for the window (`x0`, `y0`, `width_px`, `height_px`) of the frame `image`:
    /// `(degraded, target)` as `render_pair` returns them cut to the window, but computed over the
    /// window plus the PSF and distortion margin only (`source_window`), not over the whole frame. The
    /// sensor/ISP chain runs on the window (its Bayer pattern starts at the window's corner). GIL
    /// released.
    #[pyo3(signature = (image, x0, y0, width_px, height_px, seed=0, isp=true, noise=true, sensor_bits=10))]
    #[allow(clippy::too_many_arguments)]
    fn render_pair_window<'py>(
        &self,
        py: Python<'py>,
        image: &Bound<'py, PyAny>,
        x0: usize,
        y0: usize,
        width_px: usize,
        height_px: usize,
        seed: u64,
        isp: bool,
        noise: bool,
        sensor_bits: u8,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let (linear, _) = image_linear(image, "image")?;
        self.check_dims(&linear, "image")?;
        let window = PixelWindow {
            x0,
            y0,
            width: width_px,
            height: height_px,
        };
        let pipeline = pipeline(isp, noise, sensor_bits)?;
        let (degraded, target) = crate::pool::detach(py, || -> PyResult<(Planar, Planar)> {
            let degraded = self
                .sim
                .degrade_window(&pipeline, &linear, seed, window)
                .or_raise()?;
            Ok((
                degraded,
                pipeline.finish_reference(&crop(&linear, window)).or_raise()?,
            ))
        })?;
        crate::device::warn_image_notes(py, &self.sim.settings.image)?;
        Ok((planar_out(py, &degraded, false)?, planar_out(py, &target, false)?))
    }

    /// The frame region (x0, y0, width_px, height_px) that `render_pair_window` computes for a window.
    fn source_window(
        &self,
        x0: usize,
        y0: usize,
        width_px: usize,
        height_px: usize,
    ) -> PyResult<(usize, usize, usize, usize)> {
        let source = self
            .sim
            .source_window(PixelWindow {
                x0,
                y0,
                width: width_px,
                height: height_px,
            })
            .or_raise()?;
        Ok((source.x0, source.y0, source.width, source.height))
    }

    /// The PSF kernels (float32, (3, K, K)) that blur the output image at pixel (`x_px`, `y_px`)
    /// (column, row; fractional allowed).
    fn psf_at<'py>(&self, py: Python<'py>, x_px: f64, y_px: f64) -> PyResult<Bound<'py, PyAny>> {
        if !(x_px.is_finite() && y_px.is_finite()) {
            return Err(PyValueError::new_err("x_px, y_px: must be finite"));
        }
        let [x, y] = self.sim.grid.to_mm(x_px, y_px);
        let k = self.sim.kernel_size();
        let kernels = crate::pool::detach(py, || self.kernels_at(x, y));
        f32_array(py, kernels, &[CHANNELS, k, k])
    }

    /// PSFs at the centres of a `nodes_y` x `nodes_x` grid of equal cells over the image: a dict with
    /// `kernels` (float32, (nodes_y, nodes_x, 3, K, K)), `x_px` (nodes_x,) and `y_px` (nodes_y,), the
    /// cell centres (column, row), and `pixel_um`. GIL released.
    #[pyo3(signature = (nodes_x, nodes_y))]
    fn psf_grid<'py>(&self, py: Python<'py>, nodes_x: usize, nodes_y: usize) -> PyResult<Bound<'py, PyDict>> {
        if nodes_x == 0 || nodes_y == 0 {
            return Err(PyValueError::new_err("nodes_x, nodes_y: must be at least 1"));
        }
        let centres = |length: usize, nodes: usize| -> Vec<f64> {
            (0..nodes)
                .map(|i| (i as f64 + 0.5) * length as f64 / nodes as f64 - 0.5)
                .collect()
        };
        let xs = centres(self.sim.grid.width_px, nodes_x);
        let ys = centres(self.sim.grid.height_px, nodes_y);
        let data: Vec<f32> = crate::pool::detach(py, || {
            ys.iter()
                .flat_map(|&row| xs.iter().map(move |&column| (column, row)))
                .flat_map(|(column, row)| {
                    let [x, y] = self.sim.grid.to_mm(column, row);
                    self.kernels_at(x, y)
                })
                .collect()
        });
        let k = self.sim.kernel_size();
        let out = PyDict::new(py);
        out.set_item(
            "kernels",
            f32_array(py, data, &[nodes_y, nodes_x, CHANNELS, k, k])?,
        )?;
        out.set_item("x_px", f64_array(py, xs.clone(), &[nodes_x])?)?;
        out.set_item("y_px", f64_array(py, ys.clone(), &[nodes_y])?)?;
        out.set_item("pixel_um", self.sim.grid.pitch_um)?;
        Ok(out)
    }

    /// Where every output pixel sits in the field: float32 H x W x 3 with, per pixel, the sensor
    /// position x_mm, y_mm (sensor +y up, image rows down) and the field angle (deg) of the chief ray
    /// that lands there. A prior for models that use optics (divide x, y by `half_diagonal_mm` to
    /// normalise).
    fn field_map<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (w, h) = (self.sim.grid.width_px, self.sim.grid.height_px);
        let data: Vec<f32> = crate::pool::detach(py, || {
            (0..h * w)
                .flat_map(|i| {
                    let [x, y] = self.sim.grid.to_mm((i % w) as f64, (i / w) as f64);
                    let field = self.sim.field_angle_deg_at(x, y);
                    [x as f32, y as f32, field as f32]
                })
                .collect()
        });
        f32_array(py, data, &[h, w, 3])
    }

    fn __repr__(&self) -> String {
        format!(
            "Simulator(width_px={}, height_px={}, pixel_um={}, kernel_px={})",
            self.sim.grid.width_px,
            self.sim.grid.height_px,
            self.sim.grid.pitch_um,
            self.sim.kernel_size()
        )
    }
}

/// Simulates one image through `lens`, as `unicac simulate LENS IMAGE --seed SEED` (same flags:
/// `isp`, `noise`, `illumination`, `distortion`, `sensor_bits`). `image`: H x W x 3 uint8/uint16 (sRGB) or float32
/// (linear); the result has the same dtype and representation. For many images of one size, build a
/// `Simulator` once instead (the PSFs are traced per call here). `device` as for `Simulator`. GIL
/// released.
#[pyfunction]
#[pyo3(signature = (lens, image, pixel_um=None, seed=0, isp=true, noise=true, illumination=true, distortion=true, sensor_bits=10, device="cpu"))]
#[allow(clippy::too_many_arguments)]
pub fn simulate<'py>(
    py: Python<'py>,
    lens: &PyLens,
    image: &Bound<'py, PyAny>,
    pixel_um: Option<f64>,
    seed: u64,
    isp: bool,
    noise: bool,
    illumination: bool,
    distortion: bool,
    sensor_bits: u8,
    device: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let (linear, _) = image_linear(image, "image")?;
    let simulator = PySimulator::new(
        py,
        lens,
        linear.width,
        linear.height,
        pixel_um,
        distortion,
        illumination,
        device,
    )?;
    simulator.simulate(py, image, seed, isp, noise, sensor_bits)
}

/// PSFs over a `width_px` x `height_px` image at the centres of a `nodes_y` x `nodes_x` grid (see
/// `Simulator.psf_grid`); `device` as for `Simulator`. GIL released.
#[pyfunction]
#[pyo3(signature = (lens, width_px, height_px, nodes_x, nodes_y, pixel_um=None, device="cpu"))]
#[allow(clippy::too_many_arguments)]
pub fn psf_grid<'py>(
    py: Python<'py>,
    lens: &PyLens,
    width_px: usize,
    height_px: usize,
    nodes_x: usize,
    nodes_y: usize,
    pixel_um: Option<f64>,
    device: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let simulator = PySimulator::new(py, lens, width_px, height_px, pixel_um, true, true, device)?;
    simulator.psf_grid(py, nodes_x, nodes_y)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PySimulator>()?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(psf_grid, m)?)?;
    Ok(())
}
