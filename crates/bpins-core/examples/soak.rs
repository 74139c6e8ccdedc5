//! A soak run of the front door: frames fed to one `Compass` at a fixed rate for a
//! given time, as a robot would for a day. Reports the latency percentiles (p50, p99,
//! max, from a fixed histogram of 10 µs bins, so the report itself allocates nothing
//! as it runs), the heap in use and the resident memory at the start and the end,
//! allocations made by the loop, frames that missed their period, and the heading
//! error against the truth.
//!
//! ```sh
//! cargo run --release -p bpins-core --example soak -- --seconds 3600                 # an hour at 30 Hz, 612 × 512
//! cargo run --release -p bpins-core --example soak -- --seconds 600 --full-size      # ten minutes, 2448 × 2048
//! cargo run --release -p bpins-core --example soak -- --seconds 60 --rate-hz 100
//! ```
//!
//! Frames: a pool of 16 rendered before the clock starts (a robot turning 22.5° a
//! frame, tilt wobbling ±5° as an IMU reads it to 0.1°, the sun at 40°/25°), fed in
//! turn; the latency is the compass's alone (borrowed u16 buffer → heading ± 1σ).
//! Every `--report-s` seconds (default 60) a line gives the window's figures, so a
//! drift shows while it runs. Memory is the heap in use (a counting allocator) and
//! the resident set from /proc/self/statm (Linux; "n/a" elsewhere). The resident set
//! also holds the histogram's pages as far as the slowest frame reached (10 µs bins
//! of 8 bytes: 0.8 MB per second of the worst latency); the heap is exact.
//!
//! The loop runs on a worker of a rayon pool of its own (`ThreadPool::install`), as a
//! robot's loop that wants no allocation per frame does (docs/rust.md). With
//! `--outside-pool` it runs on the main thread instead: each parallel step of a frame
//! then goes through rayon's global job queue, whose crossbeam `Injector` allocates a
//! 1520-byte block per 63 jobs (counted among the compass's allocations).

use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::compass::{Attitude, Compass, CompassConfig, Sun};
use bpins_core::conventions::wrap_deg_180;
use bpins_core::internal::chain::{ChainFrame, NoiseIndex, Scene};
use bpins_core::internal::heading::field::RawImage;
use bpins_core::internal::simulate::render_mosaic;
use bpins_core::sensor::{Response, DEFAULT_MOSAIC};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicI64, AtomicU64, Ordering::Relaxed};
use std::time::{Duration, Instant};

