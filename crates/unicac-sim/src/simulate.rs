//! `LensSimulator`: a sharp linear-light image on the sensor in, the lens's image of it out.
//!
//! Coordinates: the input is the **ideal** image (each scene direction at its paraxial, distortion-free
//! position on the sensor grid). The simulator blurs it with the PSF of the field imaged there
//! (spatially varying, `convolve`), then optionally warps it to the real chief-ray positions
//! (distortion; outside the input it replicates the border) and scales by the relative illumination
//! (chief-ray mapping and vignetting). A rotationally symmetric lens reads all three off one field
//! radius (`FieldOptics::Radial`); one that is not (a decentred or tilted unit) off maps over the
//! image plane (`FieldOptics::Planar`, `planar`), whose warp and shading run on the CPU path.

use crate::chief::ChiefRayMap;
use crate::convolve::{
    convolve_varying_laid_out, node_positions, Blend, KernelGrid, Method, TileLayout, KERNEL_TAIL_TOLERANCE,
};
use crate::device::{ImageBackend, ImagePass};
use crate::error::SimResult;
use crate::geometry::{PixelWindow, SensorGrid};
use crate::planar::{PlanarField, DEFAULT_PLANAR_PSF_INTERVALS};
use crate::psf_map::{RadialPsfs, RadialSampling, DEFAULT_RADIAL_SAMPLING};
use crate::radial_table::RadialTable;
use rayon::prelude::*;
use serde::Serialize;
use std::borrow::Cow;
use unicac_image::isp::{IspDraw, Pipeline};
use unicac_image::Planar;
use unicac_io::digest::canonical_json;
use unicac_optics::Lens;
use unicac_psf::{lens_fingerprint, FieldPsf, Kernel, PsfCache};
use unicac_psf::{visible_wavelengths_um, PsfSettings, PsfTracer, SpectralResponse, SpectralWeights};
use unicac_trace::InvalidParameter;

/// Fidelity and effect switches (defaults at the knee of the sweep in docs/performance.md).
#[derive(Debug, Clone, Serialize)]
pub struct SimulationSettings {
    pub psf: PsfSettings,
    /// Wavelengths from 400 to 700 nm.
    pub wavelengths: usize,
    /// Where the radial PSF samples from the axis to the corner go (`psf_map::RadialSampling`).
    pub radial: RadialSampling,
    /// For a lens that is not rotationally symmetric: PSF lattice intervals along the image's longer
    /// side (`planar`; a field is traced at every lattice node).
    pub planar_psf_intervals: usize,
    /// Use the planar maps even for a rotationally symmetric lens (what the dataset's as-built split
    /// renders its designs with, so that a design and its units share one path; the radial path turns
    /// its kernels by resampling, which spreads kernels of a few pixels: docs/tolerancing.md).
    pub planar: bool,
    /// Kernel-node intervals along the image's longer side. Field-relative, so the interpolation error
    /// stays the same at every resolution (the PSF changes over a fraction of the field, not over a
    /// number of pixels); the spacing never drops below `MIN_NODE_SPACING_PX`.
    pub node_intervals: usize,
    /// Direct or FFT corner convolutions (same result; `Auto` takes the cheaper).
    pub method: Method,
    /// Share of each kernel's L1 mass that a tile's convolution may crop away, so that tiles with small
    /// PSFs convolve with small kernels (`convolve::extent`: every output pixel moves by at most this
    /// times the image's largest value; 0 crops exact zeros only).
    pub kernel_tail: f64,
    pub blend: Blend,
    pub distortion: bool,
    pub illumination: bool,
    #[serde(skip)]
    pub response: SpectralResponse,
    /// Where the image pass (blur, warp, shading) runs: the CPU path, or a device that may take it
    /// (`device`; it falls back to the CPU path whenever it declines).
    #[serde(skip)]
    pub image: ImageBackend,
    /// Where traced PSF maps are kept between runs (`None`: always trace).
    #[serde(skip)]
    pub cache: Option<PsfCache>,
}

/// Most pixels of an image `LensSimulator` takes (2^27, 134 MP). Peak memory of `unicac simulate` is
/// linear in the pixel count, measured at about 98 MB + 70 B per pixel (docs/reliability.md): 9.5 GB
/// at this limit.
pub const MAX_SIMULATE_PIXELS: usize = 1 << 27;

/// Node spacing floor (pixels): below it nodes cost more than they correct (docs/performance.md).
pub const MIN_NODE_SPACING_PX: usize = 8;

