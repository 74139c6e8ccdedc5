//! Registry-wide checks that hold for both kinds of catalog entry, run once per
//! registry through the one [`Entry`] type.

use super::*;
use crate::effects::EffectDef;
use crate::scene::ElementDef;

/// Names are unique snake case; each parameter's name carries its unit (a sky
/// brightness's: `mag_arcsec2`) and its
/// neutral and typical values lie in its range (a count's are whole numbers).
fn check_registry<E: Entry>() {
    let mut names: Vec<_> = E::registry().iter().map(|e| e.name()).collect();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), E::registry().len(), "{}: duplicate name", E::KIND.plural());
    for e in E::registry() {
        let n = e.name();
        assert!(n.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_'), "{n}");
        assert!(!e.summary().is_empty() && !e.source().is_empty() && !e.params().is_empty(), "{n}");
        let mut pnames: Vec<_> = e.params().iter().map(|p| p.name).collect();
        pnames.sort();
        pnames.dedup();
        assert_eq!(pnames.len(), e.params().len(), "{n}: duplicate parameter");
        for p in e.params() {
            assert!(
                ["px", "deg", "DN", "1", "count", "mag/arcsec²"].contains(&p.unit),
                "{n}.{}: unit {}",
                p.name,
                p.unit
            );
            for (unit, suffix) in [("px", "_px"), ("deg", "_deg"), ("DN", "_dn"), ("mag/arcsec²", "mag_arcsec2")] {
                assert_eq!(p.unit == unit, p.name.ends_with(suffix), "{n}.{}: unit suffix", p.name);
            }
            assert!(p.min <= p.neutral && p.neutral <= p.max, "{n}.{}: neutral out of range", p.name);
            assert!(p.min <= p.typical && p.typical <= p.max, "{n}.{}: typical out of range", p.name);
            assert!(!p.is_count() || (p.neutral.fract() == 0.0 && p.typical.fract() == 0.0), "{n}.{}", p.name);
            assert!(!p.doc.is_empty(), "{n}.{}: no doc", p.name);
            let (lo, hi) = p.physical_range();
            assert!(p.min <= lo && lo <= hi && hi <= p.max, "{n}.{}: physical range outside the bounds", p.name);
        }
    }
}

#[test]
fn both_registries_hold_the_same_rules() {
    check_registry::<EffectDef>();
    check_registry::<ElementDef>();
}

/// Every parameter of either kind is refused the same way: unknown names listed,
/// out-of-range values with their range and unit, the kind named in the message.
fn check_refusals<E: Entry>() {
    let first = E::registry()[0];
    let p = &first.params()[0];
    let mut sel = Selection::<E>::new();

    let e = sel.parse(&format!("no_such.{}=1", p.name)).unwrap_err();
    assert!(matches!(e, Error::UnknownEntry { kind, .. } if kind == E::KIND.noun()), "{e}");
    let msg = e.to_string();
    assert!(msg.contains("no_such") && E::registry().iter().all(|x| msg.contains(x.name())), "{msg}");

    let e = sel.parse(&format!("{}.no_such=1", first.name())).unwrap_err();
    assert!(matches!(e, Error::UnknownParam { .. }), "{e}");
    assert!(e.to_string().contains(p.name) && e.to_string().contains(E::KIND.noun()), "{e}");

    let e = sel.parse(&format!("{}.{}={}", first.name(), p.name, p.max + 1.0 + p.max.abs())).unwrap_err();
    assert!(matches!(e, Error::BadParam { .. }), "{e}");
    assert!(e.to_string().contains(&format!("[{}, {}]", p.min, p.max)), "{e}");
    for bad in ["abc", "nan", "inf"] {
        assert!(sel.parse(&format!("{}.{}={bad}", first.name(), p.name)).is_err(), "{bad}");
    }
    assert!(sel.is_empty(), "a refused value enables nothing");

    // A good value enables the entry, the others at the kind's starting values.
    sel.parse(&format!(" {} . {} = {} ", first.name(), p.name, p.typical)).unwrap();
    assert_eq!(sel.get(first.name(), p.name), Some(p.typical));
    for q in &first.params()[1..] {
        let start = if E::KIND == Kind::Effect { q.neutral } else { q.typical };
        assert_eq!(sel.get(first.name(), q.name), Some(start), "{}", q.name);
    }
    assert_eq!(sel.without(|e| e.name() == first.name()), Selection::new());
}

#[test]
fn both_registries_refuse_alike() {
    check_refusals::<EffectDef>();
    check_refusals::<ElementDef>();
}

#[test]
fn only_an_element_is_enabled_by_name_alone() {
    let mut effects = Selection::<EffectDef>::new();
    assert!(effects.parse(crate::effects::REGISTRY[0].name).unwrap_err().to_string().contains("effect.param=value"));
    let mut elements = Selection::<ElementDef>::new();
    elements.parse("clouds").unwrap();
    assert_eq!(elements.iter().count(), 1);
}

#[test]
fn a_count_takes_whole_numbers_only() {
    let mut s = Selection::<ElementDef>::new();
    let e = s.parse("clouds.count=2.5").unwrap_err();
    assert!(e.to_string().contains("whole"), "{e}");
    s.parse("clouds.count=3").unwrap();
    assert_eq!(s.get("clouds", "count"), Some(3.0));
}
