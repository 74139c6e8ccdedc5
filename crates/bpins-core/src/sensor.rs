//! The sensor: pixel layout (colocated or division-of-focal-plane mosaic), the
//! analyzer channels, and the EMVA 1288 linear response with noise.
//!
//! Response (CONVENTIONS.md "Sensor response", seed eq. 11), per pixel and channel k:
//!
//! ```text
//! signal_dn = g · (1 + gain_k) · (1 + prnu·n₁) · I_θ          photo-signal, DN
//! signal_dn ← signal_dn · (1 − β·signal_dn/FS)                 non-linearity (β: `sensor_nonlinearity`)
//! DN        = signal_dn + b + offset_k + dsnu·n₂ + n           n ~ N(0, σ_read² + K·signal_dn)
//! DN        = clamp(floor(DN + ½), 0, 2^bits − 1)              when rounding is on
//! ```
//!
//! `g` is DN per unit sky radiance (the sky model's radiance is 1 at the sun), `b` the
//! black level, `K` the system gain in DN/e⁻ (shot-noise variance K·signal), n₁, n₂
//! fixed-pattern standard normals keyed by pixel (constant over frames), n temporal.
//! `gain_k`, `offset_k` are the `channel_response` effect's parameters.
//! Cannot: model dark current over exposure time, or row noise.

use serde::{Deserialize, Serialize};

/// An analyzer channel by nominal angle: 0°, 45°, 90°, 135°.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Channel {
    C0 = 0,
    C45 = 1,
    C90 = 2,
    C135 = 3,
}

impl Channel {
    pub const ALL: [Channel; 4] = [Channel::C0, Channel::C45, Channel::C90, Channel::C135];

    /// Index 0..3, the position of this channel in per-channel parameter arrays.
    #[inline]
    pub fn index(self) -> usize {
        self as usize
    }

    /// Nominal analyzer angle in degrees (image angle, CONVENTIONS.md).
    pub fn angle_deg(self) -> f64 {
        45.0 * self as usize as f64
    }

    pub fn from_index(i: usize) -> Option<Channel> {
        Channel::ALL.get(i).copied()
    }

    /// The channel whose nominal angle is `deg` (0, 45, 90 or 135 exactly).
    pub fn from_angle_deg(deg: f64) -> Option<Channel> {
        Channel::ALL.into_iter().find(|c| c.angle_deg() == deg)
    }

    /// EXR channel name in a colocated capture: `I0`, `I45`, `I90`, `I135`.
    pub fn exr_name(self) -> &'static str {
        ["I0", "I45", "I90", "I135"][self.index()]
    }
}

/// Default mosaic of the Sony IMX250MZR: row 0 = [90, 45], row 1 = [135, 0].
pub const DEFAULT_MOSAIC: [[Channel; 2]; 2] = [[Channel::C90, Channel::C45], [Channel::C135, Channel::C0]];

/// A colour filter's band over an analyzer tile of a colour-polarization sensor
/// (CONVENTIONS.md: `colour_tiles`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum Band {
    R,
    G,
    B,
}

impl Band {
    pub const ALL: [Band; 3] = [Band::R, Band::G, Band::B];

    /// `R`, `G` or `B`, as `colour_tiles` names it.
    pub fn name(self) -> &'static str {
        ["R", "G", "B"][self.index()]
    }

    /// 0, 1, 2 for R, G, B.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The band named `R`, `G` or `B`.
    pub fn from_name(name: &str) -> Option<Band> {
        Band::ALL.into_iter().find(|b| b.name() == name)
    }

    /// CAPTURE.md's default centre wavelength of the band's filter, nm.
    pub fn default_centre_nm(self) -> f64 {
        [615.0, 530.0, 465.0][self.index()]
    }
}

/// The colour filters of a colour-polarization DoFP sensor (Sony IMX250MYR: `[[R, G],
/// [G, B]]`): pixel (u, v) lies under `tiles[(v / 2) % 2][(u / 2) % 2]`, each filter
/// over one whole 2 × 2 analyzer tile, a 4 × 4 superpixel (CONVENTIONS.md).
#[derive(Clone, Debug, PartialEq)]
pub struct ColourTiles {
    /// The band over each analyzer tile, by tile row and column of the superpixel.
    pub tiles: [[Band; 2]; 2],
    /// Each band's filter centre wavelength, nm, by [`Band::index`].
    pub centre_nm: [f64; 3],
}

impl ColourTiles {
    /// The IMX250MYR's order, `[[R, G], [G, B]]`, with CAPTURE.md's default wavelengths.
    pub fn imx250myr() -> ColourTiles {
        ColourTiles {
            tiles: [[Band::R, Band::G], [Band::G, Band::B]],
            centre_nm: Band::ALL.map(Band::default_centre_nm),
        }
    }