impl Default for SimulationSettings {
    fn default() -> Self {
        SimulationSettings {
            psf: PsfSettings::new(1.0),
            wavelengths: 31,
            radial: DEFAULT_RADIAL_SAMPLING,
            planar_psf_intervals: DEFAULT_PLANAR_PSF_INTERVALS,
            planar: false,
            node_intervals: 20,
            method: Method::Auto,
            kernel_tail: KERNEL_TAIL_TOLERANCE,
            blend: Blend::Bilinear,
            distortion: true,
            illumination: true,
            response: SpectralResponse::default_camera(),
            image: ImageBackend::cpu(),
            cache: None,
        }
    }
}

/// Where the simulator reads the lens's PSFs, warp and shading.
#[derive(Debug, Clone)]
pub enum FieldOptics {
    /// A rotationally symmetric lens: PSFs along one radius turned into place (`psf_map`), the warp's
    /// scale and the shading as functions of the radius (`radial_table`).
    Radial {
        psfs: RadialPsfs,
        /// ideal height / real height as a function of the real radius (pixels): the warp's scale.
        warp_scale: RadialTable,
        /// Relative illumination times vignetting, normalised by the peak transmission, over the radius.
        shading: RadialTable,
    },
    /// A lens that is not (decentred or tilted surfaces): maps over the whole image plane (`planar`).
    Planar(PlanarField),
}

impl FieldOptics {
    /// Side of the PSF kernels (pixels, odd).
    pub fn kernel_size(&self) -> usize {
        match self {
            FieldOptics::Radial { psfs, .. } => psfs.kernel_size,
            FieldOptics::Planar(planar) => planar.kernel_size,
        }
    }
}

pub struct LensSimulator {
    pub grid: SensorGrid,
    /// The real chief ray over the field: of the lens, or of its centred twin (`Lens::nominal`) when
    /// the lens is not rotationally symmetric (then only its ideal scale and largest field are used).
    pub chief: ChiefRayMap,
    pub optics: FieldOptics,
    pub settings: SimulationSettings,
    /// SHA-256 of the lens model (provenance; see `psf_cache`).
    pub lens_sha256: String,
    /// Whether the PSF map came from the cache instead of being traced.
    pub psfs_from_cache: bool,
    /// Why a freshly traced map could not be stored in the cache (the simulation itself is unaffected).
    pub cache_warning: Option<String>,
    kernels: Vec<KernelGrid>,
    /// The frame's tile layout per channel (made once: a simulator renders many images).
    layouts: Vec<TileLayout>,
}

impl LensSimulator {
    /// Prepares PSFs for a `width` x `height` image; `pixel_um` None fills the lens's field.
    pub fn new(
        lens: &Lens,
        width: usize,
        height: usize,
        pixel_um: Option<f64>,
        settings: SimulationSettings,
    ) -> SimResult<LensSimulator> {
        if width < 2 || height < 2 {
            return Err(InvalidParameter::new(
                "image_px",
                format!("{width} x {height}: too small (at least 2 x 2)"),
            )
            .into());
        }
        if width.saturating_mul(height) > MAX_SIMULATE_PIXELS {
            return Err(InvalidParameter::new(
                "image_px",
                format!(
                    "{width} x {height}: exceeds the limit of {MAX_SIMULATE_PIXELS} pixels \
                     (MAX_SIMULATE_PIXELS; peak memory grows with the pixel count, see docs/reliability.md)"
                ),
            )
            .into());
        }
        let nominal;
        let symmetric_lens = if lens.is_rotationally_symmetric() {
            lens
        } else {
            nominal = lens.nominal();
            &nominal
        };
        let chief = ChiefRayMap::new(symmetric_lens)?;
        let grid = match pixel_um {
            Some(p) => SensorGrid {
                width_px: width,
                height_px: height,
                pitch_um: unicac_psf::check_pixel_um(p)?,
            },
            None => SensorGrid::filling_field(width, height, &chief),
        };
        let mut psf_settings = settings.psf.clone();
        psf_settings.pixel_um = grid.pitch_um;
        let weights = SpectralWeights::new(&settings.response, &visible_wavelengths_um(settings.wavelengths));
        let tracer = PsfTracer::new(lens, weights, psf_settings.clone())?;
        let lens_sha256 = lens_fingerprint(lens);
        let (optics, psfs_from_cache, cache_warning) = if lens.is_rotationally_symmetric() && !settings.planar
        {
            radial_optics(&tracer, &chief, &grid, &settings, &psf_settings, &lens_sha256)?
        } else {
            let planar = PlanarField::trace(lens, &tracer, &chief, grid, settings.planar_psf_intervals)?;
            (FieldOptics::Planar(planar), false, None)
        };
        let kernel_size = optics.kernel_size();
        if kernel_size > grid.width_px.min(grid.height_px) {
            return Err(InvalidParameter::new(
                "image_px",
                format!(
                    "{width} x {height}: the PSF ({kernel_size} px) is larger than the image; simulate a larger image"
                ),
            )
            .into());
        }
        let mut simulator = LensSimulator {
            grid,
            chief,
            optics,
            settings,
            lens_sha256,
            psfs_from_cache,
            cache_warning,
            kernels: Vec::new(),
            layouts: Vec::new(),
        };
        let frame = simulator.frame();
        simulator.kernels = (0..3).map(|c| simulator.kernel_grid(c, frame)).collect();
        let kernel_tail = simulator.settings.kernel_tail;
        simulator.layouts = (simulator.kernels.iter())
            .map(|grid| TileLayout::new(width, height, grid, kernel_tail))
            .collect();
        Ok(simulator)
    }

