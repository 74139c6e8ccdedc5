//! The README's locate targets (issue 33): north, latitude and longitude errors of
//! `bpins locate` on simulated time series, against the span (15 min to 4 h), the
//! season, the latitude (0° to 60°) and the field conditions, with the share of
//! errors within 2σ; and the plot `docs/locate.svg` (RMS error against span).
//!
//! ```sh
//! cargo run --release -p bpins-core --example locate_targets -- [SEEDS] [OUT.svg] [ROW]
//! ```
//! (defaults 8 seeds per row, `docs/locate.svg`; a few minutes on two cores; with ROW,
//! only the rows whose group or label contains it, and no plot). Per row, on stderr:
//! the per-frame elevation error against its 1σ, and the share within 2σ of the same
//! frames read as a Rayleigh sky (`sky_sun`'s step 5 left out), for comparison. Each
//! seed draws the longitude, the camera's heading, the start (09:00–11:00 local solar
//! time) and the noise; the day is drawn too except in the season rows. Camera: the
//! samples' 8 mm pinhole field of view on a 306 × 256 DoFP sensor (27.6 µm), 12-bit,
//! read noise 1 DN, K = 0.1 DN/e⁻; the sky Rayleigh's unless the row says otherwise.
//! Prints the table as Markdown.

use bpins_core::camera::Projection;
use bpins_core::conventions::{image_centre_px, wrap_deg_180};
use bpins_core::effects::{EffectSet, Model};
use bpins_core::internal::capture::{Capture, FrameSpec, LensSpec, SensorSpec};
use bpins_core::internal::heading::field::FieldOptions;
use bpins_core::internal::locate::{locate, measure_data, LocateOptions, Series, SunObs};
use bpins_core::internal::pipeline::SimSensor;
use bpins_core::internal::scene::{Draws, FieldAttitude, FieldScene};
use bpins_core::internal::sky::sun::SunPosition;
use bpins_core::sensor::{Geometry, Layout, DEFAULT_MOSAIC};
use std::fmt::Write as _;
use std::path::PathBuf;

/// One row of the table: what is simulated.
struct Row {
    group: &'static str,
    label: String,
    latitude_deg: f64,
    /// Day of 2026 (0 = 1 January), or None: drawn per seed.
    day: Option<f64>,
    every_min: f64,
    span_min: f64,
    model: Model,
    scene: Vec<&'static str>,
    attitude: Option<(f64, f64)>,
    yaw: Option<(f64, f64)>,
}

impl Row {
    fn new(group: &'static str, label: String, latitude_deg: f64) -> Row {
        Row {
            group,
            label,
            latitude_deg,
            day: None,
            every_min: 5.0,
            span_min: 60.0,
            model: Model::default(),
            scene: Vec::new(),
            attitude: None,
            yaw: None,
        }
    }
}

/// Errors and 1σ of one row over its seeds: (error, σ) for north, latitude, longitude.
#[derive(Default)]
struct Stats {
    errs: [Vec<(f64, f64)>; 3],
    refused: usize,
    /// Per frame: the sky's sun elevation error, its 1σ and the Rayleigh fit's error;
    /// the quartic sky's separation, degrees.
    elevation: Vec<(f64, f64, f64)>,
    separation: Vec<f64>,
    /// As `errs`, the frames read as a Rayleigh sky.
    rayleigh: [Vec<(f64, f64)>; 3],
}

impl Stats {
    fn rms(&self, k: usize) -> f64 {
        let e = &self.errs[k];
        (e.iter().map(|x| x.0 * x.0).sum::<f64>() / e.len().max(1) as f64).sqrt()
    }
    fn within(&self, k: usize) -> f64 {
        within(&self.errs[k])
    }
    fn median_sigma(&self, k: usize) -> f64 {
        let mut s: Vec<f64> = self.errs[k].iter().map(|x| x.1).collect();
        s.sort_by(f64::total_cmp);
        s.get(s.len() / 2).copied().unwrap_or(f64::NAN)
    }
}

/// The share of errors within 2σ.
fn within(e: &[(f64, f64)]) -> f64 {
    e.iter().filter(|x| x.0.abs() <= 2.0 * x.1).count() as f64 / e.len().max(1) as f64
}

