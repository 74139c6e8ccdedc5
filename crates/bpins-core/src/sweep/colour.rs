//! A colour-polarization sensor's sweep (`[sensor] colour_tiles`, docs/colour.md): each
//! trial rendered as the colour mosaic (every pixel through the frame of the band
//! over it: [`crate::simulate::render_colour_mosaic`], the chain `bpins simulate
//! --colour-tiles` and the colour compass read) and read band by band: each 2 × 2
//! analyzer tile lies under one filter, so each superpixel is one band's, and a band's
//! heading sums take its own superpixels only. Each band gives its own heading (the
//! plain extractors, with their 1σ); the fused heading is the bands' inverse-variance
//! mean.
//!
//! A colour trial's record carries, per extractor and variant, four columns in this
//! order: R, G, B, fused ([`BandColumn`]); a monochrome sensor's carries one
//! (`None`), so its records, rows and files are what they were.

use rayon::prelude::*;

use super::spec::SweepSpec;
use crate::chain::ChainFrame;
use crate::conventions::wrap_deg_180;
use crate::heading::{HeadingContext, HeadingEstimate, HeadingSums, RowScratch};
use crate::recon::{superpixel_stokes_row, Reconstructor};
use crate::sensor::{Band, Channel, ColourTiles};
use crate::stokes::Stokes;

/// What one column of a colour sensor's record holds: one band's heading error, or the
/// fused heading's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BandColumn {
    Band(Band),
    Fused,
}

impl BandColumn {
    /// The columns of a colour sensor's record, in record order.
    pub const ALL: [BandColumn; 4] =
        [BandColumn::Band(Band::R), BandColumn::Band(Band::G), BandColumn::Band(Band::B), BandColumn::Fused];

    /// `R`, `G`, `B` or `fused`, as the outputs' `band` field writes it.
    pub fn name(self) -> &'static str {
        match self {
            BandColumn::Band(b) => b.name(),
            BandColumn::Fused => "fused",
        }
    }

    /// The column named `name` ([`Self::name`]).
    pub fn from_name(name: &str) -> Option<BandColumn> {
        BandColumn::ALL.into_iter().find(|c| c.name() == name)
    }
}

/// The band columns of every (extractor, variant) of `spec`'s records: `[None]` for a
/// monochrome sensor, [`BandColumn::ALL`] for a colour one.
pub fn band_columns(spec: &SweepSpec) -> Vec<Option<BandColumn>> {
    match spec.sensor.colour {
        None => vec![None],
        Some(_) => BandColumn::ALL.iter().map(|&c| Some(c)).collect(),
    }
}

/// One pass over a colour trial's pixels: its three band frames (by
/// [`Band::index`]), one inversion, the contexts.
#[derive(Clone, Copy, Debug)]
pub struct ColourSumsJob<'a> {
    pub frames: &'a [ChainFrame; 3],
    pub rec: &'a Reconstructor,
    pub contexts: &'a [HeadingContext],
}

/// Each band's heading sums (by [`Band::index`]) of a colour DoFP frame `w × h`, one
/// set per context: the colour mosaic as `render_colour_mosaic` renders it, its 2 × 2
/// superpixels as `mosaic_heading_sums` reads them (`rec`, samples outside (0,
/// `full_scale_dn`) masked), each superpixel added to the sums of the band over its
/// tile, tile (i, j) under `tiles.tiles[j mod 2][i mod 2]` (CONVENTIONS.md): along a
/// tile row the even tiles are one band's and the odd ones one band's, so each is
/// summed as a row of its own (every other superpixel, 4 px apart). Rows are added in
/// row order (bit-identical whatever the thread count).
#[allow(clippy::too_many_arguments)]
pub fn colour_heading_sums(
    frames: &[ChainFrame; 3],
    w: usize,
    h: usize,
    mosaic: &[[Channel; 2]; 2],
    tiles: &ColourTiles,
    rec: &Reconstructor,
    full_scale_dn: f64,
    contexts: &[HeadingContext],
) -> Vec<[HeadingSums; 3]> {
    let dn = crate::simulate::render_colour_mosaic(frames, w, h, mosaic, tiles);
    colour_mosaic_heading_sums(&dn, w, h, mosaic, tiles, rec, full_scale_dn, contexts)
}

