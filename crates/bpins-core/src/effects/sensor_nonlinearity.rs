//! # `sensor_nonlinearity` — the pixel's DN is not quite proportional to its light
//!
//! ```text
//! s' = s · (1 − β · s / FS)          s: photo-signal, DN above the offset; FS: ADC full scale, DN
//! LE ≈ β / 8                          EMVA 1288 linearity error, fraction of full scale (0 … FS)
//! ```
//!
//! Source: EMVA 1288 release 4.0 (2021), §6.7 "Linearity": the mean signal against the
//! irradiance deviates from a straight line; LE is half the spread of the relative
//! deviations from the least-squares line. A quadratic response is the lowest-order
//! shape of that deviation (a compressive full-well, β > 0, or an expansive
//! amplifier, β < 0); its deviation from the best line over 0 … FS spans
//! FS·β·(1/6 + 1/12), so LE = β/8 of full scale (β = 0.04: LE 0.5 %, a good CMOS
//! sensor; over the standard's 5 … 95 % LE = 0.81·β/8, `linearity_error`).
//! Units: β dimensionless, s and FS in DN. Frame: per pixel, after the photo-signal's
//! gain, crosstalk and PRNU, before the offset, noise and rounding (`chain::sensor_dn`,
//! WGSL `sensor_dn`; the fit's model DN, `fit::problem`). Folded on the host into the
//! frame's `nonlinearity` (`Model`, `ChainFrame`, the GPU's `FrameParams::adc.z`).
//!
//! Polarimetric signature: the four analyzers of one spot see I(1 + d cos 2(θ_k − α))/2,
//! so the square puts a cos 4(θ_k − α) term into I0 + I90 − I45 − I135, which a linear
//! sensor keeps at 0 whatever its gains and ε: a sky capture separates it from
//! `channel_response` and `extinction_ratio`.
//!
//! | param  | unit | neutral | fit bounds  | physical |
//! |--------|------|---------|-------------|----------|
//! | `beta` | 1    | 0       | [−0.2, 0.2] | ±0.08    |
//!
//! Cannot: a cubic or S-shaped response, a non-linearity that differs per pixel or
//! per channel, or one that depends on exposure time rather than on the signal.

use super::{Apply, EffectDef, ParamSpec, SensorParams, Stage};

/// The range a real sensor's non-linearity has. EMVA 1288 datasheets of machine-vision
/// CMOS sensors report linearity errors below 1 %: |LE| = |β|/8 < 0.01.
const BETA_PHYSICAL: (f64, f64) = (-0.08, 0.08);

pub const EFFECT: EffectDef = EffectDef {
    name: "sensor_nonlinearity",
    summary: "DN = s (1 - beta s/FS): a quadratic response, EMVA 1288 linearity error LE = beta/8",
    source: "EMVA 1288 release 4.0 §6.7 (linearity error), lowest-order (quadratic) response",
    stage: Stage::Sensor,
    params: &[ParamSpec {
        name: "beta",
        unit: "1",
        neutral: 0.0,
        typical: 0.04,
        min: -0.2,
        max: 0.2,
        physical: Some(BETA_PHYSICAL),
        doc: "quadratic coefficient: relative signal lost at full scale (LE = beta/8)",
    }],
    apply: Apply::Sensor { params: |v| [v[0], 0.0, 0.0, 0.0], pixel: sensor_nonlinearity },
    wgsl: Some(include_str!("../../../../shaders/effects/sensor_nonlinearity.wgsl")),
    derivatives: &[],
    inseparable: None,
};

/// The sensor's response to the photo-signal `signal_dn` (DN above the offset) at a
/// quadratic coefficient β = `p[0]` and ADC full scale `full_scale_dn`; exactly
/// `signal_dn` at β = 0.
#[inline(always)]
pub fn sensor_nonlinearity(p: &SensorParams, signal_dn: f64, full_scale_dn: f64) -> f64 {
    quadratic_response(p[0], signal_dn, full_scale_dn)
}