fn base() -> Capture {
    let (w, h) = (306u32, 256u32);
    Capture {
        dir: PathBuf::new(),
        sensor: SensorSpec {
            colour: None,
            layout: Layout::Dofp { mosaic: DEFAULT_MOSAIC },
            geometry: Geometry { width_px: w, height_px: h, pixel_pitch_um: 27.6 },
            bit_depth: 12,
            black_level_dn: 64.0,
        },
        lens: LensSpec {
            projection: Projection::Pinhole,
            focal_length_mm: 8.0,
            principal_point_px: image_centre_px(w, h),
        },
        frames: vec![FrameSpec::new("frames/f000.png", SunPosition::given(0.0, 45.0))],
    }
}

fn run(row: &Row, seeds: u64) -> Result<Stats, Box<dyn std::error::Error>> {
    let mut st = Stats::default();
    for seed in 0..seeds {
        let d = Draws::keyed(seed, 0x7a26_e700, 0);
        let lon = -180.0 + 360.0 * d.uniform(0);
        let day = row.day.unwrap_or_else(|| (365.0 * d.uniform(1)).floor());
        let local_h = 9.0 + 2.0 * d.uniform(2);
        let t = 1_767_225_600.0 + day * 86_400.0 + (local_h - lon / 15.0) * 3600.0;
        let start = chrono::DateTime::from_timestamp(t as i64, 0).ok_or("time")?;
        let (yaw_step_deg, yaw_sigma_deg) = row.yaw.map_or((0.0, None), |(s, g)| (s, Some(g)));
        let s = Series {
            latitude_deg: row.latitude_deg,
            longitude_deg: lon,
            start_utc: start.to_rfc3339_opts(chrono::SecondsFormat::Secs, true),
            every_s: row.every_min * 60.0,
            span_s: row.span_min * 60.0,
            heading_deg: 360.0 * d.uniform(3),
            yaw_step_deg,
            yaw_sigma_deg,
            seed,
        };
        let mut field = FieldScene::new(seed);
        for spec in &row.scene {
            field.parse(spec)?;
        }
        let attitude = row.attitude.map_or(FieldAttitude::default(), |(t, imu)| FieldAttitude {
            tilt_random_deg: t,
            imu_sigma_deg: Some(imu),
            sun_sigma_deg: None,
            seed,
        });
        let field = (!field.is_empty()).then_some(field);
        let (c, data) = s.simulate(&base(), &row.model, field.as_ref(), &attitude, &SimSensor::samples(seed))?;
        let frames = measure_data(&c, &data, &Model::default(), &FieldOptions::default())?;
        let (truth, _) = s.frames("png")?;
        for (f, t) in frames.iter().zip(&truth) {
            if let Ok(sun) = &f.sun {
                let e = sun.elevation_deg - t.sun.elevation_deg;
                st.elevation.push((e, sun.elevation_sigma_deg, sun.rayleigh_elevation_deg - t.sun.elevation_deg));
                st.separation.push(sun.separation_deg);
            }
        }
        let obs: Vec<SunObs> = frames.iter().filter_map(|f| f.obs()).collect();
        let wide = LocateOptions {
            max_heading_sigma_deg: 90.0,
            max_latitude_sigma_deg: 90.0,
            max_longitude_sigma_deg: 180.0,
            pole_only: false,
        };
        // The same frames read as a Rayleigh sky (step 5 of sky_sun left out: the
        // separation held at 0), for comparison.
        let rayleigh: Vec<SunObs> = frames
            .iter()
            .filter_map(|f| {
                let sun = f.sun.as_ref().ok()?;
                Some(SunObs {
                    elevation_deg: sun.rayleigh_elevation_deg,
                    elevation_sigma_deg: sun.rayleigh_elevation_sigma_deg,
                    elevation_nuisance_sigma_deg: 0.0,
                    ..f.obs()?
                })
            })
            .collect();
        if let Ok(r) = locate(&rayleigh, &wide) {
            st.rayleigh[0].push((wrap_deg_180(r.heading_deg - s.heading_deg), r.heading_sigma_deg));
            st.rayleigh[1].push((r.latitude_deg - s.latitude_deg, r.latitude_sigma_deg));
            if let (Some(l), Some(sl)) = (r.longitude_deg, r.longitude_sigma_deg) {
                st.rayleigh[2].push((wrap_deg_180(l - s.longitude_deg), sl));
            }
        }
        match locate(&obs, &wide) {
            Ok(r) => {
                st.errs[0].push((wrap_deg_180(r.heading_deg - s.heading_deg), r.heading_sigma_deg));
                st.errs[1].push((r.latitude_deg - s.latitude_deg, r.latitude_sigma_deg));
                if let (Some(l), Some(sl)) = (r.longitude_deg, r.longitude_sigma_deg) {
                    st.errs[2].push((wrap_deg_180(l - s.longitude_deg), sl));
                }
            }
            Err(_) => st.refused += 1,
        }
    }
    Ok(st)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let seeds: u64 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(8);
    let out = args.next().unwrap_or_else(|| "docs/locate.svg".into());
    // Only the rows whose group or label contains this (all rows and the plot without).
    let only = args.next();
    let mid = 45.0;
    let mut rows = vec![Row::new("target", "45° N, every 5 min for 1 h".into(), mid)];
    for span in [15.0, 30.0, 60.0, 120.0, 240.0] {
        rows.push(Row { span_min: span, ..Row::new("span", format!("{span:.0} min"), mid) });
    }
    for (day, name) in [(78.0, "20 March"), (171.0, "21 June"), (264.0, "22 September"), (354.0, "21 December")] {
        rows.push(Row { day: Some(day), ..Row::new("season", name.into(), mid) });
    }
    for lat in [0.0, 15.0, 30.0, 60.0, -45.0] {
        rows.push(Row::new("latitude", format!("{lat:.0}°"), lat));
    }
    let mut berry = EffectSet::new();
    berry.set("sky_neutral_points", "separation_deg", 30.0)?;
    rows.push(Row { attitude: Some((10.0, 0.1)), ..Row::new("field", "tilted ≤ 10°, IMU 0.1°".into(), mid) });
    rows.push(Row {
        model: berry.model(),
        scene: vec!["sky_radiance"],
        ..Row::new("field", "Berry sky (neutral points 30° apart)".into(), mid)
    });
    rows.push(Row {
        scene: vec!["sky_radiance", "clouds.count=12"],
        ..Row::new("field", "12 scattered clouds".into(), mid)
    });
    rows.push(Row { yaw: Some((7.0, 0.05)), ..Row::new("field", "turning 7°/frame, gyro 0.05°".into(), mid) });
    println!("{seeds} seeds per row; RMS error (°), share within 2σ, median 1σ (°)\n");
    println!("| group | row | north RMS | lat RMS | lon RMS | within 2σ (N / lat / lon) | median 1σ (N / lat / lon) | refused |");
    println!("|---|---|---:|---:|---:|---|---|---:|");
    let mut span_points = Vec::new();
    for row in rows
        .iter()
        .filter(|r| only.as_ref().is_none_or(|o| r.group.contains(o.as_str()) || r.label.contains(o.as_str())))
    {
        let st = run(row, seeds)?;
        let n = st.elevation.len().max(1) as f64;
        let median = |mut v: Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
        };
        eprintln!(
            "{}: per frame, elevation error RMS {:.3}° (Rayleigh's {:.3}°), {:.0} % within 2σ, median 1σ {:.3}°, median separation {:.1}°",
            row.label,
            (st.elevation.iter().map(|x| x.0 * x.0).sum::<f64>() / n).sqrt(),
            (st.elevation.iter().map(|x| x.2 * x.2).sum::<f64>() / n).sqrt(),
            100.0 * st.elevation.iter().filter(|x| x.0.abs() <= 2.0 * x.1).count() as f64 / n,
            median(st.elevation.iter().map(|x| x.1).collect()),
            median(st.separation.clone()),
        );
        eprintln!(
            "{}: read as a Rayleigh sky, within 2σ {:.0} / {:.0} / {:.0} % over {} seeds",
            row.label,
            100.0 * within(&st.rayleigh[0]),
            100.0 * within(&st.rayleigh[1]),
            100.0 * within(&st.rayleigh[2]),
            st.rayleigh[0].len()
        );
        println!(
            "| {} | {} | {:.3} | {:.3} | {:.3} | {:.0} / {:.0} / {:.0} % | {:.3} / {:.3} / {:.3} | {} |",
            row.group,
            row.label,
            st.rms(0),
            st.rms(1),
            st.rms(2),
            100.0 * st.within(0),
            100.0 * st.within(1),
            100.0 * st.within(2),
            st.median_sigma(0),
            st.median_sigma(1),
            st.median_sigma(2),
            st.refused
        );
        if row.group == "span" {
            span_points.push((row.span_min, [st.rms(0), st.rms(1), st.rms(2)]));
        }
    }
    if only.is_none() {
        std::fs::write(&out, svg(&span_points))?;
        eprintln!("wrote {out}");
    }
    Ok(())
}

