//! A camera, lens and exposure in physical units: the sensor response of a simulated
//! capture from the sky's luminance (`sky::radiometry`) instead of an auto-exposure,
//! so a user can ask what a given camera, lens and exposure achieve by day or night.
//!
//! ```text
//! E_img  = L·π·T/(4N²)                          image-plane illuminance, lux (on axis, object at ∞)
//! e⁻     = E_img · Φ · A_px · QE · t_exp        photo-electrons behind an analyzer's pass axis
//! g      = K · e⁻(L = unit)                     DN per unit model radiance (sensor.rs `Response::gain_dn`)
//! K      = (2^bits − 1 − b)/FW · 10^(G/20)      DN per e⁻: full well at full scale at 0 dB, analog gain G
//! σ_read = r_e·K,  μ_dark = K·I_dark·t_exp      read noise and dark signal, DN (`dark_signal` effect)
//! ```
//!
//! L the luminance in cd/m², T the lens transmittance, N the f-number, A_px the pixel
//! area (the capture's pitch²), QE the quantum efficiency for light polarized along
//! the analyzer's pass axis, Φ = 1.11·10¹⁶ photons s⁻¹ m⁻² lx⁻¹: sunlight's photons
//! between 400 and 700 nm per lux (Thimijan & Heins 1983, HortScience 18, 818: 0.0185
//! µmol m⁻² s⁻¹ per lux), taken for moonlight too (reflected sunlight, slightly
//! redder). The analyzer's ½ for unpolarized light is the chain's own (Malus,
//! CONVENTIONS.md: I_θ = ½(I + Q cos 2θ + U sin 2θ)), so QE here is *not* halved: an
//! EMVA 1288 QE measured with unpolarized light through the micro-polarizers is half
//! of it. Source of the camera equation: e.g. W. J. Smith, *Modern Optical
//! Engineering* (4th ed.), §8.4 (image illuminance, E = π·L·T/(4N²) for a distant
//! object on axis). The fall-off off axis is the `vignetting` effect's.
//!
//! The defaults ([`Exposure::imx250mzr`]) are those of the Sony IMX250MZR (5 MP
//! global-shutter polarization sensor, 3.45 µm pixels, 12 bit) as its cameras' EMVA
//! 1288 reports give them to about 10 %: saturation capacity ≈ 10.5 ke⁻, temporal dark
//! noise ≈ 2.3 e⁻; QE ≈ 0.6 at 525 nm along the pass axis (the monochrome IMX250's
//! ≈ 0.7 times the wire grid's ≈ 0.85); an f/1.4 lens transmitting 90 %. Replace them
//! with your camera's report. Units: s, cd/m², e⁻, DN, µm.
//!
//! Cannot: spectral weighting beyond one effective QE (the sensor's response against
//! the V curve); the cos⁴ fall-off (the `vignetting` effect); hot pixels, amplifier
//! glow, row noise; a dark current that differs per pixel (the response's DSNU).

use crate::capture::Capture;
use crate::error::{Error, Result};
use crate::pipeline::SimSensor;
use crate::scene::FieldScene;
use crate::sensor::Response;
use crate::sky::radiometry::{sky_light, SkyLight};
use crate::sky::sun::SunPosition;
use std::f64::consts::PI;

/// Photons s⁻¹ m⁻² per lux of sunlight, 400–700 nm (Thimijan & Heins 1983).
pub const PHOTONS_PER_LUX_S_M2: f64 = 0.0185e-6 * 6.022_140_76e23;

/// A camera, its lens and one exposure (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exposure {
    /// Exposure time, seconds.
    pub exposure_s: f64,
    /// The lens's f-number N.
    pub f_number: f64,
    /// The lens's transmittance T, in (0, 1].
    pub lens_transmittance: f64,
    /// Quantum efficiency for light along the analyzer's pass axis, in (0, 1].
    pub qe: f64,
    /// Full-well (saturation) capacity, e⁻: mapped to full scale at 0 dB.
    pub full_well_e: f64,
    /// Temporal dark (read) noise, e⁻.
    pub read_noise_e: f64,
    /// Analog gain, dB (K grows by 10^(G/20)).
    pub gain_db: f64,
    /// Dark current, e⁻ per second per pixel.
    pub dark_current_e_per_s: f64,
}

