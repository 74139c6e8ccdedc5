//! The report of `bpins diagnose` opens in headless Chromium without errors: no console
//! message, every residual map found and decoded, the tables there. Without Chromium on
//! PATH these tests are counted as ignored, with the reason and the install command
//! below the run's summary — except with `CI` set, where they fail (`.ci/run` installs
//! it). The harness is `tests/needs/mod.rs` (`harness = false`).

#[path = "needs/mod.rs"]
mod needs;

use std::fs::{self, File};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::thread::sleep;
use std::time::{Duration, Instant};

const CLEAN: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/clean");
const BROWSERS: [&str; 3] = ["chromium", "chromium-browser", "google-chrome"];

fn main() -> std::process::ExitCode {
    let missing = chromium().is_none().then(|| {
        format!(
            "none of {} on PATH; install it (Debian: `apt-get install -y chromium`; `.ci/run` does)",
            BROWSERS.join(", ")
        )
    });
    needs::run(vec![(
        needs::Need::new("chromium", missing),
        vec![
            ("diagnose_report_opens_in_headless_chromium", diagnose_report_opens_in_headless_chromium),
            ("calibrate_report_opens_in_headless_chromium", calibrate_report_opens_in_headless_chromium),
            ("sweep_report_opens_in_headless_chromium", sweep_report_opens_in_headless_chromium),
        ],
    )])
}

/// The first of `BROWSERS` found on PATH.
fn chromium() -> Option<PathBuf> {
    needs::find_on_path(&BROWSERS, &[])
}

/// The browser; `main` runs the tests only where there is one.
fn browser() -> PathBuf {
    chromium().expect("main checked for a browser")
}

/// Opens `page` in headless Chromium and returns its DOM once loaded, or every problem
/// seen: a console message (the report logs nothing, so any message is an error, e.g.
/// "Uncaught ReferenceError: …"), images that did not load or decode (counted by the
/// page itself into `<body data-images-ok="decoded/all">`), a browser that failed or hung.
fn render(browser: &Path, page: &Path) -> Result<String, Vec<String>> {
    render_with(browser, page, true)
}

/// [`render`]; `images`: whether the page counts its images (a page without images or
/// scripts, such as the sweep report, does not).
fn render_with(browser: &Path, page: &Path, images: bool) -> Result<String, Vec<String>> {
    let work = tempfile::tempdir().unwrap();
    let (dom_path, log_path) = (work.path().join("dom.html"), work.path().join("stderr.txt"));
    let mut child = Command::new(browser)
        .args(["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"])
        .args(["--disable-component-update", "--disable-sync", "--no-first-run"])
        .arg(format!("--user-data-dir={}", work.path().join("profile").display()))
        // Console messages go to stderr as `…:INFO:CONSOLE…] "text", source: URL (line)`.
        .args(["--enable-logging=stderr", "--v=0", "--virtual-time-budget=5000", "--dump-dom"])
        .arg(page.canonicalize().unwrap())
        // Files, not pipes: nothing blocks while we wait with a deadline.
        .stdout(File::create(&dom_path).unwrap())
        .stderr(File::create(&log_path).unwrap())
        .spawn()
        .unwrap_or_else(|e| panic!("starting {}: {e}", browser.display()));
    let deadline = Instant::now() + Duration::from_secs(60);
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break Some(status);
        }
        if Instant::now() > deadline {
            child.kill().unwrap();
            child.wait().unwrap();
            break None;
        }
        sleep(Duration::from_millis(100));
    };
    let dom = fs::read_to_string(&dom_path).unwrap();
    let log = fs::read_to_string(&log_path).unwrap();

    let mut problems: Vec<String> = log.lines().filter(|l| l.contains(":CONSOLE")).map(str::to_string).collect();
    match status {
        None => problems.push("chromium did not finish within 60 s".into()),
        Some(s) if !s.success() => problems.push(format!("chromium exited with {s}:\n{log}")),
        Some(_) => {}
    }
    match dom.split_once("data-images-ok=\"").and_then(|(_, rest)| rest.split_once('"')) {
        None if !images => {}
        None => problems.push("no data-images-ok on <body>: the page's load script did not run".into()),
        Some((counts, _)) => match counts.split_once('/') {
            Some((ok, all)) if ok == all => {}
            _ => problems.push(format!("images decoded/all: {counts}")),
        },
    }
    if problems.is_empty() {
        Ok(dom)
    } else {
        Err(problems)
    }
}

