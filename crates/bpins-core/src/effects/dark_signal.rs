//! # `dark_signal` — a warm sensor adds thermal electrons, and their shot noise
//!
//! ```text
//! s' = s + μ_dark            s: photo-signal above the offset (DN, after PRNU)
//! μ_dark = K·μ_I·t_exp       thermal (dark-current) electrons in the exposure, in DN
//! σ²(DN) = σ²_read + K·s'    its shot noise, as the photo-electrons' (the chain's sensor_dn)
//! ```
//!
//! Source: EMVA Standard 1288 Release 4.0, the linear camera model's dark signal:
//! thermally generated electrons μ_therm = μ_I·t_exp add to the photo-electrons and
//! are Poisson distributed like them, so a dark signal is an offset *with* shot
//! noise; the dark current μ_I doubles every ~6–8 K of sensor temperature (the
//! standard's doubling temperature). A channel offset (`channel_response`) or the
//! black level carries no shot noise: this effect is the share of the offset that
//! grows with exposure and temperature (long exposures at dusk, a sensor in the sun).
//! Frame: the sensor, every pixel and channel alike. Units: DN at the capture's
//! exposure and temperature. Applied at every pixel on both backends
//! (`shaders/effects/dark_signal.wgsl`), after PRNU (which scales the photo-response
//! only; dark current has its own fixed pattern, DSNU, which the response's `dsnu_dn`
//! carries) and before the non-linear response (`sensor_nonlinearity`, registry
//! order: it acts on the whole charge), the offsets and the noise; exactly `s` at
//! μ_dark = 0.
//!
//! | param     | unit | neutral | fit bounds | physical |
//! |-----------|------|---------|------------|----------|
//! | `dark_dn` | DN   | 0       | [0, 500]   | [0, 100] |
//!
//! A sky capture cannot separate it (`inseparable`): an offset common to the four
//! channels lowers the modulation as a lower sky DoLP does (measured: at 4 DN the
//! diagnosis of a sky capture gained nothing, and it traded against
//! `sky_depolarization`); a dark frame measures it.
//!
//! Cannot: a dark signal that differs between frames of one capture (exposure or
//! temperature changing between them), between channels or over the sensor (hot
//! pixels, amplifier glow: a fixed pattern), or the dark current's own
//! non-uniformity beyond the response's DSNU.

use super::{Apply, EffectDef, Inseparable, ParamSpec, SensorParams, SkyBlindness, Stage};

/// The range a real sky capture's dark signal has, DN. Engineering bound: a sky capture's
/// exposure is under a second even at dusk, and CMOS dark currents (tens of e⁻/s at room
/// temperature, doubling every 6–8 K: EMVA 1288) at conversion gains ≤ 1 DN/e⁻ stay
/// below 100 DN unless the sensor is far hotter than a camera in the sun gets.
const DARK_PHYSICAL_DN: (f64, f64) = (0.0, 100.0);

pub const EFFECT: EffectDef = EffectDef {
    name: "dark_signal",
    summary: "s + μ_dark: thermal electrons add a signal, with its shot noise, to every pixel",
    source: "EMVA 1288 Release 4.0 linear camera model: dark current μ_I·t_exp, Poisson like the photo-electrons",
    stage: Stage::Sensor,
    params: &[ParamSpec {
        name: "dark_dn",
        unit: "DN",
        neutral: 0.0,
        typical: 4.0,
        min: 0.0,
        max: 500.0,
        physical: Some(DARK_PHYSICAL_DN),
        doc: "thermal dark signal at the capture's exposure and temperature, DN (K·μ_I·t_exp)",
    }],
    apply: Apply::Sensor { params: |v| [v[0], 0.0, 0.0, 0.0], pixel: dark_signal },
    wgsl: Some(include_str!("../../../../shaders/effects/dark_signal.wgsl")),
    derivatives: &[],
    inseparable: Some(Inseparable {
        when: SkyBlindness::Always,
        why: |dmax_fixed| {
            format!(
                "a signal added alike to every channel lowers the modulation as a lower sky DoLP does ({}) and \
                 is otherwise taken by the sky's radiance; a dark frame (cap on) at the capture's exposure and \
                 temperature measures it, or fit it alone with the sky's d_max given \
                 (`fit --effects dark_signal --fixed-dmax D`)",
                if dmax_fixed { "sky_depolarization" } else { "each frame's d_max" }
            )
        },
    }),
};