impl Exposure {
    /// The Sony IMX250MZR behind an f/`f_number` lens at `exposure_s` (module doc).
    pub fn imx250mzr(exposure_s: f64, f_number: f64) -> Exposure {
        Exposure {
            exposure_s,
            f_number,
            lens_transmittance: 0.9,
            qe: 0.6,
            full_well_e: 10_500.0,
            read_noise_e: 2.3,
            gain_db: 0.0,
            dark_current_e_per_s: 0.0,
        }
    }

    /// Refuses values outside their physical range, naming them.
    pub fn check(&self) -> Result<()> {
        let bad = |what: &str, v: f64, range: &str| {
            Err(Error::OutOfRange { what: what.into(), value: v.to_string(), range: range.into() })
        };
        let pos = |v: f64| v > 0.0 && v.is_finite();
        if !pos(self.exposure_s) {
            return bad("exposure time, s", self.exposure_s, "(0, ∞)");
        }
        if !(self.f_number >= 0.5 && self.f_number.is_finite()) {
            return bad("f-number", self.f_number, "[0.5, ∞)");
        }
        for (what, v) in [("lens transmittance", self.lens_transmittance), ("quantum efficiency", self.qe)] {
            if !(v > 0.0 && v <= 1.0) {
                return bad(what, v, "(0, 1]");
            }
        }
        if !pos(self.full_well_e) {
            return bad("full well, e⁻", self.full_well_e, "(0, ∞)");
        }
        for (what, v) in [("read noise, e⁻", self.read_noise_e), ("dark current, e⁻/s", self.dark_current_e_per_s)]
        {
            if !(v >= 0.0 && v.is_finite()) {
                return bad(what, v, "[0, ∞)");
            }
        }
        if !(self.gain_db.abs() <= 60.0) {
            return bad("analog gain, dB", self.gain_db, "[−60, 60]");
        }
        Ok(())
    }

    /// Photo-electrons per cd/m² of sky behind the analyzer's pass axis (before the
    /// chain's ½ for unpolarized light), for pixels of `pixel_pitch_um`.
    pub fn electrons_per_cd_m2(&self, pixel_pitch_um: f64) -> f64 {
        let image_lux_per_cd_m2 = PI * self.lens_transmittance / (4.0 * self.f_number * self.f_number);
        let area_m2 = (pixel_pitch_um * 1e-6).powi(2);
        image_lux_per_cd_m2 * PHOTONS_PER_LUX_S_M2 * area_m2 * self.qe * self.exposure_s
    }

    /// System gain K, DN/e⁻, for `range_dn` DN between black and full scale.
    pub fn system_gain_dn_per_e(&self, range_dn: f64) -> f64 {
        range_dn / self.full_well_e * 10f64.powf(self.gain_db / 20.0)
    }
}

/// What an [`Exposure`] makes of one frame's sky.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exposed {
    /// The sensor response: gain from the sky's luminance, noise in DN.
    pub response: Response,
    /// The sky's absolute brightness for the frame's source.
    pub sky: SkyLight,
    /// Photo-electrons of an analyzer pixel looking at the zenith (unpolarized share,
    /// ½ of the pass axis's), e⁻.
    pub zenith_e: f64,
    /// The dark signal K·I_dark·t, DN: the `dark_signal` effect's `dark_dn`.
    pub dark_dn: f64,
}

