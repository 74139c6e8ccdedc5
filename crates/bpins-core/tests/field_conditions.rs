//! The standard field conditions (`bpins_core::field_conditions`) at half resolution,
//! eight frames each: the field estimator's heading stays within its target error and
//! its 1σ covers the error (the targets: ≥ 90 % of frames within 2σ, none
//! beyond 5σ, RMS ≤ 0.3°), for both extractors, where the plain least squares is
//! confidently wrong. The README's table is the same at full resolution
//! (`cargo run --release -p bpins-core --example field_table`).

use bpins_core::internal::field_conditions::{score_field, score_plain, standard};
use bpins_core::internal::heading::field::FieldOptions;
use bpins_core::internal::heading::Extractor;

#[test]
fn the_field_estimator_is_accurate_and_honest_in_every_condition() {
    let mut plain_overconfident = 0;
    for cond in standard(8, 2, 7).unwrap() {
        let sim = cond.simulate(7).unwrap();
        for e in Extractor::ALL {
            let f = score_field(&sim, e, &FieldOptions::default()).unwrap();
            eprintln!("{} / {}: field {f:?}", cond.name, e.name());
            assert!(f.within_2sigma >= 0.85, "{} / {}: {f:?}", cond.name, e.name());
            assert!(f.max_error_over_sigma <= 5.0, "{} / {}: {f:?}", cond.name, e.name());
            assert_eq!(f.with_heading, f.frames, "{} / {}: frames without a heading: {f:?}", cond.name, e.name());
            assert!(f.rms_error_deg <= 0.3, "{} / {}: {f:?}", cond.name, e.name());
        }
        let p = score_plain(&sim, Extractor::SunVector).unwrap();
        eprintln!("{} / sun_vector: plain {p:?}", cond.name);
        if p.with_heading > 0 && p.within_2sigma < 0.5 {
            plain_overconfident += 1;
        }
    }
    // Every pixel as an independent sample: a 1σ that covers its error almost nowhere.
    assert!(plain_overconfident >= 5, "plain sun vector overconfident in only {plain_overconfident} conditions");
}

/// The cloudy conditions (`field_conditions::cloudy`: rims that turn together, broken
/// skies, an overcast with holes, a veil) at half resolution under three scene seeds,
/// six frames each: per condition and extractor, ≥ 90 % of the answered frames
/// within 2σ and none beyond 4σ (the honesty target); a frame may be refused
/// (too little clear sky, a sky that misfits), but the veil and the broken skies,
/// which keep plenty of clear sky, are answered, and the overcast's holes carry a
/// heading in at least a quarter of the frames.
#[test]
fn under_clouds_the_field_estimator_is_honest_and_holes_carry_a_heading() {
    use bpins_core::internal::field_conditions::{cloudy, score_field_all};
    let names: Vec<&str> = cloudy(1, 2, 0).unwrap().iter().map(|c| c.name).collect();
    for (k, name) in names.iter().enumerate() {
        let sims: Vec<_> =
            (40..43).map(|seed| cloudy(6, 2, seed).unwrap().swap_remove(k).simulate(seed).unwrap()).collect();
        for e in Extractor::ALL {
            let f = score_field_all(&sims, e, &FieldOptions::default()).unwrap();
            eprintln!("{name} / {}: {f:?}", e.name());
            if f.with_heading == 0 {
                // The meridian line needs the solar meridian's band in the clear sky.
                assert!(*name == "fisheye_overcast_holes" && e == Extractor::MeridianLine, "{name}: {f:?}");
                continue;
            }
            assert!(f.within_2sigma >= 0.9, "{name} / {}: {f:?}", e.name());
            assert!(f.max_error_over_sigma <= 4.0, "{name} / {}: {f:?}", e.name());
        }
        let sv = score_field_all(&sims, Extractor::SunVector, &FieldOptions::default()).unwrap();
        match *name {
            "veil" | "broken_tilted" | "fisheye_broken_tilted" => {
                assert_eq!(sv.with_heading, sv.frames, "{name}: {sv:?}");
                assert!(sv.rms_error_deg <= 0.3, "{name}: {sv:?}");
            }
            "fisheye_overcast_holes" => {
                // At half resolution the holes' cells are noisier; at full resolution 28 of
                // the README table's 40 frames are answered.
                assert!(sv.with_heading * 4 >= sv.frames, "{name}: the holes carry a heading: {sv:?}");
                assert!(sv.median_cloud_fraction > 0.8, "{name}: {sv:?}");
            }
            _ => {}
        }
        if *name == "veil" {
            assert!(sv.median_cloud_fraction < 0.05, "a veil is not cloud: {sv:?}");
        }
    }
}

/// An overcast with a few small holes (issue 46 item 2), at full resolution: where the
/// holes have clear cores (cover 0.96, edges feathered over 0.05; about 1 % of the view
/// fully clear) at least half the frames are answered, ≥ 90 % of them within 2σ and
/// none beyond 4σ (`heading/field/holes.rs`: the cores read by their own DoLP, the 1σ
/// clustered by hole); where the feathering reaches into every core (cover 0.97, edge
/// 0.1, scene seed 1: at most four 8-px cells clear), every frame is refused.
#[test]
fn an_overcast_s_small_holes_carry_an_honest_heading_where_their_cores_are_clear() {
    use bpins_core::internal::field_conditions::{score_field_all, small_holes_condition};
    let sims: Vec<_> =
        (1..=3).map(|seed| small_holes_condition(0.96, 0.05, 8, 1, seed).unwrap().simulate(seed).unwrap()).collect();
    let sv = score_field_all(&sims, Extractor::SunVector, &FieldOptions::default()).unwrap();
    eprintln!("small holes, clear cores: {sv:?}");
    assert!(sv.with_heading * 2 >= sv.frames, "{sv:?}");
    assert!(sv.within_2sigma >= 0.9 && sv.max_error_over_sigma <= 4.0, "{sv:?}");
    assert!(sv.median_cloud_fraction > 0.95, "{sv:?}");
    let feathered = small_holes_condition(0.97, 0.1, 8, 1, 1).unwrap().simulate(1).unwrap();
    let f = score_field_all(&[feathered], Extractor::SunVector, &FieldOptions::default()).unwrap();
    eprintln!("small holes, feathered cores: {f:?}");
    assert_eq!(f.with_heading, 0, "{f:?}");
}
