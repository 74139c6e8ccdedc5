//! End-to-end tests of `bpins sweep` and `bpins merge` on examples/sweeps/tiny.toml:
//! a bad sweep file is refused before any trial runs, naming the file, the key and
//! what was expected; slices merge into the unsharded result bit for bit; a finished
//! slice is not recomputed, a half-written one is; a colour sensor's sweep gives a row
//! per band and a fused one, and its slices merge as well.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const TINY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/sweeps/tiny.toml");
const COLOUR_TINY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/sweeps/colour-tiny.toml");
const FILES: [&str; 6] = ["summary.json", "summary.csv", "budget.csv", "trials.csv", "report.html", "shard.toml"];

fn bpins(args: &[&str], out: Option<&Path>) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_bpins"));
    c.args(args);
    if let Some(o) = out {
        c.arg("--out").arg(o);
    }
    let o = c.output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "`bpins {args:?}` panicked:\n{err}");
    o
}

fn ok(args: &[&str], out: &Path) -> (String, String) {
    let o = bpins(args, Some(out));
    let (so, se) = (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned());
    assert!(o.status.success(), "`bpins {args:?}` failed:\n{se}");
    (so, se)
}

#[test]
fn a_bad_sweep_file_is_refused_before_any_trial_naming_file_key_and_expectation() {
    let t = tempfile::tempdir().unwrap();
    let text = fs::read_to_string(TINY).unwrap();
    for (from, to, key) in [
        ("sigma = 0.1", "sigma = -0.1", "errors[0].sigma"),
        ("distribution = \"uniform\"", "distribution = \"cauchy\"", "errors[1].distribution"),
        ("param = \"imu.tilt_x_deg\"", "param = \"imu.roll_deg\"", "errors[3].param"),
        ("trials = 12", "trials = \"many\"", "trials"),
        ("sun_azimuths_deg = [10, 40, 70]", "sun_azimuths_deg = \"north\"", "sky.sun_azimuths_deg"),
    ] {
        assert!(text.contains(from), "{from}");
        let bad = t.path().join("bad-sweep.toml");
        fs::write(&bad, text.replacen(from, to, 1)).unwrap();
        let out = t.path().join("out");
        let o = bpins(&["sweep", bad.to_str().unwrap()], Some(&out));
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains("bad-sweep.toml") && err.contains(key) && err.contains("expected"), "{key}: {err}");
        assert!(!out.exists(), "the output folder was made before the file was checked");
    }
    // Interface errors: a shard that does not exist.
    let o = bpins(&["sweep", TINY, "--shard", "3/3"], Some(&t.path().join("x")));
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("I/N"));
}

#[test]
fn merged_slices_equal_the_unsharded_sweep_and_slices_restart() {
    let t = tempfile::tempdir().unwrap();
    let whole = t.path().join("whole");
    let (stdout, _) = ok(&["sweep", TINY, "--trials", "6"], &whole);
    assert!(stdout.contains("installation_angle") && stdout.contains("budget"), "{stdout}");
    let v: serde_json::Value = serde_json::from_str(&fs::read_to_string(whole.join("summary.json")).unwrap()).unwrap();
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 5 * 2 * 3);
    for key in ["source", "extractor", "sun_elevation_deg", "mean_deg", "std_deg", "rms_deg", "p95_deg", "trials"] {
        assert!(rows.iter().all(|r| !r[key].is_null()), "a row lacks {key}");
    }
    assert!(rows.iter().all(|r| r["trials"] == 6));
    assert!(!v["budget"].as_array().unwrap().is_empty());
    // What a few trials can say (issue 49 item 7): each mean with its own 1σ, σ/√n; each
    // budget's shares of Σσ² summing to 100 % (a share of the combined variance can pass
    // 100 % by the trials' scatter), printed so, with how well each σ is known.
    for r in rows {
        let (sd, ms) = (r["std_deg"].as_f64().unwrap(), r["mean_sigma_deg"].as_f64().unwrap());
        assert!((ms - sd / 6f64.sqrt()).abs() <= 1e-12 * sd.max(1.0), "{r}");
    }
    for b in v["budget"].as_array().unwrap() {
        let sum: f64 = b["shares"].as_array().unwrap().iter().map(|x| x["share_of_sum"].as_f64().unwrap()).sum();
        assert!((sum - 1.0).abs() < 1e-9, "{b}");
    }
    let budget_lines: Vec<&str> = stdout.lines().filter(|l| l.starts_with("budget ")).collect();
    assert!(
        !budget_lines.is_empty() && budget_lines.iter().all(|l| l.contains("of Σσ²") && l.contains("from 6 trials"))
    );
    for l in &budget_lines {
        for pct in l.split(" %").filter_map(|p| p.rsplit(' ').next()?.parse::<f64>().ok()) {
            assert!((0.0..=100.0).contains(&pct), "a share beyond 100 %: {l}");
        }
    }
    assert!(stdout.contains("±1σ (°)") && stdout.contains("not a bias"), "{stdout}");

    let shards: Vec<PathBuf> = (0..4).map(|i| t.path().join(format!("shard-{i}"))).collect();
    for (i, d) in shards.iter().enumerate() {
        ok(&["sweep", TINY, "--trials", "6", "--shard", &format!("{i}/4")], d);
    }
    // A finished slice is not recomputed …
    let before = fs::metadata(shards[2].join("trials.csv")).unwrap().modified().unwrap();
    let (_, err) = ok(&["sweep", TINY, "--trials", "6", "--shard", "2/4"], &shards[2]);
    assert!(err.contains("already complete"), "{err}");
    assert_eq!(fs::metadata(shards[2].join("trials.csv")).unwrap().modified().unwrap(), before);
    // … a half-written one (killed before its shard.toml) is, and merge refuses it until then.
    fs::remove_file(shards[1].join("shard.toml")).unwrap();
    fs::write(shards[1].join("trials.csv"), "sun_elevation_deg,source\n5,install").unwrap();
    let merged = t.path().join("merged");
    let mut args = vec!["merge"];
    let names: Vec<String> = shards.iter().map(|p| p.display().to_string()).collect();
    args.extend(names.iter().map(String::as_str));
    let o = bpins(&args, Some(&merged));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("shard-1") && e.contains("incomplete"), "{e}");
    ok(&["sweep", TINY, "--trials", "6", "--shard", "1/4"], &shards[1]);
    ok(&args, &merged);
    for f in FILES {
        assert_eq!(fs::read(whole.join(f)).unwrap(), fs::read(merged.join(f)).unwrap(), "{f} differs");
    }
    // Slices of another trial count are not merged with these.
    ok(&["sweep", TINY, "--trials", "5", "--shard", "3/4"], &shards[3]);
    let o = bpins(&args, Some(&merged));
    assert!(String::from_utf8_lossy(&o.stderr).contains("trials_per_source"));
}