/// [`colour_heading_sums`] of a colour mosaic already rendered (`dn`, `w × h` DN,
/// row-major): each band's sums per context. Its WGSL twin (`bpins-gpu`'s
/// `Gpu::colour_mosaic_heading_sums`, `colour_mosaic_heading_sums` in
/// `shaders/kernels/sums.wgsl`) sums the GPU colour sweep's mosaics on the device;
/// `tests/gpu_parity.rs` compares the two on the same mosaics.
#[allow(clippy::too_many_arguments)]
pub fn colour_mosaic_heading_sums(
    dn: &[f32],
    w: usize,
    h: usize,
    mosaic: &[[Channel; 2]; 2],
    tiles: &ColourTiles,
    rec: &Reconstructor,
    full_scale_dn: f64,
    contexts: &[HeadingContext],
) -> Vec<[HeadingSums; 3]> {
    let (tw, th) = (w / 2, h / 2);
    let rows: Vec<Vec<[HeadingSums; 3]>> = (0..th)
        .into_par_iter()
        .map_init(
            || (vec![Stokes::default(); tw], [Vec::new(), Vec::new()], RowScratch::default()),
            |(stokes, parity, scratch), j| {
                let (top, bottom) = (&dn[2 * j * w..][..w], &dn[(2 * j + 1) * w..][..w]);
                superpixel_stokes_row(top, bottom, mosaic, rec, full_scale_dn, stokes);
                // The even and the odd tiles of the row, each under one band.
                for (k, p) in parity.iter_mut().enumerate() {
                    p.clear();
                    p.extend(stokes.iter().skip(k).step_by(2));
                }
                // Superpixel i sits at x = 0.5 + 2i px (PolImage::position_px(i, j) of a
                // superpixel image): the even ones from 0.5 px, the odd from 2.5, 4 px apart.
                let y = 0.5 + 2.0 * j as f64;
                contexts
                    .iter()
                    .map(|ctx| {
                        let mut acc = [HeadingSums::default(); 3];
                        for (k, p) in parity.iter().enumerate() {
                            let b = tiles.tiles[j & 1][k].index();
                            let x0 = 0.5 + 2.0 * k as f64;
                            acc[b].accumulate_row(ctx, HeadingSums::cos_2band(ctx), y, x0, 4.0, p, scratch);
                        }
                        acc
                    })
                    .collect()
            },
        )
        .collect();
    let mut total = vec![[HeadingSums::default(); 3]; contexts.len()];
    for row in rows {
        for (t, r) in total.iter_mut().zip(row) {
            for (a, b) in t.iter_mut().zip(r) {
                *a += b;
            }
        }
    }
    total
}

/// The fused heading of the bands' estimates (by [`Band::index`]; `None` where a band
/// gave none), degrees in [0°, 360°): [`fused_estimate`]'s heading. The colour
/// compass's fusion (`compass/colour.rs`) weighs its bands the same way (by the
/// independent data term); its shared part enters the fused 1σ only, which a sweep
/// does not record, so the fused heading is the same with or without it.
pub fn fuse(estimates: &[Option<HeadingEstimate>; 3]) -> Option<f64> {
    fused_estimate(estimates).map(|e| e.heading_deg)
}

