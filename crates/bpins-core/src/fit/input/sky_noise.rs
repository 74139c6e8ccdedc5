//! A capture's photon-transfer noise sums frame by frame ([`NoiseSums`]), as the fit
//! reads the frames: a colour mosaic band by band, and on the sky alone.
//!
//! ```text
//! d = DN(u) − ½[DN(u − 4) + DN(u + 4)]     colour mosaic: same band and channel, 4 px apart
//! kept where DN(u − 4), DN(u), DN(u + 4) all lie in sky cells of the frame's mask
//! E[d²] = 1.5·σ²(s), σ²(s) = σ_r² + K·s + (p·s)²  (EMVA 1288 §4, §8; `noise`)
//! ```
//!
//! A colour sensor's same-band, same-channel neighbours along a row are 4 px apart, so
//! its second difference spans 8 px. A smooth sky's curvature over 8 px is far below the
//! noise, a cloud's texture is not: on a 204 × 172 capture of a sky with six textured
//! clouds (read noise 1 DN, K = 0.1 DN/e⁻, no PRNU) every pixel's sums read 9.6 DN, K = 0
//! and 1.7 % PRNU, 3.8 × the noise variance at the sky's level (χ²/dof 0.25); on the sky
//! 1.6 DN, K = 0.088 DN/e⁻ and 0.44 % PRNU, 1.09 × (χ²/dof 1.00, docs/colour.md). So a
//! colour frame's sums are kept only where the three pixels lie in sky cells of the
//! frame's sky mask ([`crate::fit::input::masks`], the field estimator's: clouds, trees,
//! buildings and the ground left out), falling back to every pixel where the sky holds
//! fewer than [`MIN_SKY_SAMPLES`] second differences over the capture (or no frame has a
//! mask). A monochrome frame's sums read every pixel, as before colour (its 4 px span
//! sees little of a cloud's texture, and every day capture's model stays bit for bit).
//!
//! Units: DN. Frame: image coordinates (u right, v down). Cannot: tell a texture inside
//! the sky cells (a thin cloud the mask calls sky) from noise.

use crate::capture::{Capture, FrameData};
use crate::fit::input::noise::{NoiseModel, NoiseSums};
use crate::heading::field::SkyMask;

/// Fewest second differences on the sky for the sky's sums to be used (module doc).
pub const MIN_SKY_SAMPLES: f64 = 10_000.0;

/// The sums of a capture's frames: every usable pixel's, and the sky's alone.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct FrameNoise {
    all: NoiseSums,
    /// Colour frames with a mask: their sky's; other frames: the same as `all`.
    sky: NoiseSums,
}

impl FrameNoise {
    /// Adds the sums of other frames.
    pub(crate) fn merge(&mut self, o: &FrameNoise) {
        self.all.merge(&o.all);
        self.sky.merge(&o.sky);
    }

    /// The noise model: the sky's sums where they hold at least [`MIN_SKY_SAMPLES`],
    /// else every pixel's; `None` when too few samples.
    pub(crate) fn model(&self, full_scale_dn: f64) -> Option<NoiseModel> {
        let sums = if self.sky.samples() >= MIN_SKY_SAMPLES { &self.sky } else { &self.all };
        sums.model(full_scale_dn)
    }
}

/// The sensor noise of `frames` of `c` (photon transfer, [`noise_sums`]), each colour
/// frame on its sky mask in `masks` where given; `None` when too few samples. A
/// monochrome capture's: `noise::estimate`, as before colour.
pub(crate) fn noise_of(c: &Capture, frames: &[FrameData], masks: Option<&[Option<SkyMask>]>) -> Option<NoiseModel> {
    let (black, full) = (c.sensor.black_level_dn, c.sensor.full_scale_dn());
    if c.sensor.colour.is_none() {
        return crate::fit::input::noise::estimate(frames, black, full);
    }
    let mut sums = FrameNoise::default();
    for (k, d) in frames.iter().enumerate() {
        let mask = masks.and_then(|m| m.get(k)).and_then(Option::as_ref);
        sums.merge(&noise_sums(c, d, mask));
    }
    sums.model(full)
}

/// The photon-transfer sums of one frame of `c` ([`NoiseSums::add`]: each pixel against
/// the same channel's pixels 2 px to either side along its row). On a colour sensor
/// those are under another filter, so the frame's columns are first taken apart by the
/// tile column they lie in (`u div 2 mod 2`): along a row of each part the pixels 2 px
/// apart (4 px on the sensor) are the same band and channel, and the second difference
/// spans 8 px of a smooth sky instead of 4; the sky's sums keep only the pixels `mask`
/// calls sky (module doc).
pub(crate) fn noise_sums(c: &Capture, data: &FrameData, mask: Option<&SkyMask>) -> FrameNoise {
    let (black, full) = (c.sensor.black_level_dn, c.sensor.full_scale_dn());
    let mut all = NoiseSums::default();
    match (data, &c.sensor.colour) {
        (FrameData::Mosaic { width_px, height_px, dn }, Some(_)) => {
            let (w, h) = (*width_px as usize, *height_px as usize);
            for part in band_columns(dn, w, h, None) {
                all.add(&part, black, full);
            }
            let Some(mask) = mask else { return FrameNoise { all, sky: all } };
            let mut sky = NoiseSums::default();
            for part in band_columns(dn, w, h, Some(mask)) {
                sky.add(&part, black, full);
            }
            FrameNoise { all, sky }
        }
        _ => {
            all.add(data, black, full);
            FrameNoise { all, sky: all }
        }
    }
}