/// The photo-signal `signal_dn` (DN above the offset) with the dark signal μ_dark =
/// `p[0]` (DN) added; exactly `signal_dn` at μ_dark = 0 (where nothing is added, so
/// not even a −0 becomes +0).
#[inline(always)]
pub fn dark_signal(p: &SensorParams, signal_dn: f64, _full_scale_dn: f64) -> f64 {
    // s + μ_dark where μ_dark ≠ 0 (a select: the row loops stay branch-free).
    if p[0] != 0.0 {
        signal_dn + p[0]
    } else {
        signal_dn
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::tests::{intrinsics, scene};
    use crate::chain::{sensor_dn, sensor_noise, ChainFrame, NoiseIndex};
    use crate::effects::EffectSet;
    use crate::sensor::Response;

    #[test]
    fn zero_dark_signal_is_exactly_the_identity() {
        for s in [0.0, -0.0, 1.0, 123.456, 4095.0, -3.0] {
            let out = dark_signal(&[0.0; 4], s, 4095.0);
            assert_eq!(out.to_bits(), f64::to_bits(s), "{s}");
        }
        assert_eq!(dark_signal(&[4.0, 0.0, 0.0, 0.0], 100.0, 4095.0), 104.0);
    }

    /// The mean and variance of `n` noisy DN of channel 0 at photo-signal `signal_dn`.
    fn moments(set: &EffectSet, resp: &Response, signal_dn: f64, n: u32) -> (f64, f64) {
        let idx = NoiseIndex { seed: 9, trial: 0, frame: 0 };
        let f = ChainFrame::new(&set.model(), &intrinsics(), &scene(), resp, idx);
        let (mut s1, mut s2) = (0.0, 0.0);
        for p in 0..n {
            let x = sensor_dn(&f, signal_dn, 0, &sensor_noise(&f, p, 0));
            s1 += x;
            s2 += x * x;
        }
        let mean = s1 / n as f64;
        (mean, s2 / n as f64 - mean * mean)
    }

    #[test]
    fn it_is_an_offset_with_the_shot_noise_a_channel_offset_lacks() {
        // K = 0.5 DN/e⁻, read noise 2 DN: a dark signal of 40 DN raises the mean by 40
        // DN and the variance by K·40 = 20 DN²; the same offset as a channel offset
        // raises the mean alike and leaves the variance.
        let resp = Response {
            read_noise_dn: 2.0,
            system_gain_dn_per_e: 0.5,
            black_level_dn: 100.0,
            bit_depth: 16,
            ..Response::ideal(1.0)
        };
        let n = 200_000;
        let (m0, v0) = moments(&EffectSet::new(), &resp, 500.0, n);
        let mut dark = EffectSet::new();
        dark.set("dark_signal", "dark_dn", 40.0).unwrap();
        let (m1, v1) = moments(&dark, &resp, 500.0, n);
        let mut offset = EffectSet::new();
        offset.set("channel_response", "offset0_dn", 40.0).unwrap();
        let (m2, v2) = moments(&offset, &resp, 500.0, n);
        // (The dark signal's mean moves by 40 DN up to its own noise's sample mean.)
        assert!((m1 - m0 - 40.0).abs() < 0.01 && (m2 - m0 - 40.0).abs() < 1e-9, "{m0} {m1} {m2}");
        // Same draws: the variances differ only by the dark signal's shot noise.
        assert!(((v1 - v0) / 20.0 - 1.0).abs() < 0.05, "variance {v0} → {v1} DN², want +20");
        assert!((v2 - v0).abs() < 1e-6 * v0, "a channel offset has no shot noise: {v0} → {v2}");
    }
}
