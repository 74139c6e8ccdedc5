//! Progress on stderr: a bar (or a spinner, where the amount of work is unknown) on a
//! terminal; where stderr is not a terminal (`2> log`, CI, a pipe), where indicatif
//! draws nothing, plain lines instead:
//!
//! ```text
//! progress: trials 240/800 (30 %), 1 min 21 s elapsed, eta 3 min 09 s
//! ```
//!
//! at most one per tenth of the work and one every 10 s (a background tick prints
//! the latter even while the position stands still, e.g. while llvmpipe compiles a
//! kernel), never two within 1 s, and none at all for work done within 3 s; a last
//! `done` line where any was printed. `BPINS_PROGRESS_EVERY_S=60` sets the 10 s (the
//! other two scale with it: [`Pace`]). Every command's long work goes through [`bar`]
//! or [`spinner`], so every command gets both.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::{mpsc, Arc, Mutex};
use std::time::{Duration, Instant};

/// The environment variable that sets [`Pace::every`], in seconds.
pub const EVERY_VAR: &str = "BPINS_PROGRESS_EVERY_S";

/// How often plain lines come.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pace {
    /// A line at least this often while the work lasts (default 10 s).
    pub every: Duration,
    /// Work done within this prints no line (3/10 of `every`).
    pub quiet: Duration,
    /// Never two lines closer than this, e.g. tenths of the work done in a burst (1/10
    /// of `every`).
    pub gap: Duration,
}

impl Pace {
    pub fn every(every: Duration) -> Pace {
        Pace { every, quiet: every.mul_f64(0.3), gap: every / 10 }
    }

    /// `BPINS_PROGRESS_EVERY_S` where it is a positive number of seconds, else 10 s.
    pub fn from_env() -> Pace {
        let s = std::env::var(EVERY_VAR).ok().and_then(|v| v.trim().parse::<f64>().ok());
        Pace::every(Duration::from_secs_f64(s.filter(|s| s.is_finite() && *s > 0.0 && *s < 1e6).unwrap_or(10.0)))
    }
}

/// How often the background tick looks at the clock (at most).
const TICK: Duration = Duration::from_millis(500);

/// A bar over `total` steps of `what` (e.g. "trials", "frames").
pub fn bar(total: u64, what: &str) -> Progress {
    Progress::new(Some(total), what, std::io::stderr().is_terminal())
}

/// A spinner for work of unknown length (a fit's iterations): `what` and the last
/// [`Progress::set_message`].
pub fn spinner(what: &str) -> Progress {
    Progress::new(None, what, std::io::stderr().is_terminal())
}

/// Progress of one piece of work: an indicatif bar on a terminal, plain lines
/// elsewhere (see the module doc). `Sync`: rayon workers may move it.
pub struct Progress {
    inner: Arc<Inner>,
    /// Dropped with the progress: the background tick then ends.
    _tick: Option<mpsc::Sender<()>>,
}

struct Inner {
    bar: ProgressBar,
    /// `None` on a terminal (the bar draws itself).
    lines: Option<Mutex<Lines>>,
}

impl Progress {
    fn new(total: Option<u64>, what: &str, terminal: bool) -> Progress {
        let bar = match (total, terminal) {
            (_, false) => ProgressBar::with_draw_target(total, ProgressDrawTarget::hidden()),
            (Some(n), true) => {
                let pb = ProgressBar::new(n);
                pb.set_style(
                    ProgressStyle::with_template(
                        "{prefix} [{elapsed_precise}] {wide_bar} {pos}/{len} {msg} (eta {eta})",
                    )
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
                );
                pb
            }
            (None, true) => {
                let pb = ProgressBar::new_spinner();
                pb.set_style(
                    ProgressStyle::with_template("{spinner} {prefix}: {msg} [{elapsed}]")
                        .unwrap_or_else(|_| ProgressStyle::default_spinner()),
                );
                pb.enable_steady_tick(Duration::from_millis(200));
                pb
            }
        };
        bar.set_prefix(what.to_string());
        if terminal {
            return Progress { inner: Arc::new(Inner { bar, lines: None }), _tick: None };
        }
        let pace = Pace::from_env();
        let lines = Lines::new(what, total, Instant::now(), pace);
        let inner = Arc::new(Inner { bar, lines: Some(Mutex::new(lines)) });
        let (tx, rx) = mpsc::channel::<()>();
        let ticked = inner.clone();
        let tick = TICK.min(pace.gap.max(Duration::from_millis(10)));
        // The tick ends when the sender drops (the progress is dropped) or on finish.
        let _ = std::thread::Builder::new().name("progress".into()).spawn(move || {
            while let Err(mpsc::RecvTimeoutError::Timeout) = rx.recv_timeout(tick) {
                if !ticked.update(|_| ()) {
                    break;
                }
            }
        });
        Progress { inner, _tick: Some(tx) }
    }