/// The columns of a `w × h` mosaic whose tile column (`u div 2`) is even, then those
/// whose tile column is odd, each as a mosaic of its own (rows kept); a pixel outside
/// `mask`'s sky is NaN (which [`NoiseSums::add`] skips, with the differences it is in).
pub(crate) fn band_columns(dn: &[f32], w: usize, h: usize, mask: Option<&SkyMask>) -> [FrameData; 2] {
    [0, 1].map(|class| {
        let cols: Vec<usize> = (0..w).filter(|u| (u / 2) % 2 == class).collect();
        let part = (0..h)
            .flat_map(|v| {
                cols.iter().map(move |&u| match mask {
                    Some(m) if !m.is_sky(u, v) => f32::NAN,
                    _ => dn[v * w + u],
                })
            })
            .collect();
        FrameData::Mosaic { width_px: cols.len() as u32, height_px: h as u32, dn: part }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::{stream, FrameKey};

    /// An RGGB mosaic `w × h`: the bands at 0.5, 1 and 0.8 of a smooth ramp, read noise
    /// 2 DN, K = 0.2 DN/e⁻, black 100 DN; `texture(u, v)` DN added (a cloud's).
    fn mosaic(w: usize, h: usize, texture: impl Fn(usize, usize) -> f64) -> Vec<f32> {
        let key = FrameKey::new(3, 0, 0);
        let band = [[0.5, 1.0], [1.0, 0.8]];
        (0..w * h)
            .map(|p| {
                let (u, v) = (p % w, p / w);
                let s = (200.0 + 2.0 * u as f64) * band[(v / 2) % 2][(u / 2) % 2] + texture(u, v);
                (100.0 + s + (4.0 + 0.2 * s).sqrt() * key.normal(p as u32, 0, stream::TEMPORAL)) as f32
            })
            .collect()
    }

    fn sums(dn: &[f32], w: usize, h: usize, mask: Option<&SkyMask>) -> NoiseSums {
        let mut sums = NoiseSums::default();
        for part in band_columns(dn, w, h, mask) {
            sums.add(&part, 100.0, 4095.0);
        }
        sums
    }

    #[test]
    fn a_colour_mosaics_noise_is_read_within_each_band() {
        let (w, h) = (400, 200);
        let dn = mosaic(w, h, |_, _| 0.0);
        let m = sums(&dn, w, h, None).model(4095.0).unwrap();
        assert!((m.k_dn_per_e - 0.2).abs() < 0.03 && m.prnu < 0.003, "{m:?}");
        // Read as a monochrome mosaic, the steps between the bands are taken for noise.
        let mut mono = NoiseSums::default();
        mono.add(&FrameData::Mosaic { width_px: w as u32, height_px: h as u32, dn }, 100.0, 4095.0);
        let mono = mono.model(4095.0).unwrap();
        assert!(mono.variance_dn2(400.0) > 10.0 * m.variance_dn2(400.0), "{mono:?} against {m:?}");
    }

    #[test]
    fn a_clouds_texture_outside_the_sky_mask_is_not_read_as_noise() {
        // The right half of the frame a cloud: ±60 DN of texture that changes every few
        // pixels, which the mask (cells of 20 px) leaves out.
        let (w, h, cell) = (400, 200, 20);
        let texture = |u: usize, v: usize| {
            if u >= w / 2 {
                60.0 * ((u as f64 * 0.9).sin() * (v as f64 * 0.7).cos())
            } else {
                0.0
            }
        };
        let dn = mosaic(w, h, texture);
        let (cols, rows) = (w / cell, h / cell);
        let sky = (0..rows * cols).map(|i| i % cols < cols / 2).collect();
        let mask = SkyMask { cell_px: cell, cols, rows, sky, heading_deg: 0.0 };
        let truth = 4.0 + 0.2 * 400.0;
        let every = sums(&dn, w, h, None).model(4095.0).unwrap();
        assert!(every.variance_dn2(400.0) > 3.0 * truth, "the texture read as noise: {every:?}");
        let on_sky = sums(&dn, w, h, Some(&mask));
        assert!(on_sky.samples() >= MIN_SKY_SAMPLES, "{}", on_sky.samples());
        let m = on_sky.model(4095.0).unwrap();
        assert!((m.variance_dn2(400.0) / truth - 1.0).abs() < 0.1, "{m:?}: truth {truth} DN² at 400 DN");
        assert!((m.read_dn - 2.0).abs() < 1.0 && m.prnu < 0.005, "{m:?}");
    }
}
