//! `include/bpins.h` is what cbindgen makes of this crate now: regenerated here and
//! compared with the checked-in file. Stale, the test fails and says how to refresh it
//! (`BPINS_BLESS=1` writes the new header instead of comparing).

use std::path::Path;

fn generated() -> String {
    let dir = env!("CARGO_MANIFEST_DIR");
    let config = cbindgen::Config::from_file(Path::new(dir).join("cbindgen.toml")).expect("cbindgen.toml");
    let bindings =
        cbindgen::Builder::new().with_crate(dir).with_config(config).generate().expect("cbindgen parses bpins-capi");
    let mut out = Vec::new();
    bindings.write(&mut out);
    String::from_utf8(out).expect("the header is UTF-8")
}

#[test]
fn the_checked_in_header_is_current() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("include/bpins.h");
    let now = generated();
    if std::env::var_os("BPINS_BLESS").is_some() {
        std::fs::write(&path, &now).expect("writing include/bpins.h");
        return;
    }
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    if checked_in != now {
        let line = checked_in.lines().zip(now.lines()).position(|(a, b)| a != b).map_or(0, |i| i + 1);
        panic!(
            "{} is stale (first difference near line {line}): the C ABI changed. Regenerate it with\n    \
             BPINS_BLESS=1 cargo test -p bpins-capi --test header\nand commit it.",
            path.display()
        );
    }
    // What a C host relies on is in it.
    for name in [
        "bpins_compass_new(",
        "bpins_compass_new_with_calibration(",
        "bpins_compass_heading_u16(",
        "bpins_compass_heading_u8(",
        "bpins_compass_heading_f32(",
        "bpins_compass_free(",
        "bpins_last_error_message(",
        "bpins_version(",
        "BPINS_ERR_PANIC",
        "typedef struct BpinsCompass BpinsCompass;",
    ] {
        assert!(now.contains(name), "{name} missing from the header");
    }
}