    /// The radially symmetric lens's PSFs (None for a planar one: see `optics`).
    pub fn radial(&self) -> Option<&RadialPsfs> {
        match &self.optics {
            FieldOptics::Radial { psfs, .. } => Some(psfs),
            FieldOptics::Planar(_) => None,
        }
    }

    /// Every traced PSF (the radial samples or the planar lattice's fields), all of `kernel_size` px.
    pub fn psfs(&self) -> &[FieldPsf] {
        match &self.optics {
            FieldOptics::Radial { psfs, .. } => &psfs.psfs,
            FieldOptics::Planar(planar) => &planar.psfs,
        }
    }

    /// Side of the PSF kernels (pixels, odd).
    pub fn kernel_size(&self) -> usize {
        self.optics.kernel_size()
    }

    /// The PSF of `channel` that blurs the output image at sensor point (x, y) mm (the field landing
    /// there).
    pub fn kernel_at(&self, x_mm: f64, y_mm: f64, channel: usize) -> Kernel {
        match &self.optics {
            FieldOptics::Radial { psfs, .. } => psfs.kernel_at(x_mm, y_mm, channel),
            FieldOptics::Planar(planar) => {
                let real = self.grid.to_px([x_mm, y_mm]);
                planar.kernel_at_ideal(planar.ideal_for(real, real), channel)
            }
        }
    }

    /// Angle from the axis (deg) of the field whose chief ray lands at sensor point (x, y) mm.
    pub fn field_angle_deg_at(&self, x_mm: f64, y_mm: f64) -> f64 {
        match &self.optics {
            FieldOptics::Radial { .. } => self.chief.angle_for_height(x_mm.hypot(y_mm)),
            FieldOptics::Planar(planar) => {
                let real = self.grid.to_px([x_mm, y_mm]);
                let [x, y] = planar.field_deg_at(&self.chief, planar.ideal_for(real, real));
                x.to_radians()
                    .tan()
                    .hypot(y.to_radians().tan())
                    .atan()
                    .to_degrees()
            }
        }
    }

    /// Real (distorted) sensor position of the field whose ideal image is at `ideal_mm`.
    fn real_position(&self, ideal_mm: [f64; 2]) -> [f64; 2] {
        if !self.settings.distortion || self.chief.paraxial_height_per_tan_mm() == 0.0 {
            return ideal_mm;
        }
        let ideal = ideal_mm[0].hypot(ideal_mm[1]);
        if ideal == 0.0 {
            return ideal_mm;
        }
        let angle = (ideal / self.chief.paraxial_height_per_tan_mm())
            .atan()
            .to_degrees();
        let scale = self.chief.height_for_angle(angle) / ideal;
        [ideal_mm[0] * scale, ideal_mm[1] * scale]
    }

    /// Kernel nodes over `window` (frame pixels), spaced as for the whole frame; the kernel of each node
    /// is the PSF of the field imaged at that frame position.
    fn kernel_grid(&self, channel: usize, window: PixelWindow) -> KernelGrid {
        let spacing = self.node_spacing_px();
        let nodes = |length: usize| ((length - 1).div_ceil(spacing) + 1).max(2);
        let (nodes_x, nodes_y) = (nodes(window.width), nodes(window.height));
        let xs = node_positions(window.width, nodes_x);
        let ys = node_positions(window.height, nodes_y);
        let (x0, y0) = (window.x0 as f64, window.y0 as f64);
        let kernels = ys
            .par_iter()
            .flat_map_iter(|&row| xs.iter().map(move |&column| (column, row)))
            .map(|(column, row)| match &self.optics {
                FieldOptics::Radial { psfs, .. } => {
                    let [x, y] = self.real_position(self.grid.to_mm(x0 + column, y0 + row));
                    psfs.kernel_at(x, y, channel)
                }
                FieldOptics::Planar(planar) => planar.kernel_at_ideal([x0 + column, y0 + row], channel),
            })
            .collect();
        KernelGrid::new(nodes_x, nodes_y, kernels)
            .expect("one kernel per node, all of the radial table's odd size")
    }