/// A colour-polarization sensor (examples/sweeps/colour-tiny.toml): each band's row (R,
/// G, B) and the fused one, in the table and every file; a blue-only weak grid moves the
/// blue row and leaves R and G on the nominal chain's errors; two slices merge into the
/// whole run bit for bit.
#[test]
fn a_colour_sweep_has_a_row_per_band_and_a_fused_one_and_merges() {
    let t = tempfile::tempdir().unwrap();
    let whole = t.path().join("whole");
    let (stdout, _) = ok(&["sweep", COLOUR_TINY, "--trials", "4"], &whole);
    assert!(stdout.contains("colour sensor: a row per band") && stdout.contains("sun_vector fused"), "{stdout}");
    let v: serde_json::Value = serde_json::from_str(&fs::read_to_string(whole.join("summary.json")).unwrap()).unwrap();
    let rows = v["rows"].as_array().unwrap();
    // 3 sources and combined, 2 extractors, 2 sun elevations, 4 band columns.
    assert_eq!(rows.len(), 4 * 2 * 2 * 4);
    let row = |source: &str, ex: &str, el: f64, band: &str| {
        rows.iter()
            .find(|r| {
                r["source"] == source && r["extractor"] == ex && r["sun_elevation_deg"] == el && r["band"] == band
            })
            .unwrap_or_else(|| panic!("no row {source} {ex} {el} {band}"))
            .clone()
    };
    for el in [20.0, 50.0] {
        for ex in ["sun_vector", "meridian_line"] {
            let rms = |source: &str, band: &str| row(source, ex, el, band)["rms_deg"].as_f64().unwrap();
            let worst = ["R", "G", "B"].iter().map(|b| rms("pixel_noise", b)).fold(0.0, f64::max);
            assert!(rms("pixel_noise", "fused") <= worst, "{ex} at {el}°: the fused row is worse than every band");
        }
        // ε_B ∈ [0, 0.3] lowers the blue band's DoLP alone: the superpixels' gradient
        // leak (the nominal error) grows against it in B's row only; R's and G's stay the
        // nominal chain's, within the few thousandths their own pixels differ by.
        let mean = |band: &str| row("blue_grid", "sun_vector", el, band)["mean_deg"].as_f64().unwrap();
        let (r, g, b) = (mean("R"), mean("G"), mean("B"));
        assert!((b - g).abs() > 3.0 * (r - g).abs().max(1e-3), "sun_vector at {el}°: R {r} G {g} B {b}");
    }
    let csv = fs::read_to_string(whole.join("summary.csv")).unwrap();
    assert!(csv.starts_with("source,extractor,sun_elevation_deg,known,band,"), "{csv}");
    assert!(fs::read_to_string(whole.join("trials.csv"))
        .unwrap()
        .starts_with("sun_elevation_deg,source,trial,sun_azimuth_deg,extractor,known,band,error_deg\n"));
    let shards: Vec<PathBuf> = (0..2).map(|i| t.path().join(format!("shard-{i}"))).collect();
    for (i, d) in shards.iter().enumerate() {
        ok(&["sweep", COLOUR_TINY, "--trials", "4", "--shard", &format!("{i}/2")], d);
    }
    let merged = t.path().join("merged");
    let names: Vec<String> = shards.iter().map(|p| p.display().to_string()).collect();
    let mut args = vec!["merge"];
    args.extend(names.iter().map(String::as_str));
    let (merge_out, _) = ok(&args, &merged);
    assert!(merge_out.contains("meridian_line fused"), "{merge_out}");
    for f in FILES {
        assert_eq!(fs::read(whole.join(f)).unwrap(), fs::read(merged.join(f)).unwrap(), "{f} differs");
    }
}