    pub fn set_position(&self, pos: u64) {
        self.inner.bar.set_position(pos);
        self.inner.update(|l| l.pos = pos);
    }

    pub fn inc(&self, delta: u64) {
        self.inner.bar.inc(delta);
        self.inner.update(|l| l.pos += delta);
    }

    pub fn set_length(&self, len: u64) {
        self.inner.bar.set_length(len);
        self.inner.update(|l| l.len = Some(len));
    }

    pub fn set_message(&self, msg: impl Into<String>) {
        let msg: String = msg.into();
        self.inner.bar.set_message(msg.clone());
        self.inner.update(|l| l.msg = msg);
    }

    /// Runs `f` with the bar hidden (to print rows between its draws).
    pub fn suspend<R, F: FnOnce() -> R>(&self, f: F) -> R {
        self.inner.bar.suspend(f)
    }

    /// Ends the work: the bar vanishes; in lines, a last `done` line where any was
    /// printed (so a log says the work ended).
    pub fn finish_and_clear(&self) {
        self.inner.bar.finish_and_clear();
        if let Some(m) = &self.inner.lines {
            let mut l = m.lock().unwrap_or_else(|e| e.into_inner());
            if let Some(line) = l.finish(Instant::now()) {
                say!("{line}");
            }
        }
    }
}

/// The bar itself, for what [`Progress`] does not wrap (drawn on a terminal only).
impl std::ops::Deref for Progress {
    type Target = ProgressBar;
    fn deref(&self) -> &ProgressBar {
        &self.inner.bar
    }
}

impl Inner {
    /// Applies `change` to the lines' state and prints a line if one is due. False
    /// once the work is finished (the tick then stops).
    fn update(&self, change: impl FnOnce(&mut Lines)) -> bool {
        let Some(m) = &self.lines else { return true };
        let mut l = m.lock().unwrap_or_else(|e| e.into_inner());
        if l.finished {
            return false;
        }
        change(&mut l);
        if let Some(line) = l.due(Instant::now()) {
            say!("{line}");
        }
        true
    }
}

/// The state of the plain lines (stderr not a terminal).
struct Lines {
    what: String,
    len: Option<u64>,
    pos: u64,
    msg: String,
    start: Instant,
    pace: Pace,
    /// When the last line was printed, and at which tenth of the work.
    last: Option<(Instant, u64)>,
    printed: usize,
    finished: bool,
}

impl Lines {
    fn new(what: &str, len: Option<u64>, start: Instant, pace: Pace) -> Lines {
        let msg = String::new();
        Lines { what: what.into(), len, pos: 0, msg, start, pace, last: None, printed: 0, finished: false }
    }

    /// Which tenth of the work is done (0…10); 0 where the length is unknown.
    fn tenth(&self) -> u64 {
        match self.len {
            Some(n) if n > 0 => (self.pos.min(n) * 10) / n,
            _ => 0,
        }
    }

    /// The line to print at `now`, if one is due (and then it counts as printed).
    fn due(&mut self, now: Instant) -> Option<String> {
        let elapsed = now.saturating_duration_since(self.start);
        if elapsed < self.pace.quiet {
            return None;
        }
        let (since, last_tenth) = match self.last {
            Some((t, tenth)) => (now.saturating_duration_since(t), tenth),
            None => (elapsed, 0),
        };
        let tenth = self.tenth();
        if since < self.pace.gap || (since < self.pace.every && tenth <= last_tenth) {
            return None;
        }
        self.last = Some((now, tenth));
        self.printed += 1;
        Some(self.line(elapsed))
    }

    /// The closing line, where any line was printed.
    fn finish(&mut self, now: Instant) -> Option<String> {
        if std::mem::replace(&mut self.finished, true) || self.printed == 0 {
            return None;
        }
        let elapsed = now.saturating_duration_since(self.start);
        let done = match self.len {
            Some(n) => format!("{}/{n}", self.pos.min(n)),
            None => String::new(),
        };
        Some(format!("progress: {} {done} done in {}", self.what, duration(elapsed)).replace("  ", " "))
    }