    fn frame(&self) -> PixelWindow {
        PixelWindow {
            x0: 0,
            y0: 0,
            width: self.grid.width_px,
            height: self.grid.height_px,
        }
    }

    /// The kernel grids of the whole frame, one per channel (R, G, B).
    pub fn kernel_grids(&self) -> &[KernelGrid] {
        &self.kernels
    }

    /// Distance between kernel nodes (pixels) for this image size.
    pub fn node_spacing_px(&self) -> usize {
        let longer = self.grid.width_px.max(self.grid.height_px);
        (longer / self.settings.node_intervals.max(1)).max(MIN_NODE_SPACING_PX)
    }

    /// Simulates the lens on a linear RGB image of the prepared size: `blur`, then `geometry` (on the
    /// settings' image device when it takes the pass).
    pub fn apply(&self, image: &Planar) -> SimResult<Planar> {
        self.apply_cow(Cow::Borrowed(image))
    }

    /// `apply` of an image the caller gives up (see `apply_cow`).
    fn apply_consuming(&self, image: Planar) -> SimResult<Planar> {
        self.apply_cow(Cow::Owned(image))
    }

    /// `apply`; an owned image is dead once blurred, so the CPU path's warp writes its output over it
    /// instead of into a new frame (at 12 MP 144 MB fewer fresh pages).
    fn apply_cow(&self, image: Cow<Planar>) -> SimResult<Planar> {
        self.check_frame(&image)?;
        let blurred = if self.geometry_on_device() {
            if let Some(out) = self.settings.image.apply(&self.frame_pass(&image)) {
                return Ok(out);
            }
            // The CPU path, without asking the device again for each half.
            self.blur_on_cpu(&image)
        } else {
            self.blur(&image)?
        };
        if !self.moves_or_shades() {
            return Ok(blurred); // no copy of a frame that `geometry` would hand back unchanged
        }
        let frame = self.frame();
        let out = match image {
            Cow::Owned(sharp) => sharp,
            Cow::Borrowed(_) => Planar::new(frame.width, frame.height, 3),
        };
        Ok(self.warp_and_shade_into(&blurred, frame, frame, out))
    }

    /// The lens's spatially varying blur alone (no distortion, no shading), in the ideal image's
    /// coordinates: what `apply` does before `geometry`.
    pub fn blur(&self, image: &Planar) -> SimResult<Planar> {
        self.check_frame(image)?;
        let pass = ImagePass {
            warp_scale: None,
            shading: None,
            ..self.frame_pass(image)
        };
        if let Some(out) = self.settings.image.apply(&pass) {
            return Ok(out);
        }
        Ok(self.blur_on_cpu(image))
    }

    /// `blur` on the CPU path (the frame checked by the caller).
    fn blur_on_cpu(&self, image: &Planar) -> Planar {
        let (w, h) = (self.grid.width_px, self.grid.height_px);
        let mut blurred = Planar::new(w, h, 3);
        for c in 0..3 {
            convolve_varying_laid_out(
                image.plane(c),
                w,
                h,
                &self.kernels[c],
                &self.layouts[c],
                self.settings.method,
                self.settings.blend,
                blurred.plane_mut(c),
            );
        }
        blurred
    }

    /// The whole frame's optics, as a device takes them.
    fn frame_pass<'a>(&'a self, image: &'a Planar) -> ImagePass<'a> {
        let frame = self.frame();
        let grids = [&self.kernels[0], &self.kernels[1], &self.kernels[2]];
        let layouts = [&self.layouts[0], &self.layouts[1], &self.layouts[2]];
        self.image_pass(image, frame, frame, grids, layouts)
    }

    /// Whether a device may take the warp and the shading: they are radial tables for a symmetric
    /// lens; a planar lens's stay on the CPU path (a device may still take its blur).
    fn geometry_on_device(&self) -> bool {
        matches!(self.optics, FieldOptics::Radial { .. })
    }

    /// The optics of `region` (frame pixels `source`) for the output pixels `window`, as a device
    /// takes them (without the warp and the shading when they cannot go there: `geometry_on_device`).
    fn image_pass<'a>(
        &'a self,
        region: &'a Planar,
        source: PixelWindow,
        window: PixelWindow,
        grids: [&'a KernelGrid; 3],
        layouts: [&'a TileLayout; 3],
    ) -> ImagePass<'a> {
        let (warp_scale, shading) = match &self.optics {
            FieldOptics::Radial {
                warp_scale, shading, ..
            } => (
                self.settings.distortion.then_some(warp_scale),
                self.settings.illumination.then_some(shading),
            ),
            FieldOptics::Planar(_) => (None, None),
        };
        ImagePass {
            image: region,
            blur: true,
            source,
            window,
            grids,
            layouts,
            blend: self.settings.blend,
            centre_px: self.grid.centre_px(),
            warp_scale,
            shading,
        }
    }