/// RMS error against span, log-log, one line per quantity.
fn svg(points: &[(f64, [f64; 3])]) -> String {
    let (w, h, l, r, t, b) = (560.0, 340.0, 70.0, 150.0, 30.0, 50.0);
    let (x0, x1) = (10f64.ln(), 300f64.ln());
    let (y0, y1) = (0.001f64.ln(), 3f64.ln());
    let px = |m: f64| l + (m.ln() - x0) / (x1 - x0) * (w - l - r);
    let py = |e: f64| h - b - (e.max(0.001).ln() - y0) / (y1 - y0) * (h - t - b);
    let mut s = String::new();
    let _ = write!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"12\">\n\
         <rect width=\"{w}\" height=\"{h}\" fill=\"white\"/>\n\
         <text x=\"{l}\" y=\"18\">bpins locate: RMS error against span (frames every 5 min, 45° N)</text>\n"
    );
    for m in [15.0, 30.0, 60.0, 120.0, 240.0] {
        let _ = writeln!(
            s,
            "<line x1=\"{0:.1}\" y1=\"{1}\" x2=\"{0:.1}\" y2=\"{2}\" stroke=\"#ddd\"/><text x=\"{0:.1}\" y=\"{3}\" text-anchor=\"middle\">{m:.0}</text>",
            px(m),
            t,
            h - b,
            h - b + 16.0
        );
    }
    for e in [0.001, 0.01, 0.1, 1.0] {
        let _ = writeln!(
            s,
            "<line x1=\"{l}\" y1=\"{0:.1}\" x2=\"{1}\" y2=\"{0:.1}\" stroke=\"#ddd\"/><text x=\"{2}\" y=\"{3:.1}\" text-anchor=\"end\">{e}°</text>",
            py(e),
            w - r,
            l - 6.0,
            py(e) + 4.0
        );
    }
    let _ =
        writeln!(s, "<text x=\"{:.1}\" y=\"{}\" text-anchor=\"middle\">span (min)</text>", (l + w - r) / 2.0, h - 8.0);
    for (k, (name, colour)) in
        [("north", "#1f77b4"), ("latitude", "#d62728"), ("longitude", "#2ca02c")].iter().enumerate()
    {
        let pts: Vec<String> = points.iter().map(|(m, e)| format!("{:.1},{:.1}", px(*m), py(e[k]))).collect();
        let _ = writeln!(
            s,
            "<polyline fill=\"none\" stroke=\"{colour}\" stroke-width=\"2\" points=\"{}\"/>",
            pts.join(" ")
        );
        let y = t + 20.0 + 18.0 * k as f64;
        let _ = writeln!(
            s,
            "<line x1=\"{0}\" y1=\"{y}\" x2=\"{1}\" y2=\"{y}\" stroke=\"{colour}\" stroke-width=\"2\"/><text x=\"{2}\" y=\"{3}\">{name}</text>",
            w - r + 10.0,
            w - r + 30.0,
            w - r + 36.0,
            y + 4.0
        );
    }
    s.push_str("</svg>\n");
    s
}