/// The fused estimate of the bands' plain estimates (by [`Band::index`]; `None` where
/// a band gave none): the sweep's fused column and `bpins heading --estimator plain`'s
/// `fused` row. `None` where no band answered.
///
/// ```text
/// w_b = 1/σ_b²                        σ_b the band's own statistical 1σ (the plain extractors'), degrees
/// ψ   = ψ₁ + Σ w_b·wrap(ψ_b − ψ₁) / Σ w_b    offsets from the first band's ψ₁, wrapped to ±180°
/// σ   = 1/√(Σ w_b)                    the bands' noise independent (each its own pixels)
/// ```
///
/// Equal weights where any answering band's σ is not a positive finite number; σ is
/// then the equal-weight mean's, √(Σ σ_b²)/n. `samples` is the bands' sum. The 1σ is
/// statistical only, as the monochrome plain estimator's: the pixel noise of each
/// band, independent between bands because each band reads its own pixels. What the
/// bands share (the reference tilt, the sun, the camera model, a sky that is not
/// Rayleigh's) moves every band's heading alike, is in no band's σ and so not in the
/// fused one either; the field estimator's fusion carries it (`compass/colour.rs`).
/// Units: degrees. Cannot: widen σ where the bands disagree beyond their noise (no
/// Birge ratio: the plain 1σ stays the seed paper's statistical one).
pub fn fused_estimate(estimates: &[Option<HeadingEstimate>; 3]) -> Option<HeadingEstimate> {
    let ok: Vec<&HeadingEstimate> = estimates.iter().flatten().collect();
    let first = ok.first()?.heading_deg;
    let weighted = ok.iter().all(|e| e.sigma_deg.is_finite() && e.sigma_deg > 0.0);
    let (mut sw, mut swx) = (0.0, 0.0);
    for e in &ok {
        let w = if weighted { 1.0 / (e.sigma_deg * e.sigma_deg) } else { 1.0 };
        sw += w;
        swx += w * wrap_deg_180(e.heading_deg - first);
    }
    let sigma_deg = if weighted {
        1.0 / sw.sqrt()
    } else {
        ok.iter().map(|e| e.sigma_deg * e.sigma_deg).sum::<f64>().sqrt() / ok.len() as f64
    };
    Some(HeadingEstimate {
        heading_deg: (first + swx / sw).rem_euclid(360.0),
        sigma_deg,
        samples: ok.iter().map(|e| e.samples).sum(),
    })
}

#[cfg(test)]
mod tests {
    use super::super::run::{run_units, unit_count, CpuSums, Shard};
    use super::super::stats::{summarise, Row};
    use super::super::store::{merge, run_to_dir};
    use super::*;
    use std::path::Path;

    /// A 96 × 80 px colour DoFP sensor (RGGB), one sun, pixel noise: seconds.
    const COLOUR_TINY: &str = r#"
format = "bpins-sweep/1"
seed = 11
trials = 6
extractors = ["sun_vector", "meridian_line"]
[sensor]
layout = "dofp"
width_px = 96
height_px = 80
pixel_pitch_um = 27.6
colour_tiles = [["R", "G"], ["G", "B"]]
[lens]
projection = "pinhole"
focal_length_mm = 4.0
[sky]
sun_elevations_deg = [30]
sun_azimuths_deg = [10, 40, 70]
trials_per_azimuth = 2
[response]
peak_dn = 1000.0
[[errors]]
source = "rotation"
param = "array_rotation.dtheta_deg"
distribution = "normal"
sigma = 0.1
[[errors]]
source = "noise"
param = "sensor.read_noise_dn"
distribution = "normal"
sigma = 3.0
per = "pixel"
"#;

    fn spec(text: &str) -> SweepSpec {
        SweepSpec::parse(Path::new("colour.toml"), text).unwrap()
    }

    fn rows_of(s: &SweepSpec) -> Vec<Row> {
        summarise(s, &run_units(s, 0..unit_count(s), &CpuSums, &|_, _| {}).unwrap()).rows
    }

