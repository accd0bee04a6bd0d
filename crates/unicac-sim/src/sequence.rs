//! A sequence of images through one lens (what `unicac simulate a.png b.png ...` does): PSF maps depend
//! on the image size, so one simulator serves every image of the size it was made for and a new one is
//! made when the size changes; image k of a run seeded s draws its sensor noise from seed s + k, so an
//! image's output does not depend on how many images came before it, only on its place.

use crate::error::SimResult;
use crate::simulate::{LensSimulator, SimulationSettings};
use unicac_optics::Lens;

/// Simulators for successive images, made when the image size changes.
pub struct SimulatorSequence<'a> {
    lens: &'a Lens,
    pixel_um: Option<f64>,
    settings: SimulationSettings,
    current: Option<LensSimulator>,
}

impl<'a> SimulatorSequence<'a> {
    pub fn new(lens: &'a Lens, pixel_um: Option<f64>, settings: SimulationSettings) -> SimulatorSequence<'a> {
        SimulatorSequence {
            lens,
            pixel_um,
            settings,
            current: None,
        }
    }

    /// The simulator of a `width_px` x `height_px` image: the previous one when its size is the same.
    pub fn for_size(&mut self, width_px: usize, height_px: usize) -> SimResult<&LensSimulator> {
        let reusable = self
            .current
            .as_ref()
            .is_some_and(|s| (s.grid.width_px, s.grid.height_px) == (width_px, height_px));
        if !reusable {
            let simulator = LensSimulator::new(
                self.lens,
                width_px,
                height_px,
                self.pixel_um,
                self.settings.clone(),
            )?;
            self.current = Some(simulator);
        }
        Ok(self.current.as_ref().expect("made above"))
    }
}

/// The noise seed of the `index`-th image of a run seeded `run_seed`.
pub fn image_seed(run_seed: u64, index: usize) -> u64 {
    run_seed.wrapping_add(index as u64)
}