    /// The lens's geometry alone on a frame-sized linear RGB image: the distortion warp and the
    /// relative-illumination shading that `apply` puts after the blur (each only when switched on).
    /// Carrying a sharp image through it gives the target whose pixels correspond to `apply`'s.
    pub fn geometry(&self, image: &Planar) -> SimResult<Planar> {
        self.check_frame(image)?;
        if !self.moves_or_shades() {
            return Ok(image.clone());
        }
        if self.geometry_on_device() {
            let pass = ImagePass {
                blur: false,
                ..self.frame_pass(image)
            };
            if let Some(out) = self.settings.image.apply(&pass) {
                return Ok(out);
            }
        }
        let frame = self.frame();
        Ok(self.warp_and_shade(image, frame, frame))
    }

    /// Whether `geometry` changes an image: the distortion warp or the shading is switched on.
    fn moves_or_shades(&self) -> bool {
        self.settings.distortion || self.settings.illumination
    }

    /// The whole chain on one sharp linear image, as `unicac simulate` runs it: the ISP draw of `seed`
    /// (white-balance perturbation, noise seed), inverse white balance, the optics (`apply`), then sensor
    /// noise and the ISP. The image is consumed (unprocessed in place).
    pub fn degrade(&self, pipeline: &Pipeline, image: Planar, seed: u64) -> SimResult<Planar> {
        let draw = pipeline.draw(seed)?;
        let raw = pipeline.unprocess(image, &draw)?;
        self.process(pipeline, &self.apply_consuming(raw)?, &draw)
    }

    /// `pipeline.process` (the sensor and the ISP) with the steps this simulator's image device takes
    /// (the noisy read-out, the development of the mosaic) run there.
    pub fn process(&self, pipeline: &Pipeline, raw: &Planar, draw: &IspDraw) -> SimResult<Planar> {
        Ok(pipeline.process_on(raw, draw, &self.settings.image)?)
    }

    /// The ideal (undistorted) frame position that output pixel `real` (frame pixels) shows, where the
    /// warp samples the blurred ideal image, and the shading there (1 with the illumination off).
    /// `guess`: an ideal position near the answer (the planar map's inversion starts there).
    #[inline(always)]
    fn source_of(&self, real: [f64; 2], guess: [f64; 2]) -> ([f64; 2], f32) {
        match &self.optics {
            FieldOptics::Radial {
                warp_scale, shading, ..
            } => {
                // Pixel offsets from the centre scale like sensor millimetres (the same factor on both
                // axes).
                let [cx, cy] = self.grid.centre_px();
                let (dx, dy) = (real[0] - cx, real[1] - cy);
                let radius = (dx * dx + dy * dy).sqrt();
                let scale = if self.settings.distortion {
                    warp_scale.at(radius)
                } else {
                    1.0
                };
                let shade = if self.settings.illumination {
                    shading.at(radius) as f32
                } else {
                    1.0
                };
                ([cx + dx * scale, cy + dy * scale], shade)
            }
            FieldOptics::Planar(planar) => {
                let ideal = if self.settings.distortion {
                    planar.ideal_for(real, guess)
                } else {
                    real
                };
                let shade = if self.settings.illumination {
                    planar.shading_at(ideal) as f32
                } else {
                    1.0
                };
                (ideal, shade)
            }
        }
    }

    /// Distortion and shading of the output pixels of `window` in one pass over them: output pixel at
    /// real position r samples `blurred` (which covers `source` of the frame) at the ideal position of
    /// the field landing at r (bilinear; when the distortion is off, at r itself, which copies the
    /// pixel), times the shading at r when it is on (`source_of`).
    fn warp_and_shade(&self, blurred: &Planar, source: PixelWindow, window: PixelWindow) -> Planar {
        let out = Planar::new(window.width, window.height, 3);
        self.warp_and_shade_into(blurred, source, window, out)
    }