/// The system allocator, counting calls and bytes in use.
struct Counting;
static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);
static HEAP_BYTES: AtomicI64 = AtomicI64::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Relaxed);
        HEAP_BYTES.fetch_add(l.size() as i64, Relaxed);
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        HEAP_BYTES.fetch_sub(l.size() as i64, Relaxed);
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Relaxed);
        HEAP_BYTES.fetch_add(new as i64 - l.size() as i64, Relaxed);
        unsafe { System.realloc(p, l, new) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Latencies in 10 µs bins up to 10 s; the last bin holds anything longer.
struct Histogram {
    bins: Vec<u64>,
    max_ms: f64,
    count: u64,
    /// One past the highest bin in use: clearing touches no more (the zeroed pages
    /// above stay unmapped, so the resident figure is the compass's).
    top: usize,
}

impl Histogram {
    const BIN_MS: f64 = 0.01;

    fn new() -> Self {
        Histogram { bins: vec![0; 1_000_000], max_ms: 0.0, count: 0, top: 0 }
    }

    fn add(&mut self, ms: f64) {
        let i = ((ms / Self::BIN_MS) as usize).min(self.bins.len() - 1);
        self.bins[i] += 1;
        self.top = self.top.max(i + 1);
        self.max_ms = self.max_ms.max(ms);
        self.count += 1;
    }

    /// The `p` quantile (0…1), as the upper edge of its bin, in ms.
    fn quantile_ms(&self, p: f64) -> f64 {
        let want = ((self.count as f64 * p).ceil() as u64).max(1);
        let mut seen = 0;
        for (i, n) in self.bins[..self.top].iter().enumerate() {
            seen += n;
            if seen >= want {
                return (i + 1) as f64 * Self::BIN_MS;
            }
        }
        self.max_ms
    }

    fn clear(&mut self) {
        self.bins[..self.top].iter_mut().for_each(|b| *b = 0);
        (self.max_ms, self.count, self.top) = (0.0, 0, 0);
    }
}

struct Args {
    outside_pool: bool,
    seconds: f64,
    rate_hz: f64,
    report_s: f64,
    width_px: usize,
    height_px: usize,
}

fn args() -> Result<Args, String> {
    let mut a =
        Args { outside_pool: false, seconds: 60.0, rate_hz: 30.0, report_s: 60.0, width_px: 612, height_px: 512 };
    let mut it = std::env::args().skip(1);
    while let Some(k) = it.next() {
        let mut num = |name: &str| -> Result<f64, String> {
            let v = it.next().ok_or(format!("{name} needs a value"))?;
            v.parse::<f64>().ok().filter(|x| x.is_finite() && *x > 0.0).ok_or(format!("{name} = {v}: a number > 0"))
        };
        match k.as_str() {
            "--seconds" => a.seconds = num("--seconds")?,
            "--rate-hz" => a.rate_hz = num("--rate-hz")?,
            "--report-s" => a.report_s = num("--report-s")?,
            "--full-size" => (a.width_px, a.height_px) = (2448, 2048),
            "--outside-pool" => a.outside_pool = true,
            _ => {
                return Err(format!(
                    "unknown argument {k} (--seconds S, --rate-hz R, --report-s S, --full-size, --outside-pool)"
                ))
            }
        }
    }
    Ok(a)
}

/// Resident set size in MB, from /proc/self/statm (pages × 4 KiB).
fn rss_mb() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: f64 = s.split_whitespace().nth(1)?.parse().ok()?;
    Some(pages * 4096.0 / 1e6)
}

fn mb(x: Option<f64>) -> String {
    x.map_or("n/a".into(), |v| format!("{v:.1} MB"))
}

fn heap_mb() -> f64 {
    HEAP_BYTES.load(Relaxed) as f64 / 1e6
}

