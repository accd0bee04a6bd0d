//! The image pass and the sensor/ISP steps on another device (a GPU). The simulator hands its blur and geometry over as plain
//! data (`ImagePass`): the input region, the kernel grids with the tile layout the CPU path follows,
//! and the radial tables of the warp and the shading. The device returns the output or declines (too
//! small a job for it, no adapter, a failure), and then the CPU path runs: a simulation never fails
//! for want of a device. Defined here, implemented by unicac-gpu, chosen by the faces (`--device`):
//! the shape of `unicac_psf::RayBackend` for the rays.

use crate::convolve::{Blend, KernelGrid, TileLayout};
use crate::geometry::PixelWindow;
use crate::radial_table::RadialTable;
use std::sync::Arc;
use unicac_image::isp::{Demosaic, IspDevice, SensorNoise, WhiteBalanceGains};
use unicac_image::Planar;

/// One region's optics, as the CPU path computes them in `LensSimulator::apply_region`: each channel
/// of `image` (the frame pixels `source`) convolved with its kernel grid by `layout` and `blend` (when
/// `blur` is set; else the region as it is), then every output pixel of `window` sampling the blurred
/// region at its ideal position (the warp; the pixel itself when `warp_scale` is None) times the
/// shading (1 when `shading` is None). `LensSimulator::blur` and `geometry` are the two halves.
pub struct ImagePass<'a> {
    pub image: &'a Planar,
    pub blur: bool,
    pub source: PixelWindow,
    pub window: PixelWindow,
    pub grids: [&'a KernelGrid; 3],
    pub layouts: [&'a TileLayout; 3],
    pub blend: Blend,
    /// The frame's centre (pixels): the warp and the shading depend on the distance from it.
    pub centre_px: [f64; 2],
    pub warp_scale: Option<&'a RadialTable>,
    pub shading: Option<&'a RadialTable>,
}

/// A device that can run an `ImagePass`, and the sensor/ISP steps it takes (`IspDevice`).
pub trait ImageDevice: IspDevice + Send + Sync {
    /// The pass's output (`window`'s size, 3 channels), or None to leave it to the CPU path (the reason,
    /// when the user should hear it, is kept for `take_notes`).
    fn apply(&self, pass: &ImagePass) -> Option<Planar>;
    /// Where the pass ran last ("cpu", "gpu (llvmpipe ...)"): for reports.
    fn describe(&self) -> String;
    /// Notes gathered since the last call (a fallback to the CPU), for the face to print.
    fn take_notes(&self) -> Vec<String>;
}

/// The device of a simulator's image pass: the CPU path (the default) or an `ImageDevice`.
#[derive(Clone, Default)]
pub struct ImageBackend(Option<Arc<dyn ImageDevice>>);

impl ImageBackend {
    pub fn cpu() -> ImageBackend {
        ImageBackend(None)
    }

    pub fn new(device: Arc<dyn ImageDevice>) -> ImageBackend {
        ImageBackend(Some(device))
    }

    /// Whether this is the plain CPU path (no device at all).
    pub fn is_cpu(&self) -> bool {
        self.0.is_none()
    }

    /// The device's output, or None for the CPU path.
    pub fn apply(&self, pass: &ImagePass) -> Option<Planar> {
        self.0.as_ref()?.apply(pass)
    }

    pub fn describe(&self) -> String {
        self.0.as_ref().map_or_else(|| "cpu".into(), |d| d.describe())
    }

    pub fn take_notes(&self) -> Vec<String> {
        self.0.as_ref().map(|d| d.take_notes()).unwrap_or_default()
    }
}

/// The backend's device takes the ISP steps it offers; the CPU path takes none.
impl IspDevice for ImageBackend {
    fn read_out(&self, exposure: &Planar, sensor: &SensorNoise, noise_seed: u64) -> Option<Planar> {
        self.0.as_ref()?.read_out(exposure, sensor, noise_seed)
    }

    fn develop(
        &self,
        dn: &Planar,
        sensor: &SensorNoise,
        gains: WhiteBalanceGains,
        method: Demosaic,
    ) -> Option<Planar> {
        self.0.as_ref()?.develop(dn, sensor, gains, method)
    }
}

/// Two backends are equal when they are the same device (or both the CPU path).
impl PartialEq for ImageBackend {
    fn eq(&self, other: &Self) -> bool {
        match (&self.0, &other.0) {
            (None, None) => true,
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            _ => false,
        }
    }
}

impl std::fmt::Debug for ImageBackend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:?}", self.describe())
    }
}