    /// `warp_and_shade` into `out` (window-sized, RGB; every sample is written, so its values do not
    /// matter).
    fn warp_and_shade_into(
        &self,
        blurred: &Planar,
        source: PixelWindow,
        window: PixelWindow,
        mut out: Planar,
    ) -> Planar {
        assert_eq!(blurred.channels, 3, "an RGB image");
        assert_eq!(
            (out.width, out.height, out.channels),
            (window.width, window.height, 3),
            "an output of the window's size"
        );
        let (w, h) = (blurred.width, blurred.height);
        let planes = [blurred.plane(0), blurred.plane(1), blurred.plane(2)];
        let (red, rest) = out.data.split_at_mut(window.width * window.height);
        let (green, blue) = rest.split_at_mut(window.width * window.height);
        red.par_chunks_mut(window.width)
            .zip(green.par_chunks_mut(window.width))
            .zip(blue.par_chunks_mut(window.width))
            .enumerate()
            .for_each(|(row, ((red, green), blue))| {
                let y = (window.y0 + row) as f64;
                let mut guess = [window.x0 as f64, y];
                for column in 0..window.width {
                    let ([x, y], shade) = self.source_of([(window.x0 + column) as f64, y], guess);
                    // The next pixel's source sits about one pixel further along.
                    guess = [x + 1.0, y];
                    let taps = BilinearTaps::new(w, h, x - source.x0 as f64, y - source.y0 as f64);
                    red[column] = taps.sample(planes[0]) * shade;
                    green[column] = taps.sample(planes[1]) * shade;
                    blue[column] = taps.sample(planes[2]) * shade;
                }
            });
        out
    }

    /// The frame pixels that the output pixels of `window` depend on: the ideal positions they sample
    /// (distortion), grown by the kernel radius and one pixel for the bilinear sample, clipped to the
    /// frame. Inside the frame, a render of this region alone equals the whole frame's there.
    pub fn source_window(&self, window: PixelWindow) -> SimResult<PixelWindow> {
        window.check_inside(self.grid.width_px, self.grid.height_px)?;
        let (mut lo_x, mut lo_y, mut hi_x, mut hi_y) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
        let border = (0..window.width)
            .flat_map(|c| [(c, 0), (c, window.height - 1)])
            .chain((0..window.height).flat_map(|r| [(0, r), (window.width - 1, r)]));
        // The ideal-position map is one-to-one and continuous (a monotonic radial scaling, or the
        // inverse of a planar landing map that does not fold), so the window's border bounds the
        // sources of all its pixels.
        for (column, row) in border {
            let real = [(window.x0 + column) as f64, (window.y0 + row) as f64];
            let ([x, y], _) = self.source_of(real, real);
            (lo_x, lo_y, hi_x, hi_y) = (lo_x.min(x), lo_y.min(y), hi_x.max(x), hi_y.max(y));
        }
        let margin = (self.kernel_size() / 2 + 2) as f64;
        let (w, h) = (self.grid.width_px as f64, self.grid.height_px as f64);
        let x0 = (lo_x - margin).floor().clamp(0.0, w - 1.0) as usize;
        let y0 = (lo_y - margin).floor().clamp(0.0, h - 1.0) as usize;
        let x1 = (hi_x + margin).ceil().clamp(0.0, w - 1.0) as usize;
        let y1 = (hi_y + margin).ceil().clamp(0.0, h - 1.0) as usize;
        Ok(PixelWindow {
            x0,
            y0,
            width: x1 - x0 + 1,
            height: y1 - y0 + 1,
        })
    }

    /// `apply` for the output pixels of `window` only: the optics on `image` (the whole frame, linear
    /// RGB) computed over `source_window(window)` instead of the frame. Equal to the window of `apply`
    /// up to the placement of kernel nodes (the nodes are laid over the region, at the frame's spacing).
    pub fn apply_window(&self, image: &Planar, window: PixelWindow) -> SimResult<Planar> {
        self.check_frame(image)?;
        let source = self.source_window(window)?;
        self.apply_region(&crop(image, source), source, window)
    }

    /// `degrade` for the output pixels of `window` only (`apply_window` between the ISP steps; the
    /// Bayer pattern starts at the window's top-left pixel).
    pub fn degrade_window(
        &self,
        pipeline: &Pipeline,
        image: &Planar,
        seed: u64,
        window: PixelWindow,
    ) -> SimResult<Planar> {
        self.check_frame(image)?;
        let source = self.source_window(window)?;
        let draw = pipeline.draw(seed)?;
        let raw = pipeline.unprocess(crop(image, source), &draw)?;
        self.process(pipeline, &self.apply_region(&raw, source, window)?, &draw)
    }