    /// The band over pixel `(u, v)`.
    #[inline]
    pub fn band_at(&self, u: usize, v: usize) -> Band {
        self.tiles[(v >> 1) & 1][(u >> 1) & 1]
    }

    /// The bands the superpixel holds, in R, G, B order.
    pub fn bands(&self) -> Vec<Band> {
        Band::ALL.into_iter().filter(|&b| self.has(b)).collect()
    }

    /// Whether band `b` lies over any tile of the superpixel (allocates nothing).
    pub fn has(&self, b: Band) -> bool {
        self.tiles.iter().flatten().any(|&t| t == b)
    }

    /// Which tiles of the superpixel band `b` covers, by tile row and column.
    pub fn classes(&self, b: Band) -> [[bool; 2]; 2] {
        self.tiles.map(|row| row.map(|t| t == b))
    }
}

/// How analyzer channels are laid out on the pixels.
#[derive(Clone, Debug, PartialEq)]
pub enum Layout {
    /// Every pixel measures every listed channel at the same point (seed paper's
    /// idealisation); 3 channels (0, 45, 90) or all 4.
    Colocated { channels: Vec<Channel> },
    /// One analyzer per pixel, in 2 × 2 tiles: `mosaic[row % 2][col % 2]`.
    Dofp { mosaic: [[Channel; 2]; 2] },
}

impl Layout {
    /// The channel a DoFP pixel `(u, v)` samples.
    #[inline]
    pub fn dofp_channel(mosaic: &[[Channel; 2]; 2], u: usize, v: usize) -> Channel {
        mosaic[v & 1][u & 1]
    }
}

/// Sensor geometry in pixels and micrometres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry {
    pub width_px: u32,
    pub height_px: u32,
    pub pixel_pitch_um: f64,
}

/// EMVA 1288 linear response parameters (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Response {
    /// DN per unit sky radiance reaching an ideal pixel.
    pub gain_dn: f64,
    /// Black level b, DN.
    pub black_level_dn: f64,
    /// Read noise σ_read, DN.
    pub read_noise_dn: f64,
    /// System gain K, DN per electron (shot-noise variance = K · signal_dn).
    pub system_gain_dn_per_e: f64,
    /// Per-pixel offset non-uniformity (DSNU) σ, DN: the seed's "grayscale
    /// response inconsistency".
    pub dsnu_dn: f64,
    /// Per-pixel gain non-uniformity (PRNU) σ, relative.
    pub prnu: f64,
    /// Bits per sample; DN are clipped to [0, 2^bits − 1] when `quantize` is on.
    pub bit_depth: u32,
    /// Round to integer DN and clip (a real sensor); off for the seed's continuous sweep.
    pub quantize: bool,
}

impl Response {
    /// A noise-free, unquantised response with gain `gain_dn` and no black level.
    pub fn ideal(gain_dn: f64) -> Self {
        Response {
            gain_dn,
            black_level_dn: 0.0,
            read_noise_dn: 0.0,
            system_gain_dn_per_e: 0.0,
            dsnu_dn: 0.0,
            prnu: 0.0,
            bit_depth: 16,
            quantize: false,
        }
    }

    /// The sample captures' sensor (samples/README.md) at gain `gain_dn`:
    /// 12-bit with rounding and clipping, black level 64 DN, read noise 1 DN, shot
    /// noise at K = 0.1 DN/e⁻, no fixed-pattern noise.
    pub fn samples(gain_dn: f64) -> Self {
        Response {
            black_level_dn: 64.0,
            read_noise_dn: 1.0,
            system_gain_dn_per_e: 0.1,
            bit_depth: 12,
            quantize: true,
            ..Response::ideal(gain_dn)
        }
    }

    /// Largest DN the sensor can output.
    pub fn full_scale_dn(&self) -> f64 {
        ((1u64 << self.bit_depth) - 1) as f64
    }
}

/// Whether a measured DN is usable: neither clipped at zero nor saturated.
#[inline]
pub(crate) fn dn_is_valid(dn: f64, full_scale_dn: f64) -> bool {
    dn > 0.0 && dn < full_scale_dn
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_round_trip_angles() {
        for c in Channel::ALL {
            assert_eq!(Channel::from_angle_deg(c.angle_deg()), Some(c));
            assert_eq!(Channel::from_index(c.index()), Some(c));
        }
        assert_eq!(Channel::from_angle_deg(30.0), None);
    }

    #[test]
    fn default_mosaic_matches_the_imx250mzr() {
        assert_eq!(Layout::dofp_channel(&DEFAULT_MOSAIC, 0, 0), Channel::C90);
        assert_eq!(Layout::dofp_channel(&DEFAULT_MOSAIC, 1, 0), Channel::C45);
        assert_eq!(Layout::dofp_channel(&DEFAULT_MOSAIC, 0, 1), Channel::C135);
        assert_eq!(Layout::dofp_channel(&DEFAULT_MOSAIC, 3, 5), Channel::C0);
    }
}