fn diagnose_report_opens_in_headless_chromium() {
    let browser = browser();
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("diag");
    let run = Command::new(env!("CARGO_BIN_EXE_bpins"))
        .args(["diagnose", CLEAN, "--max-added", "1", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(run.status.success(), "`bpins diagnose` failed:\n{}", String::from_utf8_lossy(&run.stderr));
    let report = out.join("report.html");
    let html = fs::read_to_string(&report).unwrap();

    let dom = render(&browser, &report)
        .unwrap_or_else(|p| panic!("{} does not render cleanly:\n{}", report.display(), p.join("\n")));
    // Four maps per step, all of them decoded; the step table and the verdict there.
    let imgs = html.matches("<img ").count();
    assert!(imgs >= 4, "report.html shows {imgs} images");
    assert!(dom.contains(&format!("data-images-ok=\"{imgs}/{imgs}\"")), "not every image decoded");
    for what in ["The error, step by step", "<td>(no effect)</td>", "What remains", "Final model: frames"] {
        assert!(dom.contains(what), "the rendered report lacks `{what}`");
    }

    // The check catches a broken page: the same report, one map pointing nowhere and a
    // script that throws.
    let broken = out.join("broken.html");
    let bad =
        html.replacen("src=\"step0/", "src=\"missing/", 1).replace("</body>", "<script>notDefined()</script></body>");
    fs::write(&broken, bad).unwrap();
    let problems = render(&browser, &broken).expect_err("a broken page passed the check");
    assert!(problems.iter().any(|p| p.contains("Uncaught ReferenceError")), "script error missed: {problems:?}");
    assert!(problems.iter().any(|p| p.contains(&format!("{}/{imgs}", imgs - 1))), "missing image missed: {problems:?}");
}

fn calibrate_report_opens_in_headless_chromium() {
    let browser = browser();
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("cal");
    let lab = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/lab-flawed-sensor/lab");
    let run = Command::new(env!("CARGO_BIN_EXE_bpins")).args(["calibrate", lab, "--out"]).arg(&out).output().unwrap();
    assert!(run.status.success(), "`bpins calibrate` failed:\n{}", String::from_utf8_lossy(&run.stderr));
    let report = out.join("report.html");
    let html = fs::read_to_string(&report).unwrap();
    let dom = render(&browser, &report)
        .unwrap_or_else(|p| panic!("{} does not render cleanly:\n{}", report.display(), p.join("\n")));
    let imgs = html.matches("<img ").count();
    assert!(imgs >= 8, "report.html shows {imgs} maps");
    assert!(dom.contains(&format!("data-images-ok=\"{imgs}/{imgs}\"")), "not every map decoded");
    for what in ["Per channel: mean, white spread, gradient across the die", "conversion gain K", "Not determined"] {
        assert!(dom.contains(what), "the rendered report lacks `{what}`");
    }
}

fn sweep_report_opens_in_headless_chromium() {
    let browser = browser();
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("sweep");
    let tiny = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/sweeps/tiny.toml");
    let run = Command::new(env!("CARGO_BIN_EXE_bpins"))
        .args(["sweep", tiny, "--trials", "4", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(run.status.success(), "`bpins sweep` failed:\n{}", String::from_utf8_lossy(&run.stderr));
    let report = out.join("report.html");
    let html = fs::read_to_string(&report).unwrap();
    assert!(!html.contains("<script"), "the sweep report needs no script");
    let dom = render_with(&browser, &report, false)
        .unwrap_or_else(|p| panic!("{} does not render cleanly:\n{}", report.display(), p.join("\n")));
    // One σ-against-elevation plot per extractor (2) and a histogram per row (5 sources
    // × 2 extractors × 3 elevations), every one in the rendered DOM.
    assert_eq!(dom.matches("<svg").count(), 2 + 30, "svg plots in the rendered report");
    assert_eq!(dom.matches("<polyline").count(), 2 * 5, "one line per source and extractor");
    for what in ["σ of the heading error against the sun elevation", "Error budget", "Histograms of the heading error"]
    {
        assert!(dom.contains(what), "the rendered report lacks `{what}`");
    }
}