    fn apply_region(&self, region: &Planar, source: PixelWindow, window: PixelWindow) -> SimResult<Planar> {
        let grids: Vec<KernelGrid> = (0..3).map(|c| self.kernel_grid(c, source)).collect();
        let layouts: Vec<TileLayout> = (grids.iter())
            .map(|grid| TileLayout::new(source.width, source.height, grid, self.settings.kernel_tail))
            .collect();
        let pass = self.image_pass(
            region,
            source,
            window,
            [&grids[0], &grids[1], &grids[2]],
            [&layouts[0], &layouts[1], &layouts[2]],
        );
        if self.geometry_on_device() || !self.moves_or_shades() {
            if let Some(out) = self.settings.image.apply(&pass) {
                return Ok(out);
            }
        }
        let mut blurred = Planar::new(source.width, source.height, 3);
        for c in 0..3 {
            convolve_varying_laid_out(
                region.plane(c),
                source.width,
                source.height,
                &grids[c],
                &layouts[c],
                self.settings.method,
                self.settings.blend,
                blurred.plane_mut(c),
            );
        }
        if !self.moves_or_shades() {
            return Ok(crop(
                &blurred,
                PixelWindow {
                    x0: window.x0 - source.x0,
                    y0: window.y0 - source.y0,
                    ..window
                },
            ));
        }
        Ok(self.warp_and_shade(&blurred, source, window))
    }

    fn check_frame(&self, image: &Planar) -> SimResult<()> {
        let (w, h) = (self.grid.width_px, self.grid.height_px);
        if image.width != w || image.height != h || image.channels != 3 {
            return Err(InvalidParameter::new(
                "image",
                format!(
                    "expected a {w} x {h} RGB image, got {} x {} with {} channels",
                    image.width, image.height, image.channels
                ),
            )
            .into());
        }
        Ok(())
    }
}

/// The radial optics of a rotationally symmetric lens, from the cache when it holds them: the optics,
/// whether they came from the cache, and why a fresh map could not be stored there.
fn radial_optics(
    tracer: &PsfTracer,
    chief: &ChiefRayMap,
    grid: &SensorGrid,
    settings: &SimulationSettings,
    psf_settings: &PsfSettings,
    lens_sha256: &str,
) -> SimResult<(FieldOptics, bool, Option<String>)> {
    let corner = grid.half_diagonal_mm().min(chief.max_height_mm());
    // The cache key covers everything the radial PSFs depend on, the tracing device included (a GPU f32
    // map is not served to a CPU run): the settings' backend is the one that traces.
    let cache_entry = settings.cache.as_ref().map(|cache| {
        let inputs = (
            psf_settings,
            &psf_settings.backend,
            tracer.weights(),
            corner,
            settings.radial,
        );
        let key = PsfCache::key(&[b"radial", lens_sha256.as_bytes(), &canonical_json(&inputs)]);
        (cache, key)
    });
    let cached = cache_entry
        .as_ref()
        .and_then(|(cache, key)| cache.load(key))
        .and_then(|psfs| RadialPsfs::from_psfs(corner, chief, psfs));
    let psfs_from_cache = cached.is_some();
    let mut cache_warning = None;
    let psfs = match cached {
        Some(radial) => radial,
        None => {
            let radial = RadialPsfs::trace(tracer, chief, corner, settings.radial, false)?;
            if let Some((cache, key)) = &cache_entry {
                // A cache that cannot be written costs the next run time, not this run its result.
                if let Err(error) = cache.store(key, &radial.psfs) {
                    cache_warning = Some(format!("PSF cache {}: {error}", cache.dir.display()));
                }
            }
            radial
        }
    };
    let max_radius_px = 0.5 * (grid.width_px as f64).hypot(grid.height_px as f64);
    let warp_scale = RadialTable::sample(max_radius_px, |r| exact_warp_scale(chief, grid, r));
    let shading = RadialTable::sample(max_radius_px, |r| exact_shading(chief, &psfs, grid, r));
    let optics = FieldOptics::Radial {
        psfs,
        warp_scale,
        shading,
    };
    Ok((optics, psfs_from_cache, cache_warning))
}

/// The warp's scale at `radius_px` from the frame centre, evaluated from the chief-ray map: the output
/// pixel at real radius r samples the ideal image at r times this (tabulated in `LensSimulator::new`).
fn exact_warp_scale(chief: &ChiefRayMap, grid: &SensorGrid, radius_px: f64) -> f64 {
    if chief.paraxial_height_per_tan_mm() == 0.0 {
        return 1.0;
    }
    // On the axis, the limit of ideal / real (the first chief-ray segment is linear).
    let radius_mm = (radius_px * grid.pitch_um * 1e-3).max(1e-9);
    chief.ideal_height(radius_mm) / radius_mm
}

/// The shading factor at `radius_px` from the frame centre: the chief-ray map's relative illumination
/// times the radial PSFs' transmission, normalised by the peak transmission (tabulated in
/// `LensSimulator::new`).
fn exact_shading(chief: &ChiefRayMap, radial: &RadialPsfs, grid: &SensorGrid, radius_px: f64) -> f64 {
    let radius_mm = radius_px * grid.pitch_um * 1e-3;
    let axis = radial.peak_transmission().max(1e-12);
    chief.illumination_factor(radius_mm) * radial.transmission_at(radius_mm) / axis
}

