//! The standard field conditions (`bpins_core::field_conditions`) at half resolution,
//! eight frames each: the field estimator's heading stays within its target error and
//! its 1σ covers the error (the targets: ≥ 90 % of frames within 2σ, none
//! beyond 5σ, RMS ≤ 0.3°), for both extractors, where the plain least squares is
//! confidently wrong. The README's table is the same at full resolution
//! (`cargo run --release -p bpins-core --example field_table`).

use bpins_core::field_conditions::{score_field, score_plain, standard};
use bpins_core::heading::field::FieldOptions;
use bpins_core::heading::Extractor;

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
