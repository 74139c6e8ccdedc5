//! A colour-polarization sensor through the compass (Sony IMX250MYR: each 2 × 2
//! analyzer tile under one filter of a 4 × 4 superpixel, CONVENTIONS.md): each band's
//! cells from its own pixels only (`Cells::fill_from_mosaic_band`), a field heading per
//! band, and one fused heading.
//!
//! ```text
//! d_b   = max(fit, jackknife, coherent)_b          the band's data term, degrees
//! w_b   = 1 / d_b²
//! h     = h_ref + Σ w_b·wrap(h_b − h_ref) / Σ w_b  inverse-variance mean, about the best band's heading
//! χ²    = Σ w_b·wrap(h_b − h)²,  B = max(1, χ²/(n − 1))     Birge ratio: bands that disagree widen it
//! d     = √(B / Σ w_b)                             the fused data term (in `fit_deg`)
//! s     = Σ w_b·s_b / Σ w_b  for s in misfit, cross, tilt, sun, floor    shared: fully correlated
//! ```
//!
//! The bands read the same sky through the same lens at the same instant, so what
//! their noise does not explain is shared: the reference tilt, the sun, the floor, a
//! sky-model misfit (the same clouds in every band) move every band's heading the same
//! way, so they pass into the weighted mean as the same weighted mean of their sizes
//! (a fully correlated error is never averaged down). Only the photon and cell noise
//! (the data term) is independent between bands, and only it falls by the fusion.
//!
//! A twilight lit by both the sun and the moon (`heading/field/two_sources.rs`): each
//! band's cells are read with both sources, and each band fits its own share w_b (the
//! frame's source's share of the polarized radiance per unit) beside the heading. The
//! ratio of the two skies is not the same in every band: the twilight sky after sunset
//! is bluer than the moonlit sky (ozone's Chappuis absorption of the sun's grazing
//! path; moonlight is reddened sunlight), so one w for the three bands would misread
//! two of them; each w_b starts from, and is held by a weak prior about, the same
//! model share (V band, `sky/twilight.rs`). The band headings then fuse as above, each
//! with its data term (the joint fit's, w_b's uncertainty in it), the band headings
//! carrying their own fitted share ([`FieldHeading::fitted_share`]). The fused reading
//! reports the green band's share: the band nearest the V band the model's shares are
//! given in, and the one with the most pixels (two tiles of four); `None` where the
//! green band has no heading. The red and blue shares are in [`ColourFix::bands`].
//!
//! Units: degrees. Cannot: weigh a band by what it shares with another beyond the
//! parts named above (its jackknife and sandwich are taken as independent), or fuse
//! two extractors. In a mixed twilight where the two bodies stand nearly in line the
//! prior holds each w_b, and a model share that misses the sky's moves every band the
//! same way: that part of the data terms is shared, not independent, and the fusion
//! averages it down as if it were not (docs/colour.md, docs/night.md "Twilight", for
//! what it does measured). `Compass::heading` of a warm colour compass allocates
//! nothing, mixed or not (the bands' headings on the stack, fused in place:
//! `tests/allocations.rs`), as the monochrome one does; `Compass::colour_headings`
//! returns its lists (every extractor's band and fused headings), allocated per frame.

use crate::heading::field::{FieldHeading, FieldQuality, SigmaParts};
use crate::heading::Extractor;
use crate::sensor::Band;

/// A colour frame's field headings: each band's, with each extractor, and the fused
/// heading of each extractor (the bands' inverse-variance mean; see the module).
#[derive(Clone, Debug)]
pub struct ColourFix {
    /// Each band the sensor has, in R, G, B order, with one heading per extractor.
    pub bands: Vec<(Band, Vec<FieldHeading>)>,
    /// One fused heading per extractor, in the extractors' order.
    pub fused: Vec<FieldHeading>,
}

