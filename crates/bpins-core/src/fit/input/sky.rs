//! Which source lit each frame's sky, for the fit and the diagnosis: the rule every
//! reader applies (`sky::source_from_time_place` at load, `sky::refusal` to refuse the
//! dark, docs/night.md "Twilight"), and a mixed twilight's second sky.
//!
//! ```text
//! P = L_sun/(L_sun + L_moon), Q = 1 − P      the sources' shares at the zenith (sky/twilight.rs)
//! fitted about the sun   where P ≥ 0.99 (and the sun above −10°)
//! fitted about the moon  where Q ≥ 0.99
//! fitted about both      otherwise, both up: S = S_R(s_p) + k·w·S_R(s_o)
//! refused                a dark night (no source to read)
//! ```
//!
//! A twilight lit by both sources sums two Rayleigh patterns about two points; fitted
//! as one it turns the heading and biases every effect fitted with it (docs/night.md).
//! So a mixed frame's sky is the Stokes sum the `twilight` scene element renders
//! (scene/twilight.rs, its code, not a copy): the frame's source p (the brighter, as
//! `bpins heading` names it) and the other source o from the frame's time and place,
//! w = u_o/u_p the model's ratio of the two skies' radiances per unit (K&S moonlight,
//! Patat et al. 2006's twilight: the weights of `Shares::sun_unit_share`), both turned
//! by the frame's one heading, o's sky at the frame's fitted d_max. The model's w is
//! good to a factor of a few, so the fit frees a factor k on it per frame (the nuisance
//! `twilight_strength`, in [0, 4], starting at 1): per frame, not per capture, because
//! the model's error moves with the sun's depression and the moon's elevation, which
//! change over a capture, and a per-frame nuisance is the fit's existing room (a
//! global slot is an effect of the registry). Only a mixed frame gets the second sky:
//! a frame one source lights (share ≥ 99 %) is fitted about it alone, as before
//! (the other's weight is then below 1/99). A dark night is an error naming the frame
//! and both shares in the words `bpins heading` prints. Angles given in capture.toml
//! (or a frame without a place) are the user's to vouch for: fitted about them alone,
//! their source "given".
//!
//! Units: degrees, shares in [0, 1]. Frame: world ENU. Cannot: the second sky's own
//! neutral points or depolarization (the frame's d_max, Rayleigh's pattern); a mixed
//! frame with given angles (no time and place: fitted about the given source alone).

use crate::capture::Capture;
use crate::error::{Error, Result};
use crate::scene::twilight::OtherSky;
use crate::sky::twilight::Dominant;
use crate::sky::{Refusal, SkySource};

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
    /// Whether both sources light the frame's sky and neither gives 99 %: fitted with
    /// the other source's sky added ([`second_skies`]).
    pub mixed: bool,
}

/// Each frame's source, or the first frame the rule refuses, as an error naming its
/// file and the reason `bpins heading` gives (both shares for a mixed twilight).
pub fn frame_skies(c: &Capture) -> Result<Vec<FrameSky>> {
    c.frames
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let file = f.file.display().to_string();
            let source = SkySource::of(&f.sun);
            if let Some(why @ Refusal::Dark(_)) = source.shares().and_then(|sh| crate::sky::refusal(&f.sun, sh)) {
                return Err(Error::Capture {
                    path: c.toml_path(),
                    message: format!(
                        "frames[{k}] {file}: {why}: not fitted (no source's pattern to read, as `bpins heading` \
                         says): leave the frame out of the capture"
                    ),
                });
            }
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
                mixed: source.shares().is_some_and(|s| s.dominant() == Dominant::Mixed),
            })
        })
        .collect()
}

/// Each frame's second sky: the other source's ([`OtherSky`], at d_max 1 — the fit sets
/// the frame's) where the frame is a mixed twilight ([`FrameSky::mixed`]), `None`
/// otherwise.
pub(crate) fn second_skies(c: &Capture) -> Vec<Option<OtherSky>> {
    c.frames
        .iter()
        .map(|f| {
            let mixed = SkySource::of(&f.sun).shares().is_some_and(|s| s.dominant() == Dominant::Mixed);
            if mixed {
                crate::scene::twilight::other_sky_of(&f.sun, 1.0)
            } else {
                None
            }
        })
        .collect()
}
