//! Which source lit each frame's sky, for the fit and the diagnosis: the rule every
//! reader applies (`sky::source_from_time_place` at load, `sky::dark_night` to refuse,
//! docs/night.md "Twilight").
//!
//! ```text
//! P = L_sun/(L_sun + L_moon), Q = 1 − P      the sources' shares at the zenith (sky/twilight.rs)
//! fitted about the sun   where P ≥ 0.99 (and the sun above −10°)
//! fitted about the moon  where Q ≥ 0.99
//! refused                otherwise: a mixed twilight, or a dark night
//! ```
//!
//! The fit's sky is one Rayleigh pattern about one point. A twilight lit by both
//! sources sums two patterns about two points; fitted as one it turns the heading and
//! biases every effect fitted with it, without the fit noticing (the same cause as the
//! compass's refusal, measured in docs/night.md). So a refused frame is an error naming
//! the frame and both shares in the words `bpins heading` prints, never a fit about the
//! brighter source. Angles given in capture.toml (or a frame without a place) are the
//! user's to vouch for: fitted about them, their source "given".
//!
//! Units: degrees, shares in [0, 1]. Frame: world ENU. Cannot: fit a mixed sky (two
//! patterns; not built).

use crate::capture::Capture;
use crate::error::{Error, Result};
use crate::sky::SkySource;

/// Which source lit a frame's sky, as `bpins heading` says it of each row (`fit.json`'s
/// and each diagnosis step's `sky`, in the frames' order).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct FrameSky {
    /// The frame's image file, as in capture.toml.
    pub file: String,
    /// "sun", "moon", or "given" for angles in capture.toml ([`SkySource::name`]).
    pub source: &'static str,
    /// The sun's and the moon's shares of the sky's light at the zenith (`null` for
    /// given angles).
    pub sun_share: Option<f64>,
    pub moon_share: Option<f64>,
    /// The source's azimuth/elevation, degrees, [± its 1σ,] and where it came from: the
    /// text of a `bpins heading --json` row's `sun`.
    pub sun: String,
}

/// Each frame's source, or the first frame the rule refuses, as an error naming its
/// file and the reason `bpins heading` gives (both shares for a mixed twilight).
pub fn frame_skies(c: &Capture) -> Result<Vec<FrameSky>> {
    c.frames
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let file = f.file.display().to_string();
            if let Some(why) = crate::sky::dark_night(&f.sun) {
                return Err(Error::Capture {
                    path: c.toml_path(),
                    message: format!(
                        "frames[{k}] {file}: {why}: not fitted (the fit reads one source's pattern, as `bpins \
                         heading` does): leave the frame out of the capture"
                    ),
                });
            }
            let source = SkySource::of(&f.sun);
            let (az, el) = (f.sun.azimuth_deg, f.sun.elevation_deg);
            let sun = match f.sun_sigma_deg {
                Some(s) => format!("{az:.4}/{el:.4} ± {s:.4}, {}", f.sun.source.describe()),
                None => format!("{az:.4}/{el:.4}, {}", f.sun.source.describe()),
            };
            Ok(FrameSky {
                file,
                source: source.name(),
                sun_share: source.shares().map(|s| s.sun_share()),
                moon_share: source.shares().map(|s| s.moon_share()),
                sun,
            })
        })
        .collect()
}
