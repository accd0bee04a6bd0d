//! # unicac-sim
//!
//! Image simulation through a lens: where pixels sit on the sensor and which of them a job takes
//! (`geometry`), the real chief ray over the field with distortion and relative illumination
//! (`chief`), PSFs over the sensor from one radius (`psf_map`), per-pixel radial quantities as lookup
//! tables (`radial_table`), the same over the whole image plane for lenses that are not rotationally
//! symmetric (`planar`: decentred or tilted units), seamless spatially varying convolution
//! (`convolve`), the simulator that puts them together (`simulate`), and the hand-over of its image
//! pass to another device (`device`).
//!
//! Hand-written because these are the product's own optics; parallel with rayon.

pub mod chief;
pub mod convolve;
pub mod device;
pub mod error;
pub mod geometry;
pub mod planar;
pub mod psf_map;
pub mod radial_table;
pub mod sequence;
pub mod simulate;

pub use chief::ChiefRayMap;
pub use device::{ImageBackend, ImageDevice, ImagePass};
pub use error::{SimError, SimResult};
pub use geometry::{PixelWindow, SensorGrid};
pub use planar::PlanarField;
pub use psf_map::{RadialPsfs, RadialSampling};
pub use sequence::{image_seed, SimulatorSequence};
pub use simulate::{crop, FieldOptics, LensSimulator, SimulationSettings, MAX_SIMULATE_PIXELS};
/// The PSF cache lives with the PSFs it caches (unicac-psf); re-exported for the simulator's users.
pub use unicac_psf::cache as psf_cache;
pub use unicac_psf::{cache_root, lens_fingerprint, PsfCache};