/// The pixels of `window` of `image`.
pub fn crop(image: &Planar, window: PixelWindow) -> Planar {
    let mut out = Planar::new(window.width, window.height, image.channels);
    for c in 0..image.channels {
        let plane = image.plane(c);
        let target = out.plane_mut(c);
        for row in 0..window.height {
            let start = (window.y0 + row) * image.width + window.x0;
            target[row * window.width..(row + 1) * window.width]
                .copy_from_slice(&plane[start..start + window.width]);
        }
    }
    out
}

/// The four pixels around a (fractional) position and their bilinear weights, found once and applied
/// to each channel. Positions outside the plane are clamped to its border (edge replication).
struct BilinearTaps {
    top: usize,
    bottom: usize,
    left: usize,
    right: usize,
    tx: f32,
    ty: f32,
}

impl BilinearTaps {
    #[inline]
    fn new(width: usize, height: usize, x: f64, y: f64) -> BilinearTaps {
        let x = x.clamp(0.0, width as f64 - 1.0);
        let y = y.clamp(0.0, height as f64 - 1.0);
        let (x0, y0) = (x as usize, y as usize);
        BilinearTaps {
            top: y0 * width,
            bottom: (y0 + 1).min(height - 1) * width,
            left: x0,
            right: (x0 + 1).min(width - 1),
            tx: (x - x0 as f64) as f32,
            ty: (y - y0 as f64) as f32,
        }
    }

    #[inline]
    fn sample(&self, plane: &[f32]) -> f32 {
        let top = plane[self.top + self.left] * (1.0 - self.tx) + plane[self.top + self.right] * self.tx;
        let bottom =
            plane[self.bottom + self.left] * (1.0 - self.tx) + plane[self.bottom + self.right] * self.tx;
        top * (1.0 - self.ty) + bottom * self.ty
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::radial_table::{SHADING_BOUND, WARP_BOUND_PX};
    use unicac_optics::builtin;

    #[test]
    fn lookups_match_the_exact_per_pixel_evaluation_within_the_stated_bound() {
        let settings = SimulationSettings {
            wavelengths: 5,
            radial: RadialSampling {
                max_samples: 9,
                ..SimulationSettings::default().radial
            },
            ..SimulationSettings::default()
        };
        // The smallest frame has the largest curvature per pixel, i.e. the largest interpolation error.
        let mut checked = 0;
        for (width, height) in [(200, 150), (1000, 750)] {
            for name in builtin::names() {
                let lens = builtin::lens(name).expect("a bundled lens");
                // A lens whose PSF outgrows the small frame is refused there; it is checked at 1000 x 750.
                let Ok(simulator) = LensSimulator::new(&lens, width, height, None, settings.clone()) else {
                    assert!(width < 1000, "{name} {width}x{height}");
                    continue;
                };
                checked += 1;
                let FieldOptics::Radial {
                    psfs,
                    warp_scale,
                    shading,
                } = &simulator.optics
                else {
                    panic!("{name} is rotationally symmetric");
                };
                let [cx, cy] = simulator.grid.centre_px();
                let (mut warp_error, mut shading_error) = (0.0f64, 0.0f64);
                // Every pixel of one quadrant (the quantities depend on the radius only) plus a fine
                // radial sweep between pixel radii.
                let quadrant = (0..height / 2 + 1)
                    .flat_map(|row| {
                        (0..width / 2 + 1).map(move |column| (column as f64 - cx, row as f64 - cy))
                    })
                    .map(|(dx, dy)| dx.hypot(dy));
                let sweep = (0..20_000).map(|i| i as f64 / 20_000.0 * cx.hypot(cy));
                for radius in quadrant.chain(sweep) {
                    let exact = exact_warp_scale(&simulator.chief, &simulator.grid, radius);
                    warp_error = warp_error.max(radius * (warp_scale.at(radius) - exact).abs());
                    let exact = exact_shading(&simulator.chief, psfs, &simulator.grid, radius);
                    shading_error = shading_error.max((shading.at(radius) - exact).abs());
                }
                println!("{name} {width}x{height}: warp {warp_error:.2e} px, shading {shading_error:.2e}");
                assert!(
                    warp_error < WARP_BOUND_PX,
                    "{name} {width}x{height}: warp moved {warp_error} px"
                );
                assert!(
                    shading_error < SHADING_BOUND,
                    "{name} {width}x{height}: shading moved {shading_error}"
                );
            }
        }
        assert!(
            checked > builtin::names().count(),
            "only {checked} lens-frame pairs checked"
        );
    }
}