    fn line(&self, elapsed: Duration) -> String {
        let msg = if self.msg.is_empty() { String::new() } else { format!(", {}", self.msg) };
        match self.len {
            Some(n) if n > 0 => {
                let pos = self.pos.min(n);
                let eta = if pos == 0 {
                    "unknown".to_string()
                } else {
                    duration(elapsed.mul_f64((n - pos) as f64 / pos as f64))
                };
                format!(
                    "progress: {} {pos}/{n} ({} %){msg}, {} elapsed, eta {eta}",
                    self.what,
                    pos * 100 / n,
                    duration(elapsed)
                )
            }
            _ => format!("progress: {}{msg}, {} elapsed", self.what, duration(elapsed)),
        }
    }
}

/// `42 s`, `3 min 09 s`, `1 h 02 min`.
fn duration(d: Duration) -> String {
    let s = d.as_secs();
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {:02} s", s / 60, s % 60),
        _ => format!("{} h {:02} min", s / 3600, (s % 3600) / 60),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PACE: Pace =
        Pace { every: Duration::from_secs(10), quiet: Duration::from_secs(3), gap: Duration::from_secs(1) };

    #[test]
    fn the_pace_is_ten_seconds_unless_the_environment_says() {
        assert_eq!(Pace::every(Duration::from_secs(10)), PACE);
        // The variable is unset in tests (cargo sets no BPINS_ variable).
        if std::env::var_os(EVERY_VAR).is_none() {
            assert_eq!(Pace::from_env(), PACE);
        }
    }

    /// Lines at a steady rate of `per_s` steps per second over `total` steps, as
    /// (seconds since start, line).
    fn run(total: u64, per_s: f64) -> Vec<(f64, String)> {
        let t0 = Instant::now();
        let mut l = Lines::new("trials", Some(total), t0, PACE);
        let mut out = Vec::new();
        for pos in 1..=total {
            let t = pos as f64 / per_s;
            l.pos = pos;
            if let Some(line) = l.due(t0 + Duration::from_secs_f64(t)) {
                out.push((t, line));
            }
        }
        out
    }

    #[test]
    fn short_work_prints_nothing() {
        assert!(run(100, 50.0).is_empty(), "2 s of work");
        let t0 = Instant::now();
        let mut l = Lines::new("trials", Some(10), t0, PACE);
        l.pos = 10;
        assert_eq!(l.finish(t0 + Duration::from_secs(1)), None, "no done line without a progress line");
    }

    #[test]
    fn long_work_prints_a_line_per_tenth_and_every_ten_seconds_at_most() {
        // 1 000 steps over 400 s: a tenth per 40 s, so a line every 10 s as well.
        let lines = run(1000, 2.5);
        let times: Vec<f64> = lines.iter().map(|l| l.0).collect();
        assert!(times.windows(2).all(|w| w[1] - w[0] >= PACE.gap.as_secs_f64()), "{times:?}");
        assert!(times.windows(2).all(|w| w[1] - w[0] <= PACE.every.as_secs_f64() + 0.5), "{times:?}");
        assert!((40..=51).contains(&lines.len()), "{} lines: {times:?}", lines.len());
        let first = &lines[0].1;
        assert!(
            first.starts_with("progress: trials 2") && first.contains("/1000 (2 %), 10 s elapsed, eta 6 min"),
            "{first}"
        );
        // Fast work: a line per tenth, not one per step.
        let lines = run(100_000, 10_000.0);
        assert!((8..=10).contains(&lines.len()), "{lines:?}");
        assert!(lines[0].0 >= PACE.quiet.as_secs_f64(), "{lines:?}");
    }

    #[test]
    fn a_spinner_prints_its_message_every_ten_seconds() {
        let t0 = Instant::now();
        let mut l = Lines::new("fit", None, t0, PACE);
        let mut n = 0;
        for k in 0..600 {
            l.msg = format!("iteration {k} (LM)");
            n += usize::from(l.due(t0 + Duration::from_millis(100 * k)).is_some());
        }
        assert_eq!(n, 5, "60 s: lines at 10, 20, 30, 40, 50 s");
        l.msg = "iteration 7 (LM)".into();
        assert_eq!(l.line(Duration::from_secs(75)), "progress: fit, iteration 7 (LM), 1 min 15 s elapsed");
        assert_eq!(l.finish(t0 + Duration::from_secs(61)).as_deref(), Some("progress: fit done in 1 min 01 s"));
        assert_eq!(l.finish(t0 + Duration::from_secs(62)), None, "once");
    }
}
