//! `Planar`: the one image type of the pipeline. Channels are stored one after another (planar), rows
//! top to bottom, each row left to right; values are f32 (linear light unless a function says otherwise).
//! Planar storage makes per-channel work (convolution, Bayer sampling, metrics) contiguous.

/// A planar f32 image with `channels` planes of `width` x `height` samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Planar {
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    /// `channels * height * width` samples; sample (c, y, x) is at `(c * height + y) * width + x`.
    pub data: Vec<f32>,
}

impl Planar {
    /// A zero image.
    pub fn new(width: usize, height: usize, channels: usize) -> Planar {
        Planar {
            width,
            height,
            channels,
            data: vec![0.0; width * height * channels],
        }
    }

    /// An image from per-pixel values given by `f(channel, x, y)`.
    pub fn from_fn(
        width: usize,
        height: usize,
        channels: usize,
        f: impl Fn(usize, usize, usize) -> f32,
    ) -> Planar {
        let mut image = Planar::new(width, height, channels);
        for c in 0..channels {
            for y in 0..height {
                for x in 0..width {
                    image.data[(c * height + y) * width + x] = f(c, x, y);
                }
            }
        }
        image
    }

    /// [`Self::from_fn`] with the rows made in parallel (`f` must be `Sync`): the same samples.
    pub fn from_fn_parallel(
        width: usize,
        height: usize,
        channels: usize,
        f: impl Fn(usize, usize, usize) -> f32 + Sync,
    ) -> Planar {
        use rayon::prelude::*;
        let mut image = Planar::new(width, height, channels);
        if width > 0 {
            // Row r of the data is row r % height of channel r / height.
            image.data.par_chunks_mut(width).enumerate().for_each(|(r, row)| {
                let (c, y) = (r / height, r % height);
                for (x, out) in row.iter_mut().enumerate() {
                    *out = f(c, x, y);
                }
            });
        }
        image
    }

    /// The first NaN or infinite sample as (channel, x, y, value), for errors that name the position.
    pub fn first_non_finite(&self) -> Option<(usize, usize, usize, f32)> {
        let index = self.data.iter().position(|v| !v.is_finite())?;
        let n = self.pixels();
        let (channel, within) = (index / n, index % n);
        Some((
            channel,
            within % self.width,
            within / self.width,
            self.data[index],
        ))
    }

    pub fn pixels(&self) -> usize {
        self.width * self.height
    }

    pub fn plane(&self, channel: usize) -> &[f32] {
        let n = self.pixels();
        &self.data[channel * n..(channel + 1) * n]
    }

    pub fn plane_mut(&mut self, channel: usize) -> &mut [f32] {
        let n = self.pixels();
        &mut self.data[channel * n..(channel + 1) * n]
    }

    #[inline]
    pub fn get(&self, channel: usize, x: usize, y: usize) -> f32 {
        self.data[(channel * self.height + y) * self.width + x]
    }

    #[inline]
    pub fn set(&mut self, channel: usize, x: usize, y: usize, value: f32) {
        self.data[(channel * self.height + y) * self.width + x] = value;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parallel_from_fn_makes_the_same_samples() {
        let f = |c: usize, x: usize, y: usize| (c * 1000 + y * 37 + x) as f32 * 0.5;
        for (width, height, channels) in [(7, 5, 3), (1, 1, 1), (0, 4, 2), (4, 0, 3)] {
            assert_eq!(
                Planar::from_fn_parallel(width, height, channels, f),
                Planar::from_fn(width, height, channels, f)
            );
        }
    }

    #[test]
    fn planar_layout_indexes_channel_row_column() {
        let image = Planar::from_fn(3, 2, 2, |c, x, y| (c * 100 + y * 10 + x) as f32);
        assert_eq!(image.get(1, 2, 1), 112.0);
        assert_eq!(image.plane(1)[0], 100.0);
        assert_eq!(image.data.len(), 12);
    }
}