fn main() -> Result<(), Error> {
    let a = args()?;
    let (w, h) = (a.width_px, a.height_px);
    let scale = w as f64 / 612.0;
    let lens =
        Intrinsics::new(Projection::Pinhole, scale * 8000.0 / 13.8, (w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
    eprintln!("rendering 16 frames of {w} × {h} px …");
    let pool: Vec<(Vec<u16>, Attitude, f64)> = (0..16)
        .map(|k| {
            let t = k as f64;
            let (tx, ty) = (5.0 * (0.9 * t).sin(), 4.0 * (0.6 * t + 1.0).cos());
            let heading = 22.5 * t;
            let scene = Scene {
                sun_az_deg: 40.0,
                sun_el_deg: 25.0,
                heading_deg: heading,
                tilt_x_deg: tx,
                tilt_y_deg: ty,
                dmax: 0.6,
            };
            let noise = NoiseIndex { seed: 11, trial: 0, frame: k };
            let f = ChainFrame::new(&Default::default(), &lens, &scene, &Response::samples(3000.0), noise);
            let raw = render_mosaic(&f, w, h, &DEFAULT_MOSAIC).into_iter().map(|x| x as u16).collect();
            let imu = (0.1 * (1.7 * t).sin(), 0.1 * (2.3 * t).cos());
            (raw, Attitude { tilt_x_deg: tx + imu.0, tilt_y_deg: ty + imu.1, sigma_deg: 0.1 }, heading)
        })
        .collect();
    if a.outside_pool {
        return soak(&a, &pool, lens);
    }
    eprintln!("the loop on a rayon pool's worker (--outside-pool: on the main thread)");
    rayon::ThreadPoolBuilder::new().build()?.install(|| soak(&a, &pool, lens))
}

type Error = Box<dyn std::error::Error + Send + Sync>;

/// The warm-up and the timed loop over `pool` (frame, attitude, true heading).
fn soak(a: &Args, pool: &[(Vec<u16>, Attitude, f64)], lens: Intrinsics) -> Result<(), Error> {
    let (w, h) = (a.width_px, a.height_px);
    let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
    let mut compass = Compass::new(CompassConfig::dofp(lens, w, h, 12, 64.0))?;
    // Warm-up: the compass sizes its buffers on the first frames.
    for (raw, att, _) in pool {
        compass.heading(RawImage::packed(raw, w, h), sun, *att)?;
    }
    let (mut all, mut window) = (Histogram::new(), Histogram::new());
    let (heap0, rss0, alloc0) = (heap_mb(), rss_mb(), ALLOCATIONS.load(Relaxed));
    let period = Duration::from_secs_f64(1.0 / a.rate_hz);
    let frames = (a.seconds * a.rate_hz).round() as u64;
    println!(
        "soak: {frames} frames of {w} × {h} px at {} Hz ({} s); heap {heap0:.1} MB, resident {} at start",
        a.rate_hz,
        a.seconds,
        mb(rss0)
    );
    println!(
        "{:>8} {:>9} {:>9} {:>9} {:>9} {:>10} {:>12} {:>8}",
        "time (s)", "frames", "p50 (ms)", "p99 (ms)", "max (ms)", "heap (MB)", "resident", "missed"
    );
    let (mut missed, mut missed_window, mut sq_err, mut no_heading) = (0u64, 0u64, 0.0f64, 0u64);
    let mut compass_allocs = 0u64;
    let start = Instant::now();
    let mut next_report = a.report_s;
    for k in 0..frames {
        let (raw, att, truth) = &pool[(k % 16) as usize];
        let a0 = ALLOCATIONS.load(Relaxed);
        let t0 = Instant::now();
        let fix = compass.heading(RawImage::packed(raw, w, h), sun, *att)?;
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        compass_allocs += ALLOCATIONS.load(Relaxed) - a0;
        all.add(ms);
        window.add(ms);
        match fix.heading_deg() {
            Some(hd) => sq_err += wrap_deg_180(hd - truth).powi(2),
            None => no_heading += 1,
        }
        let due = start + period.mul_f64((k + 1) as f64);
        match due.checked_duration_since(Instant::now()) {
            Some(rest) => std::thread::sleep(rest),
            None => (missed, missed_window) = (missed + 1, missed_window + 1),
        }
        let now = start.elapsed().as_secs_f64();
        if now >= next_report || k + 1 == frames {
            println!(
                "{now:>8.0} {:>9} {:>9.2} {:>9.2} {:>9.2} {:>10.1} {:>12} {missed_window:>8}",
                k + 1,
                window.quantile_ms(0.5),
                window.quantile_ms(0.99),
                window.max_ms,
                heap_mb(),
                mb(rss_mb())
            );
            window.clear();
            missed_window = 0;
            next_report += a.report_s;
        }
    }
    let allocs = ALLOCATIONS.load(Relaxed) - alloc0;
    let used = frames - no_heading;
    println!(
        "latency over {frames} frames: p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms (period {:.1} ms); \
         {missed} frames missed their period",
        all.quantile_ms(0.5),
        all.quantile_ms(0.99),
        all.max_ms,
        period.as_secs_f64() * 1e3
    );
    println!(
        "memory: heap {heap0:.1} MB → {:.1} MB, resident {} → {}; allocations: {compass_allocs} inside the \
         compass's calls, {} elsewhere in the loop (the reports)",
        heap_mb(),
        mb(rss0),
        mb(rss_mb()),
        allocs - compass_allocs
    );
    println!(
        "heading: RMS error {:.4}° over {used} frames, {no_heading} without a heading",
        (sq_err / used.max(1) as f64).sqrt()
    );
    Ok(())
}