/// The fused heading of one extractor over its bands' headings `hs` (see the module).
/// Allocates nothing where a band has a heading (the bands are walked in place).
pub(crate) fn fuse(extractor: Extractor, hs: &[&FieldHeading]) -> FieldHeading {
    let quality = fused_quality(hs);
    // Every band is read about the same source.
    let source = hs.first().map_or_else(Default::default, |h| h.source);
    // The bands with a heading, each with its weight w_b.
    let ok = || {
        hs.iter().filter_map(|h| h.result.as_ref().ok()).map(|&(h, p)| (h, p, 1.0 / data_deg(&p).max(1e-12).powi(2)))
    };
    let Some((h_ref, _, _)) = ok().min_by(|a, b| data_deg(&a.1).total_cmp(&data_deg(&b.1))) else {
        // No band has a heading: the reason of the band that kept the most sky.
        let best = hs.iter().max_by_key(|h| h.quality.cells_used).expect("a colour sensor has bands");
        return FieldHeading { extractor, result: best.result.clone(), quality, source, fitted_share: None };
    };
    let wrap = |x: f64| (x + 180.0).rem_euclid(360.0) - 180.0;
    let sw: f64 = ok().map(|(_, _, w)| w).sum();
    let offset = ok().map(|(h, _, w)| w * wrap(h - h_ref)).sum::<f64>() / sw;
    let h = (h_ref + offset).rem_euclid(360.0);
    let chi2: f64 = ok().map(|(hb, _, w)| w * wrap(hb - h).powi(2)).sum();
    let n = ok().count();
    let birge = if n > 1 { (chi2 / (n - 1) as f64).max(1.0) } else { 1.0 };
    // A fully correlated part passes into the weighted mean with the same weights.
    let shared = |f: fn(&SigmaParts) -> f64| ok().map(|(_, p, w)| w * f(&p)).sum::<f64>() / sw;
    let parts = SigmaParts {
        fit_deg: (birge / sw).sqrt(),
        jackknife_deg: 0.0,
        coherent_deg: 0.0,
        misfit_deg: shared(|p| p.misfit_deg),
        cross_deg: shared(|p| p.cross_deg),
        tilt_deg: shared(|p| p.tilt_deg),
        sun_deg: shared(|p| p.sun_deg),
        floor_deg: shared(|p| p.floor_deg),
    };
    // A share is the fused reading's where `fuse_bands` gives it (the green band's).
    FieldHeading { extractor, result: Ok((h, parts)), quality, source, fitted_share: None }
}

/// The fused heading of extractor `i` (the `i`-th heading of each band) over `bands`,
/// with the green band's fitted share where the fused reading has a heading and the
/// green band one (a mixed twilight, module doc).
pub(crate) fn fuse_bands(extractor: Extractor, bands: &[(Band, Vec<FieldHeading>)], i: usize) -> FieldHeading {
    let hs: Vec<&FieldHeading> = bands.iter().map(|(_, hs)| &hs[i]).collect();
    let mut fused = fuse(extractor, &hs);
    if fused.result.is_ok() {
        fused.fitted_share = bands.iter().find(|(b, _)| *b == Band::G).and_then(|(_, hs)| hs[i].fitted_share);
    }
    fused
}

/// A band's data term: the largest of its own noise estimates.
fn data_deg(p: &SigmaParts) -> f64 {
    p.fit_deg.max(p.jackknife_deg).max(p.coherent_deg)
}