/// The response of frame `index` of capture `c` exposed by `e`: the gain from the
/// frame's source (sun or moon, [`sky_light`]) and the capture's pixel pitch, the
/// noise in DN from `e`; PRNU and DSNU from `s` (its peak fraction, read noise and
/// system gain are not used).
pub fn exposed_response(c: &Capture, index: usize, s: &SimSensor, e: &Exposure) -> Result<Exposed> {
    e.check()?;
    let f = c.frames.get(index).ok_or_else(|| Error::TooFewSamples(format!("no frame {index} to expose")))?;
    let sky = sky_light(&f.sun)?;
    let range_dn = c.sensor.full_scale_dn() - c.sensor.black_level_dn;
    let k = e.system_gain_dn_per_e(range_dn);
    let e_per_unit = e.electrons_per_cd_m2(c.sensor.geometry.pixel_pitch_um) * sky.unit_cd_m2;
    let response = Response {
        gain_dn: k * e_per_unit,
        black_level_dn: c.sensor.black_level_dn,
        read_noise_dn: e.read_noise_e * k,
        system_gain_dn_per_e: k,
        dsnu_dn: s.dsnu_dn,
        prnu: s.prnu,
        bit_depth: c.sensor.bit_depth,
        quantize: true,
    };
    let zenith_e = 0.5 * e.electrons_per_cd_m2(c.sensor.geometry.pixel_pitch_um) * sky.zenith_cd_m2;
    Ok(Exposed { response, sky, zenith_e, dark_dn: k * e.dark_current_e_per_s * e.exposure_s })
}

/// `field` under the sky of the source `sun` (its cd/m² per unit radiance, what the
/// `night_background` glow is measured against) and with the other source's sky of its
/// time and place (the `twilight` element, at the frame's `dmax`); unchanged where the
/// source has no modelled sky or no element needs it.
pub(crate) fn field_under(field: &FieldScene, sun: &SunPosition, dmax: f64) -> FieldScene {
    let needs = field.iter().any(|(d, _)| d.name == crate::scene::night_background::ELEMENT.name);
    let field = match sky_light(sun) {
        Ok(l) if needs => field.clone().with_sky_unit_cd_m2(l.unit_cd_m2),
        _ => field.clone(),
    };
    crate::scene::twilight::under(field, sun, dmax)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sunlit_zenith_fills_the_well_in_a_millisecond() {
        // 2 kcd/m² (the sun at 40°), f/4, 1 ms, 3.45 µm, QE 0.6, T 0.9:
        // E = π·0.9/64·2000 = 88.4 lx; photons = 88.4·1.114e16·1.19e-11·1e-3 = 11.7e3;
        // e⁻ = 0.6 × that ≈ 7.0e3 along the pass axis, 3.5e3 unpolarized: a third of
        // the IMX250MZR's 10.5 ke⁻ well, as a sky exposure of ~1 ms at f/4 gives.
        let e = Exposure { exposure_s: 1e-3, ..Exposure::imx250mzr(1e-3, 4.0) };
        let n = 0.5 * e.electrons_per_cd_m2(3.45) * 2000.0;
        assert!((n - 3.5e3).abs() < 0.05 * 3.5e3, "{n}");
        assert!(n < e.full_well_e);
    }

    #[test]
    fn electrons_scale_with_exposure_aperture_and_pixel_area() {
        let e = Exposure::imx250mzr(0.5, 1.4);
        let base = e.electrons_per_cd_m2(3.45);
        let longer = Exposure { exposure_s: 1.0, ..e }.electrons_per_cd_m2(3.45);
        let slower = Exposure { f_number: 2.8, ..e }.electrons_per_cd_m2(3.45);
        assert!((longer / base - 2.0).abs() < 1e-12);
        assert!((base / slower - 4.0).abs() < 1e-12, "one stop per √2 of N: N² × 4");
        assert!((e.electrons_per_cd_m2(6.9) / base - 4.0).abs() < 1e-12);
        // K: full well at full scale at 0 dB, ×2 at 6.02 dB.
        assert!((e.system_gain_dn_per_e(4031.0) - 4031.0 / 10_500.0).abs() < 1e-12);
        let g6 = Exposure { gain_db: 20.0 * 2f64.log10(), ..e }.system_gain_dn_per_e(4031.0);
        assert!((g6 / e.system_gain_dn_per_e(4031.0) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn values_out_of_range_are_named() {
        let e = Exposure::imx250mzr(1.0, 1.4);
        assert!(e.check().is_ok());
        for (bad, word) in [
            (Exposure { exposure_s: 0.0, ..e }, "exposure"),
            (Exposure { f_number: 0.1, ..e }, "f-number"),
            (Exposure { qe: 1.5, ..e }, "quantum"),
            (Exposure { read_noise_e: -1.0, ..e }, "read noise"),
        ] {
            let m = bad.check().unwrap_err().to_string();
            assert!(m.contains(word), "{m}");
        }
    }
}