    fn row<'a>(rows: &'a [Row], source: &str, extractor: &str, band: &str) -> &'a Row {
        rows.iter()
            .find(|r| r.source == source && r.extractor == extractor && r.band.as_deref() == Some(band))
            .unwrap_or_else(|| panic!("no row {source} {extractor} {band}"))
    }

    /// A tiny colour sweep: a row per band and a fused one for every source and
    /// extractor, every trial answered, the fused error within the bands' (never worse
    /// than the worst band), and the bands' errors their own (not one mono read).
    #[test]
    fn a_colour_sweep_gives_each_band_and_the_fused_heading() {
        let s = spec(COLOUR_TINY);
        let rows = rows_of(&s);
        // rotation, noise and combined, two extractors, one elevation, four band columns.
        assert_eq!(rows.len(), 3 * 2 * 4);
        for ex in ["sun_vector", "meridian_line"] {
            let bands: Vec<&Row> = ["R", "G", "B"].iter().map(|b| row(&rows, "noise", ex, b)).collect();
            let fused = row(&rows, "noise", ex, "fused");
            assert!(bands.iter().chain([&fused]).all(|r| r.trials == 6 && r.failed == 0), "{ex}");
            let worst = bands.iter().map(|r| r.rms_deg).fold(0.0, f64::max);
            assert!(fused.rms_deg <= worst, "{ex}: fused {} worse than the worst band {worst}", fused.rms_deg);
            // Trial by trial the fused error lies within the bands' (a weighted mean).
            for t in 0..6 {
                let (lo, hi) =
                    bands.iter().map(|r| r.errors_deg[t]).fold((f64::MAX, f64::MIN), |(a, b), e| (a.min(e), b.max(e)));
                assert!(fused.errors_deg[t] >= lo - 1e-12 && fused.errors_deg[t] <= hi + 1e-12, "{ex} trial {t}");
            }
            // Each band reads its own pixels: three different sets of errors.
            assert!(bands[0].errors_deg != bands[1].errors_deg && bands[1].errors_deg != bands[2].errors_deg);
        }
    }

    /// A blue-only weak grid (`band_response.eps_b` = 0.3: the blue band's DoLP ×
    /// 0.7/1.3) moves the blue row alone: R and G read the same pixels bit for bit, B's
    /// noise-driven error grows with its smaller DoLP.
    #[test]
    fn a_blue_only_extinction_shows_in_the_blue_row() {
        let clean = spec(COLOUR_TINY);
        let blue = spec(&format!(
            "{COLOUR_TINY}[[errors]]\nsource = \"noise\"\nparam = \"band_response.eps_b\"\ndistribution = \"fixed\"\nvalue = 0.3\n"
        ));
        let (a, b) = (rows_of(&clean), rows_of(&blue));
        for ex in ["sun_vector", "meridian_line"] {
            for band in ["R", "G"] {
                assert_eq!(row(&a, "noise", ex, band).errors_deg, row(&b, "noise", ex, band).errors_deg, "{ex} {band}");
            }
            let (ra, rb) = (row(&a, "noise", ex, "B"), row(&b, "noise", ex, "B"));
            assert!(rb.rms_deg > 1.2 * ra.rms_deg, "{ex}: B's RMS {} → {}", ra.rms_deg, rb.rms_deg);
        }
    }

    /// Shards of a colour sweep merge into the whole run bit for bit (trials.csv read
    /// back band by band); its files carry the band, a monochrome sweep's do not.
    #[test]
    fn colour_shards_merge_bit_for_bit_and_the_files_name_the_band() {
        let s = spec(COLOUR_TINY.replacen("trials = 6", "trials = 3", 1).as_str());
        let t = tempfile::tempdir().unwrap();
        let whole = t.path().join("whole");
        run_to_dir(&s, Shard::WHOLE, &CpuSums, &whole, &|_, _| {}).unwrap();
        let dirs: Vec<_> = (0..2)
            .map(|i| {
                let d = t.path().join(format!("s{i}"));
                run_to_dir(&s, Shard { index: i, count: 2 }, &CpuSums, &d, &|_, _| {}).unwrap();
                d
            })
            .collect();
        let merged = t.path().join("merged");
        merge(&dirs, &merged).unwrap();
        for f in ["summary.json", "summary.csv", "budget.csv", "trials.csv", "report.html"] {
            assert_eq!(std::fs::read(whole.join(f)).unwrap(), std::fs::read(merged.join(f)).unwrap(), "{f}");
        }
        let csv = std::fs::read_to_string(whole.join("summary.csv")).unwrap();
        assert!(csv.starts_with("source,extractor,sun_elevation_deg,known,band,mean_deg"), "{csv}");
        assert!(csv.lines().any(|l| l.starts_with("noise,sun_vector,30,,fused,")), "{csv}");
        let trials = std::fs::read_to_string(whole.join("trials.csv")).unwrap();
        assert_eq!(trials.lines().count(), 1 + 3 * 3 * 2 * 4, "header + sources × trials × extractors × bands");
        let json = std::fs::read_to_string(whole.join("summary.json")).unwrap();
        assert!(json.contains("\"band\": \"fused\"") && json.contains("\"band\": \"B\""));
        // A budget per extractor and band, each of the two sources.
        let v: serde_json::Value = serde_json::from_str(&json).unwrap();
        let budget = v["budget"].as_array().unwrap();
        assert_eq!(budget.len(), 2 * 4);
        assert!(budget.iter().all(|b| b["band"].is_string() && b["shares"].as_array().unwrap().len() == 2));
        // A monochrome sweep's rows carry no band.
        let mono = spec(&COLOUR_TINY.replacen("colour_tiles = [[\"R\", \"G\"], [\"G\", \"B\"]]", "", 1));
        assert!(rows_of(&mono).iter().all(|r| r.band.is_none()));
    }

    /// Each superpixel goes to its own band's sums: at neutral bands the three sets add
    /// up to the monochrome read of the same (bitwise equal) mosaic, and a blue gain of 2
    /// multiplies the blue sums' scatter (weighted by P², DN²) by 4 and leaves R's and
    /// G's bit for bit.
    #[test]
    fn each_superpixel_is_summed_in_its_own_band() {
        use super::super::run::{peak, TrialSetup, Unit};
        let s = spec(COLOUR_TINY);
        let (w, h) = s.size_px();
        let (crate::sensor::Layout::Dofp { mosaic }, Some(tiles)) = (&s.sensor.layout, &s.sensor.colour) else {
            panic!("a colour DoFP sensor")
        };
        let sums = |s: &SweepSpec, source: usize| {
            let p = peak(s, 30.0, 10.0);
            let t = TrialSetup::new(s, Unit { elevation: 0, source, trial: 0 }, p).unwrap();
            let (rec, ctx) = (&t.readings[0].rec, &t.readings[0].contexts[0]);
            let bands = colour_heading_sums(t.band_frames.as_deref().unwrap(), w, h, mosaic, tiles, rec, 1e9, &[*ctx]);
            let mono = crate::simulate::mosaic_heading_sums(&t.frame, w, h, mosaic, rec, 1e9, ctx);
            (bands[0], mono)
        };
        // Source 1 (pixel noise): the noise is the bands' shared one.
        let (bands, mono) = sums(&s, 1);
        assert_eq!(bands.iter().map(|b| b.n).sum::<f64>(), mono.n);
        assert!(bands.iter().all(|b| b.n > 0.0));
        assert_eq!(bands[1].n, bands[0].n + bands[2].n, "G has half the superpixels");
        for k in 0..6 {
            let total: f64 = bands.iter().map(|b| b.scatter[k]).sum();
            assert!((total - mono.scatter[k]).abs() <= 1e-9 * mono.scatter[0].abs(), "scatter {k}");
        }
        let blue = spec(&format!(
            "{COLOUR_TINY}[[errors]]\nsource = \"rotation\"\nparam = \"band_response.qe_b\"\ndistribution = \"fixed\"\nvalue = 2.0\n"
        ));
        // Source 0 (rotation, noise-free), with and without the blue gain.
        let ((a, _), (b, _)) = (sums(&s, 0), sums(&blue, 0));
        assert_eq!((a[0], a[1]), (b[0], b[1]));
        for k in 0..6 {
            assert!((b[2].scatter[k] - 4.0 * a[2].scatter[k]).abs() <= 1e-9 * a[2].scatter[0], "scatter {k}");
        }
    }

    #[test]
    fn an_engine_without_colour_refuses_a_colour_sweep_before_writing_anything() {
        struct NoColour;
        impl super::super::run::SumsEngine for NoColour {
            fn name(&self) -> &str {
                "gpu"
            }
            fn heading_sums(
                &self,
                jobs: &[super::super::run::SumsJob],
                layout: &crate::sensor::Layout,
                w: usize,
                h: usize,
                full: f64,
            ) -> crate::error::Result<Vec<Vec<HeadingSums>>> {
                CpuSums.heading_sums(jobs, layout, w, h, full)
            }
        }
        let s = spec(COLOUR_TINY);
        let e = run_units(&s, 0..1, &NoColour, &|_, _| {}).unwrap_err().to_string();
        assert!(e.contains("colour_tiles") && e.contains("--backend cpu"), "{e}");
        // Refused before the output folder is made.
        let t = tempfile::tempdir().unwrap();
        let out = t.path().join("out");
        let e = run_to_dir(&s, Shard::WHOLE, &NoColour, &out, &|_, _| {}).unwrap_err().to_string();
        assert!(e.contains("colour_tiles") && !out.exists(), "{e}");
        // The CPU's empty answer is no refusal.
        assert!(super::super::run::check_engine(&s, &CpuSums).is_ok());
    }

    fn est(heading_deg: f64, sigma_deg: f64) -> Option<HeadingEstimate> {
        Some(HeadingEstimate { heading_deg, sigma_deg, samples: 10 })
    }

    #[test]
    fn the_fused_heading_is_the_inverse_variance_mean_across_north() {
        // 359° (σ 1) and 1° (σ 1): 0°, not 180°.
        let f = fuse(&[est(359.0, 1.0), est(1.0, 1.0), None]).unwrap();
        assert!(wrap_deg_180(f).abs() < 1e-12, "{f}");
        // σ 1 against σ 2: weights 4 : 1.
        let f = fuse(&[est(10.0, 1.0), None, est(15.0, 2.0)]).unwrap();
        assert!((f - 11.0).abs() < 1e-12, "{f}");
        // A σ of zero: equal weights.
        let f = fuse(&[est(10.0, 0.0), est(20.0, 1.0), est(30.0, 1.0)]).unwrap();
        assert!((f - 20.0).abs() < 1e-12, "{f}");
        assert_eq!(fuse(&[None, None, None]), None);
        // The fused 1σ: 1/√Σ(1/σ_b²) (σ 1 and 2: 1/√1.25), below every band's; the
        // samples the bands'.
        let f = fused_estimate(&[est(10.0, 1.0), None, est(15.0, 2.0)]).unwrap();
        assert!((f.sigma_deg - 1.25f64.sqrt().recip()).abs() < 1e-12 && f.samples == 20, "{f:?}");
        let f = fused_estimate(&[est(10.0, 0.3), est(11.0, 0.3), est(12.0, 0.3)]).unwrap();
        assert!((f.sigma_deg - 0.3 / 3f64.sqrt()).abs() < 1e-12 && (f.heading_deg - 11.0).abs() < 1e-12, "{f:?}");
        // Equal weights: the equal-weight mean's √(Σσ²)/n.
        let f = fused_estimate(&[est(10.0, 0.0), est(20.0, 3.0), est(30.0, 4.0)]).unwrap();
        assert!((f.sigma_deg - 5.0 / 3.0).abs() < 1e-12, "{f:?}");
        assert_eq!(BandColumn::from_name("fused"), Some(BandColumn::Fused));
        assert_eq!(BandColumn::from_name("B"), Some(BandColumn::Band(Band::B)));
        assert_eq!(BandColumn::from_name("b"), None);
    }
}