/// What the fused heading rests on: the bands' cells together, their fractions
/// weighted by the cells each observed, the largest residual and misfit.
fn fused_quality(hs: &[&FieldHeading]) -> FieldQuality {
    let q = || hs.iter().map(|h| &h.quality);
    let sum = |f: fn(&FieldQuality) -> usize| q().map(f).sum::<usize>();
    let (total, valid, used) = (sum(|x| x.cells_total), sum(|x| x.cells_valid), sum(|x| x.cells_used));
    let cloud = q().map(|x| x.cloud_fraction * x.cells_valid as f64).sum::<f64>() / (valid.max(1) as f64);
    let max = |f: fn(&FieldQuality) -> f64| q().map(f).filter(|x| x.is_finite()).fold(f64::NAN, f64::max);
    FieldQuality {
        cells_total: total,
        cells_valid: valid,
        cells_used: used,
        used_fraction: used as f64 / total.max(1) as f64,
        residual_rms_deg: max(|x| x.residual_rms_deg),
        misfit_deg: max(|x| x.misfit_deg),
        iterations: q().map(|x| x.iterations).max().unwrap_or(0),
        cloud_fraction: cloud,
        sun_elevation_offset_deg: max(|x| x.sun_elevation_offset_deg.abs()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::heading::field::NoHeading;

    fn band(h: f64, fit: f64, tilt: f64) -> FieldHeading {
        let parts = SigmaParts { fit_deg: fit, tilt_deg: tilt, ..SigmaParts::default() };
        let quality = FieldQuality { cells_total: 100, cells_valid: 100, cells_used: 90, ..FieldQuality::default() };
        let source = Default::default();
        FieldHeading { extractor: Extractor::SunVector, result: Ok((h, parts)), quality, source, fitted_share: None }
    }

    #[test]
    fn equal_bands_halve_the_variance_of_the_noise_and_keep_what_they_share() {
        let (a, b) = (band(10.0, 0.02, 0.05), band(10.0, 0.02, 0.05));
        let f = fuse(Extractor::SunVector, &[&a, &b]);
        let (h, p) = f.result.unwrap();
        assert!((h - 10.0).abs() < 1e-12);
        assert!((p.fit_deg - 0.02 / 2f64.sqrt()).abs() < 1e-12, "{p:?}");
        assert!((p.tilt_deg - 0.05).abs() < 1e-15, "the tilt is every band's: not averaged down");
        assert_eq!(f.quality.cells_used, 180);
    }

    #[test]
    fn the_mean_weighs_by_the_noise_and_wraps_through_north() {
        let (a, b) = (band(359.9, 0.01, 0.0), band(0.3, 0.03, 0.0));
        let (h, _) = fuse(Extractor::SunVector, &[&a, &b]).result.unwrap();
        // w = 1/0.01², 1/0.03²: the mean is 359.9 + 0.4·(1/9)/(1 + 1/9) = 359.94.
        assert!((h - 359.94).abs() < 1e-9, "{h}");
    }

    #[test]
    fn a_shared_part_passes_with_the_bands_weights() {
        let (a, b) = (band(10.0, 0.01, 0.04), band(10.0, 0.02, 0.09));
        let (_, p) = fuse(Extractor::SunVector, &[&a, &b]).result.unwrap();
        // w = 10⁴, 2.5·10³: the fused heading is 0.8·a + 0.2·b, its tilt error 0.8·0.04 + 0.2·0.09.
        assert!((p.tilt_deg - 0.05).abs() < 1e-12, "{p:?}");
    }

    #[test]
    fn bands_that_disagree_beyond_their_noise_widen_the_fused_sigma() {
        let (a, b) = (band(10.0, 0.01, 0.0), band(10.1, 0.01, 0.0));
        let (_, p) = fuse(Extractor::SunVector, &[&a, &b]).result.unwrap();
        // χ² = 2·(0.05/0.01)² = 50 on 1 dof: 1σ √(50/2)·0.01 = 0.05°, the half spread.
        assert!((p.fit_deg - 0.05).abs() < 1e-9, "{p:?}");
    }

    #[test]
    fn a_band_without_a_heading_is_left_out_and_none_gives_a_reason() {
        let a = band(10.0, 0.02, 0.0);
        let mut b = band(0.0, 0.0, 0.0);
        b.result = Err(NoHeading::TooLittleSky { used: 3, total: 100 });
        let (h, p) = fuse(Extractor::SunVector, &[&a, &b]).result.unwrap();
        assert_eq!((h, p.fit_deg), (10.0, 0.02));
        let f = fuse(Extractor::SunVector, &[&b, &b]);
        assert!(matches!(f.result, Err(NoHeading::TooLittleSky { .. })));
    }
}