/// s·(1 − β·s/FS), DN: [`sensor_nonlinearity`] at β = `beta`.
#[inline(always)]
pub fn quadratic_response(beta: f64, signal_dn: f64, full_scale_dn: f64) -> f64 {
    // s·(1 − β·s/FS): 1 − 0·x = 1 exactly, so β = 0 is the identity.
    signal_dn * (1.0 - beta * (signal_dn / full_scale_dn))
}

/// The EMVA 1288 linearity error (fraction of full scale) of the response at `beta`,
/// measured as the standard does: half the spread of the deviations from the
/// least-squares line through `n` equally spaced signals from 5 % to 95 % of full scale.
/// (What ties β to a datasheet's LE; the test below pins β/8.)
#[cfg(test)]
fn linearity_error(beta: f64, n: usize) -> f64 {
    let fs = 1.0;
    let xs: Vec<f64> = (0..n).map(|i| 0.05 + 0.9 * i as f64 / (n - 1) as f64).collect();
    let ys: Vec<f64> = xs.iter().map(|&x| quadratic_response(beta, x, fs)).collect();
    let (mx, my) = (xs.iter().sum::<f64>() / n as f64, ys.iter().sum::<f64>() / n as f64);
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    let (a, b) = (sxy / sxx, my - sxy / sxx * mx);
    let dev = xs.iter().zip(&ys).map(|(&x, &y)| y - (a * x + b));
    let (lo, hi) = dev.fold((f64::MAX, f64::MIN), |(l, h), d| (l.min(d), h.max(d)));
    0.5 * (hi - lo) / fs
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::tests::{intrinsics, scene};
    use crate::chain::{sensor_dn, sensor_noise, ChainFrame, NoiseIndex};
    use crate::effects::EffectSet;
    use crate::sensor::Response;

    #[test]
    fn zero_strength_is_the_identity_and_full_scale_loses_beta() {
        for s in [0.0, 1.0, 123.456, 4095.0, -3.0] {
            assert_eq!(sensor_nonlinearity(&[0.0; 4], s, 4095.0), s);
        }
        // At full scale the response has lost β of its signal; at half scale β/2.
        assert!((quadratic_response(0.04, 4095.0, 4095.0) - 4095.0 * 0.96).abs() < 1e-9);
        assert!((quadratic_response(0.04, 2047.5, 4095.0) - 2047.5 * 0.98).abs() < 1e-9);
    }

    #[test]
    fn emva_linearity_error_is_beta_over_eight() {
        // Over 5 … 95 % (0.9 of the range) the square's deviation from its best line
        // spans 0.9²·β/4, so LE = 0.81·β/8; and LE is linear in β.
        let le = linearity_error(0.04, 91);
        assert!((le / (0.04 / 8.0) - 0.81).abs() < 0.02, "LE {le}");
        assert!((linearity_error(0.08, 91) / le - 2.0).abs() < 1e-9);
        assert_eq!(linearity_error(0.0, 91), 0.0);
    }

    #[test]
    fn the_chain_compresses_bright_pixels_and_keeps_the_offset() {
        let mut set = EffectSet::new();
        set.set("sensor_nonlinearity", "beta", 0.1).unwrap();
        let resp = Response { black_level_dn: 64.0, bit_depth: 12, ..Response::ideal(1000.0) };
        let idx = NoiseIndex { seed: 1, trial: 0, frame: 0 };
        let f = ChainFrame::new(&set.model(), &intrinsics(), &scene(), &resp, idx);
        let n = sensor_noise(&f, 5, 0);
        // Dark stays at the black level; the compression grows with the square of the signal.
        assert_eq!(sensor_dn(&f, 0.0, 0, &n), 64.0);
        let loss = |s: f64| s + 64.0 - sensor_dn(&f, s, 0, &n);
        assert!((loss(2000.0) / loss(1000.0) - 4.0).abs() < 1e-9);
        assert!((loss(4095.0) - 409.5).abs() < 1e-9);
    }
}
