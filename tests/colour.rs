//! Colour-polarization captures (samples/colour-clear, an IMX250MYR-like RGGB layout
//! made by an independent implementation of the spec): `heading` reads each band from
//! its own pixels and fuses the bands; `maps` writes each band's maps; `fit` and
//! `diagnose` model each pixel through its band (`crates/bpins-core/tests/colour_fit.rs`);
//! the plain estimator reads each band and fuses them, `locate` reads the green band;
//! and the frames are never read as monochrome when the `colour_tiles` key is deleted
//! (read as mono the plain estimator is off by 0.24° RMS at up to 3.1σ on this capture).

mod common;
use common::*;
use std::fs;

const COLOUR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/samples/colour-clear");

#[test]
fn every_band_of_the_colour_sample_reads_its_heading_and_the_fused_one_is_honest() {
    let tmp = tempfile::tempdir().unwrap();
    let json = tmp.path().join("colour.json");
    bpins(&["heading", COLOUR, "--json", &s(&json)]).ok();
    let v: serde_json::Value = serde_json::from_slice(&fs::read(&json).unwrap()).unwrap();
    let rows = v["frames"].as_array().unwrap();
    let of = |band: &str| -> Vec<(f64, f64)> {
        rows.iter()
            .filter(|r| r["band"] == band)
            .map(|r| (r["error_deg"].as_f64().unwrap(), r["sigma_deg"].as_f64().unwrap()))
            .collect()
    };
    for band in ["fused", "R", "G", "B"] {
        let e = of(band);
        assert_eq!(e.len(), 4, "{band}: {v}");
        // The truth within 3σ every frame (the sample's noise: hundredths of a degree).
        for (err, sigma) in &e {
            assert!(err.abs() < 3.0 * sigma && err.abs() < 0.06, "{band}: error {err}°, 1σ {sigma}°");
        }
    }
    // The fused heading's 1σ lies within the bands' (the floor, shared by all, dominates
    // here, and bands that disagree beyond their noise widen it), and its error is no
    // larger than the worst band's.
    for i in 0..4 {
        let fused = of("fused")[i];
        let bands: Vec<(f64, f64)> = ["R", "G", "B"].iter().map(|b| of(b)[i]).collect();
        let widest = bands.iter().map(|b| b.1).fold(0.0, f64::max);
        assert!(fused.1 <= widest, "frame {i}: fused 1σ {} over every band's (widest {widest})", fused.1);
        let worst = bands.iter().map(|b| b.0.abs()).fold(0.0, f64::max);
        assert!(fused.0.abs() <= worst, "frame {i}");
    }
    // One summary line per band.
    let bands: Vec<&str> = v["summary"].as_array().unwrap().iter().map(|x| x["band"].as_str().unwrap()).collect();
    assert_eq!(bands, ["fused", "R", "G", "B"]);
}

/// `heading --estimator plain` reads a colour capture band by band (it refused one
/// before): a row per band and a fused one per frame, as the field route's; each band's
/// sun_vector heading near the truth within its statistical 1σ; the fused 1σ the bands'
/// inverse-variance one, below every band's; `--recon superpixel` each band's tiles
/// with every channel moved to its tile's centre (as the tile reads them, the sky's
/// gradient across it biased G by up to 0.13° here; now within 0.003°).
#[test]
fn the_plain_estimator_reads_each_band_of_the_colour_sample_and_fuses_them() {
    let tmp = tempfile::tempdir().unwrap();
    let json = tmp.path().join("plain.json");
    bpins(&["heading", COLOUR, "--estimator", "plain", "--json", &s(&json)]).ok();
    let v = read_json(&json);
    assert_eq!((v["estimator"].as_str(), v["recon"].as_str()), (Some("plain"), Some("demosaic")));
    let rows = v["frames"].as_array().unwrap();
    assert_eq!(rows.len(), 4 * 4, "a fused row and three band rows per frame");
    let of = |band: &str| -> Vec<(f64, f64, u64)> {
        rows.iter()
            .filter(|r| r["band"] == band)
            .map(|r| (f64_of(r, "error_deg"), f64_of(r, "sigma_deg"), r["samples"].as_u64().unwrap()))
            .collect()
    };
    // The truth within 3σ every frame (measured: R, the dimmest band, up to 2.5σ; its 1σ
    // statistical, widened by the design effect of the band's interpolated samples).
    for band in ["fused", "R", "G", "B"] {
        for (i, (err, sigma, _)) in of(band).into_iter().enumerate() {
            assert!(err.abs() < 3.0 * sigma && err.abs() < 0.03, "{band} frame {i}: error {err}°, 1σ {sigma}°");
        }
    }
    for i in 0..4 {
        let (fused, bands) = (of("fused")[i], ["R", "G", "B"].map(|b| of(b)[i]));
        let inverse = bands.iter().map(|b| b.1.powi(-2)).sum::<f64>().sqrt().recip();
        assert!((fused.1 - inverse).abs() < 1e-12 && bands.iter().all(|b| fused.1 < b.1), "frame {i}");
        // G has two tiles of four, R and B one each; the fused row counts them all.
        assert_eq!((bands[1].2, bands[0].2 + bands[1].2 + bands[2].2), (2 * bands[0].2, fused.2), "frame {i}");
        assert_eq!(bands[0].2, bands[2].2, "frame {i}");
    }
    let bands: Vec<&str> = v["summary"].as_array().unwrap().iter().map(|x| x["band"].as_str().unwrap()).collect();
    assert_eq!(bands, ["fused", "R", "G", "B"]);
    // The superpixel route: each band's tiles, every channel moved to its tile's centre.
    let sp = tmp.path().join("superpixel.json");
    bpins(&["heading", COLOUR, "--estimator", "plain", "--recon", "superpixel", "--json", &s(&sp)]).ok();
    let sp = read_json(&sp);
    let rows = |band: &str| -> Vec<(f64, f64)> {
        let f = sp["frames"].as_array().unwrap().iter().filter(|r| r["band"] == band);
        f.map(|r| (f64_of(r, "error_deg"), f64_of(r, "sigma_deg"))).collect()
    };
    let (g, fused) = (rows("G"), rows("fused"));
    assert!(g.len() == 4 && g.iter().all(|e| e.0.abs() < 0.01), "G: {g:?}");
    assert!(fused.len() == 4 && fused.iter().all(|e| e.0.abs() < 2.0 * e.1), "fused: {fused:?}");
}

/// `locate` reads a colour capture (it refused one before) through its green band: an
/// hour of stamped frames of a turning colour camera, located within 2σ of the truth and
/// of the clear-sky targets, as the monochrome camera of the same pixels is.
#[test]
fn locate_reads_a_colour_capture_through_its_green_band() {
    let tmp = tempfile::tempdir().unwrap();
    let common = [
        "--width-px",
        "306",
        "--height-px",
        "256",
        "--pixel-pitch-um",
        "27.6",
        "--time-utc",
        "2026-06-21T01:00:00Z",
        "--latitude-deg",
        "36.07",
        "--longitude-deg",
        "120.38",
        "--headings-deg",
        "30",
        "--every-min",
        "5",
        "--span-min",
        "60",
        "--yaw-step-deg",
        "7",
        "--yaw-sigma-deg",
        "0.05",
    ];
    for colour in [true, false] {
        let cap = tmp.path().join(if colour { "colour" } else { "mono" });
        let mut args = vec!["simulate", "--out", cap.to_str().unwrap()];
        if colour {
            args.extend(["--colour-tiles", "RGGB"]);
        }
        args.extend(common);
        bpins(&args).ok();
        let json = tmp.path().join("locate.json");
        let r = bpins(&["locate", &s(&cap), "--truth", &s(&cap.join("truth.toml")), "--json", &s(&json)]).ok();
        assert!(r.stdout.contains("route stamped: 13 frames over 60 min"), "{}", r.stdout);
        let v = read_json(&json);
        let l = &v["located"];
        for (key, sigma, target) in [
            ("heading_deg", "heading_sigma_deg", 0.2),
            ("latitude_deg", "latitude_sigma_deg", 0.5),
            ("longitude_deg", "longitude_sigma_deg", 0.5),
        ] {
            let e = f64_of(&v["errors"], key);
            assert!(e.abs() < target && e.abs() < 2.0 * f64_of(l, sigma), "colour {colour}: {key}: error {e} ({l})");
        }
    }
}

/// `bpins maps` on a colour capture: each band's four maps as layers named with the
/// band, the same numbers as `bpins_core::colour_maps` on the frame's mosaic.
#[test]
fn maps_of_a_colour_capture_are_each_bands_kernel_maps() {
    use bpins_core::internal::capture::{read_exr_layers, Capture, FrameData};
    use bpins_core::internal::heading::field::RawImage;
    use bpins_core::sensor::{Channel, DEFAULT_MOSAIC};
    use bpins_core::{colour_maps, Interpolation, MapsConfig, Reconstructor};
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("maps");
    for (route, size) in [("opencv", (408, 340)), ("opencv_ea", (408, 340)), ("superpixel", (102, 85))] {
        bpins(&["maps", COLOUR, "--out", &s(&out), "--frames", "1", "--interpolation", route])
            .ok()
            .stderr_has(&format!("({} × {} px", size.0, size.1))
            .stderr_has("bands R, G, B");
        let c = Capture::load(COLOUR.as_ref()).unwrap();
        let FrameData::Mosaic { dn, width_px, height_px } = c.read_frame(1).unwrap() else { panic!("a DoFP sample") };
        let rec = Reconstructor::new(&Default::default(), c.sensor.black_level_dn, &Channel::ALL).unwrap();
        let cfg = MapsConfig {
            interpolation: Interpolation::from_name(route).unwrap(),
            mosaic: DEFAULT_MOSAIC,
            full_scale_dn: c.sensor.full_scale_dn(),
            aoe_centre_px: [c.lens.principal_point_px.0, c.lens.principal_point_px.1],
        };
        let tiles = c.sensor.colour.clone().unwrap();
        let raw = RawImage::packed(&dn, width_px as usize, height_px as usize);
        let want = colour_maps(&raw, &rec, &cfg, &tiles).unwrap();
        let (gw, gh, got) = read_exr_layers(&out.join("f1_maps.exr")).unwrap();
        assert_eq!((gw as usize, gh as usize), size);
        assert_eq!(got.len(), 12, "four maps of three bands");
        let layer = |name: &str| &got.iter().find(|(n, _)| n == name).unwrap_or_else(|| panic!("{name}")).1;
        let same = |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(x, y)| x == y || (x.is_nan() && y.is_nan()));
        for m in &want {
            let b = m.band.name();
            assert!(same(layer(&format!("AoP_deg_{b}")), &m.maps.aop_deg), "{route} {b}");
            assert!(same(layer(&format!("DoLP_{b}")), &m.maps.dolp), "{route} {b}");
            assert!(same(layer(&format!("I_dn_{b}")), &m.maps.intensity_dn), "{route} {b}");
            assert!(same(layer(&format!("AoE_deg_{b}")), &m.maps.aoe_deg), "{route} {b}");
        }
    }
}

#[test]
fn a_colour_mosaic_read_as_monochrome_is_refused_and_names_the_frame() {
    let tmp = tempfile::tempdir().unwrap();
    let cap = tmp.path().join("colour-as-mono");
    fs::create_dir_all(cap.join("frames")).unwrap();
    for f in fs::read_dir(format!("{COLOUR}/frames")).unwrap() {
        let f = f.unwrap();
        fs::copy(f.path(), cap.join("frames").join(f.file_name())).unwrap();
    }
    let toml = fs::read_to_string(format!("{COLOUR}/capture.toml")).unwrap();
    let mono: String = toml.lines().filter(|l| !l.starts_with("colour_tiles")).map(|l| format!("{l}\n")).collect();
    assert_ne!(mono, toml);
    fs::write(cap.join("capture.toml"), mono).unwrap();
    for estimator in ["plain", "field"] {
        bpins(&["heading", &s(&cap), "--estimator", estimator])
            .fails()
            .stderr_has("frames[0] (frames/f000.png)")
            .stderr_has("4-pixel period")
            .stderr_has("colour_tiles");
    }
    // A monochrome capture of the same spec passes the same test.
    bpins(&["heading", concat!(env!("CARGO_MANIFEST_DIR"), "/samples/clean")]).ok();
}

/// Per band (R, G, B) of a colour mosaic (IMX250MYR tiles, the default mosaic [[90, 45],
/// [135, 0]]): its mean DN above black, and its DoLP relative to green's, free of the
/// noise's bias: each band's normalised (Q, U)/I projected on each of green's two tiles
/// of the same 4 × 4 superpixel, over green's one tile on its other (independent noise).
fn band_means(dn: &[f32], w: usize, h: usize, black: f64) -> ([f64; 3], [f64; 3]) {
    let tile = |u0: usize, v0: usize| {
        let px = |du: usize, dv: usize| dn[(v0 + dv) * w + u0 + du] as f64 - black;
        let (i90, i45, i135, i0) = (px(0, 0), px(1, 0), px(0, 1), px(1, 1));
        let i = 0.5 * (i0 + i45 + i90 + i135);
        (0.5 * i, [(i0 - i90) / i, (i45 - i135) / i])
    };
    let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
    let (mut mean, mut proj, mut n) = ([0.0; 3], [0.0; 3], 0.0);
    for v0 in (0..h - 3).step_by(4) {
        for u0 in (0..w - 3).step_by(4) {
            let (r, g1, g2, b) = (tile(u0, v0), tile(u0 + 2, v0), tile(u0, v0 + 2), tile(u0 + 2, v0 + 2));
            for (k, m) in [r.0, 0.5 * (g1.0 + g2.0), b.0].into_iter().enumerate() {
                mean[k] += m;
            }
            proj[0] += 0.5 * (dot(r.1, g1.1) + dot(r.1, g2.1));
            proj[1] += dot(g1.1, g2.1);
            proj[2] += 0.5 * (dot(b.1, g1.1) + dot(b.1, g2.1));
            n += 1.0;
        }
    }
    (mean.map(|m| m / n), proj.map(|p| p / proj[1]))
}

#[test]
fn simulate_writes_a_colour_capture_whose_bands_read_their_headings_and_differ_as_the_model_says() {
    let tmp = tempfile::tempdir().unwrap();
    // The colour sample's sky and sensor (samples/README.md), two of its headings; on
    // its pixel count and on a quarter of it at twice the pitch (the same field of
    // view): there the default cells are a single 4 × 4 superpixel wide, too few places
    // per channel of one band to move its mean to the cell's centre, so a colour
    // compass's cells are at least 8 px (0.2–0.4° off, 12σ, before).
    for (w, h, pitch, name) in [("408", "340", "20.7", "colour"), ("204", "170", "41.4", "small")] {
        let out = tmp.path().join(name);
        let mut args: Vec<String> = [
            "simulate",
            "--out",
            &s(&out),
            "--colour-tiles",
            "RGGB",
            "--width-px",
            w,
            "--height-px",
            h,
            "--pixel-pitch-um",
            pitch,
            "--sun-azimuth-deg",
            "200",
            "--sun-elevation-deg",
            "45",
            "--headings-deg",
            "7,187",
            "--dmax",
            "0.7",
            "--read-noise-dn",
            "1",
            "--system-gain-dn-per-e",
            "0.1",
        ]
        .map(String::from)
        .to_vec();
        for e in [
            "sky_spectrum.radiance_r=0.625",
            "sky_spectrum.radiance_b=1.25",
            "sky_spectrum.dmax_r=1.0571",
            "sky_spectrum.dmax_b=0.8857",
            "band_response.qe_r=0.8",
            "band_response.qe_b=0.6667",
            "band_response.eps_r=0.005",
            "band_response.eps_g=0.004",
            "band_response.eps_b=0.0083",
        ] {
            args.extend(["--effect".to_string(), e.to_string()]);
        }
        bpins(&args).ok();
        let toml = fs::read_to_string(out.join("capture.toml")).unwrap();
        assert!(toml.contains(r#"colour_tiles = [["R", "G"], ["G", "B"]]"#), "{toml}");
        assert!(toml.contains("band_centre_nm"), "{toml}");
        // Every band's heading within 3σ of the truth, and the fused one.
        let json = tmp.path().join(format!("{name}.json"));
        bpins(&["heading", &s(&out), "--json", &s(&json)]).ok();
        let v = read_json(&json);
        let rows = v["frames"].as_array().unwrap();
        for band in ["fused", "R", "G", "B"] {
            let e: Vec<_> = rows.iter().filter(|r| r["band"] == band).collect();
            assert_eq!(e.len(), 2, "{name}, {band}: {v}");
            for r in e {
                let (err, sigma) = (r["error_deg"].as_f64().unwrap(), r["sigma_deg"].as_f64().unwrap());
                assert!(err.abs() < 3.0 * sigma, "{name}, {band}: error {err}°, 1σ {sigma}°");
            }
        }
    }
    let out = tmp.path().join("colour");
    // The bands as the model says: R = 0.625 × 0.8 (1 + ε_R)/(1 + ε_G) ≈ 0.5 of green's
    // signal, B = 1.25 × 0.667 (1 + ε_B)/(1 + ε_G) ≈ 0.837; red the most polarized, blue
    // the least: the ratio of their d_max times each band's analyzer efficiency
    // (1 − ε)/(1 + ε) over green's.
    let c = bpins_core::internal::capture::Capture::load(&out).unwrap();
    let bpins_core::internal::capture::FrameData::Mosaic { dn, .. } = c.read_frame(0).unwrap() else {
        panic!("a dofp capture has mosaic frames")
    };
    let (mean, dolp) = band_means(&dn, 408, 340, 64.0);
    let (r, b) = (mean[0] / mean[1], mean[2] / mean[1]);
    assert!((r - 0.5).abs() < 0.01 && (b - 0.837).abs() < 0.01, "mean DN {mean:?}");
    let eff = |e: f64| (1.0 - e) / (1.0 + e);
    let (want_r, want_b) = (1.0571 * eff(0.005) / eff(0.004), 0.8857 * eff(0.0083) / eff(0.004));
    // Within 0.01: a tile's four analyzers sit on four rays, and the part of its (Q, U)/I
    // that the radiance's gradient makes does not scale with d_max (here +0.005 on R,
    // −0.005 on B, noise-free alike).
    assert!((dolp[0] - want_r).abs() < 0.01 && (dolp[2] - want_b).abs() < 0.01, "DoLP / green's {dolp:?}");
}

#[test]
fn simulate_refuses_colour_tiles_it_cannot_write() {
    let tmp = tempfile::tempdir().unwrap();
    let out = s(&tmp.path().join("never"));
    // Not four bands of R, G, B; a band missing; a colocated sensor (no tiles to cover).
    bpins(&["simulate", "--out", &out, "--colour-tiles", "RGBX"]).fails().stderr_has("--colour-tiles");
    bpins(&["simulate", "--out", &out, "--colour-tiles", "RGGR"]).fails().stderr_has("each band");
    bpins(&["simulate", "--out", &out, "--colour-tiles", "RGGB", "--layout", "colocated"])
        .fails()
        .stderr_has("--colour-tiles");
    assert!(!tmp.path().join("never").exists());
}

/// The colour sample's blue sky and sensor, as `simulate` flags.
const BLUE_SKY: [&str; 16] = [
    "--colour-tiles",
    "RGGB",
    "--effect",
    "sky_spectrum.radiance_r=0.625",
    "--effect",
    "sky_spectrum.radiance_b=1.25",
    "--effect",
    "sky_spectrum.dmax_r=1.0571",
    "--effect",
    "sky_spectrum.dmax_b=0.8857",
    "--effect",
    "band_response.qe_r=0.8",
    "--effect",
    "band_response.qe_b=0.6667",
    "--effect",
    "band_response.eps_b=0.0083",
];

/// Each frame's fused (or mono) error, 1σ and cloud fraction of `bpins heading` on a
/// capture of eight headings of a partly cloudy sky (error and 1σ NaN where a frame
/// has no heading).
fn cloudy(dir: &std::path::Path, name: &str, seed: &str, az: &str, scene: &[&str], colour: bool) -> Vec<[f64; 3]> {
    let cap = dir.join(name);
    let json = dir.join(format!("{name}.json"));
    #[rustfmt::skip]
    let mut args: Vec<&str> = vec![
        "simulate", "--out", cap.to_str().unwrap(), "--scene-seed", seed, "--seed", seed,
        "--width-px", "612", "--height-px", "512", "--sun-azimuth-deg", az, "--sun-elevation-deg", "25",
        "--headings-deg", "0,40,80,120,160,200,240,280",
    ];
    for s in scene {
        args.extend(["--scene", s]);
    }
    if colour {
        args.extend(BLUE_SKY);
    }
    bpins(&args).ok();
    bpins(&["heading", cap.to_str().unwrap(), "--json", json.to_str().unwrap()]).ok();
    let v = read_json(&json);
    let rows = v["frames"].as_array().unwrap();
    rows.iter()
        .filter(|r| r.get("band").is_none_or(|b| b.is_null() || b == "fused"))
        .map(|r| {
            let x = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
            [x("error_deg"), x("sigma_deg"), x("cloud_fraction")]
        })
        .collect()
}

fn rms(rows: &[[f64; 3]]) -> f64 {
    (rows.iter().map(|r| r[0] * r[0]).sum::<f64>() / rows.len() as f64).sqrt()
}

/// Clouds by colour (issue 45 item 3; docs/colour.md's table): a cloud's white light
/// raises the red-to-blue ratio of a blue sky, so a colour camera finds the clouds a
/// monochrome one of the same pixel count cannot: the sunlit rims of a deck that turns
/// one way (mono 0.36° RMS on seeds 1–3: they form a second tight sky) and thin clouds
/// that are neither brighter nor depolarized enough for the other tests.
#[test]
fn a_colour_camera_finds_the_clouds_by_their_white_and_keeps_the_clear_skys_heading() {
    let tmp = tempfile::tempdir().unwrap();
    #[rustfmt::skip]
    let rims = ["clouds.count=6", "clouds.coherence=1", "clouds.rim=1", "clouds.min_elevation_deg=45",
        "clouds.radius_min_deg=8", "clouds.radius_max_deg=20", "clouds.dolp_factor=0.6"];
    for seed in ["1", "3"] {
        let c = cloudy(tmp.path(), &format!("rims-{seed}"), seed, "120", &rims, true);
        assert!(c.len() == 8 && c.iter().all(|r| r[0].is_finite()), "seed {seed}: every frame has a heading: {c:?}");
        assert!(rms(&c) < 0.05, "seed {seed}: {:.4}° RMS: {c:?}", rms(&c));
        assert!(c.iter().all(|r| r[0].abs() < 3.0 * r[1]), "seed {seed}: {c:?}");
    }
    #[rustfmt::skip]
    let thin = ["clouds.count=10", "clouds.brightness=1.1", "clouds.dolp_factor=0.8", "clouds.coherence=0.9",
        "clouds.min_elevation_deg=30", "clouds.radius_min_deg=10", "clouds.radius_max_deg=25"];
    let colour = cloudy(tmp.path(), "thin-colour", "1", "40", &thin, true);
    let mono = cloudy(tmp.path(), "thin-mono", "1", "40", &thin, false);
    let median_cloud = |rows: &[[f64; 3]]| {
        let mut c: Vec<f64> = rows.iter().map(|r| r[2]).collect();
        c.sort_by(f64::total_cmp);
        c[c.len() / 2]
    };
    // Mono sees almost none of these clouds; colour sees them and reads the clear sky.
    assert!(median_cloud(&mono) < 0.1 && median_cloud(&colour) > 0.3, "mono {mono:?}, colour {colour:?}");
    assert!(colour.iter().all(|r| r[0].is_finite()), "every colour frame has a heading: {colour:?}");
    assert!(rms(&colour) < 0.015, "{:.4}° RMS: {colour:?}", rms(&colour));
    assert!(colour.iter().all(|r| r[0].abs() < 3.0 * r[1]), "{colour:?}");
}

/// The fit's photon-transfer noise is read on the sky alone (issue 45; docs/colour.md):
/// a colour mosaic's second difference spans 8 px, and a textured cloud's 8 px read as
/// noise made 9.6 DN, K = 0 and 1.7 % PRNU of a capture whose truth is 1 DN, K = 0.1 DN/e⁻
/// and none (the noise variance at the sky's level 3.8 × the truth, χ²/dof 0.25). On the
/// frames' sky masks it is within a few tenths of a DN² of the truth and χ²/dof ≈ 1.
#[test]
fn a_cloudy_colour_captures_noise_is_read_on_its_sky() {
    let tmp = tempfile::tempdir().unwrap();
    let (cap, out) = (tmp.path().join("cap"), tmp.path().join("fit"));
    #[rustfmt::skip]
    let mut args = vec![
        "simulate", "--out", cap.to_str().unwrap(), "--width-px", "204", "--height-px", "172",
        "--pixel-pitch-um", "41.4", "--sun-azimuth-deg", "200", "--sun-elevation-deg", "45",
        "--headings-deg", "7,97", "--dmax", "0.70", "--read-noise-dn", "1", "--system-gain-dn-per-e", "0.1",
        "--seed", "1", "--scene-seed", "1", "--scene", "clouds.count=6", "--scene", "clouds.min_elevation_deg=30",
        "--scene", "clouds.radius_min_deg=10", "--scene", "clouds.radius_max_deg=25",
    ];
    args.extend(BLUE_SKY);
    bpins(&args).ok();
    bpins(&["fit", cap.to_str().unwrap(), "--effects", "sky_spectrum", "--out", out.to_str().unwrap()]).ok();
    let fit = read_json(&out.join("fit.json"));
    let noise = &fit["noise"];
    let (read, k, prnu) = (f64_of(noise, "read_dn"), f64_of(noise, "k_dn_per_e"), f64_of(noise, "prnu"));
    // The variance at a G pixel's level of this sky (~1 000 DN above black), DN².
    let s = 1000.0;
    let (var, truth) = (read * read + k * s + (prnu * s).powi(2), 1.0 + 0.1 * s);
    assert!((var / truth - 1.0).abs() < 0.25, "{noise}: {var:.1} DN² at {s} DN, truth {truth}");
    assert!(read < 4.0 && prnu < 0.006, "{noise}");
    let chi2 = f64_of(&fit, "chi2_per_dof");
    assert!((0.8..1.3).contains(&chi2), "χ²/dof {chi2}");
}

/// `bpins fit` models a colour capture's bands by default (docs/colour.md, "Fitting and
/// diagnosing one"): the bands differ in level (the sky's colour × the filters' QE) and
/// in DoLP, which one level and one d_max per frame cannot fit (on this capture χ²/dof
/// 1055 and the headings 0.55° and 0.73° off, 4.0σ both, before). Named no band effect,
/// the fit adds `sky_spectrum`, says so and writes it in fit.json's `added`; named
/// `band_response`, it adds nothing; a monochrome capture adds nothing; `diagnose`
/// still starts from the capture's base model.
#[test]
fn fit_adds_sky_spectrum_to_a_colour_capture_that_names_no_band_effect() {
    let tmp = tempfile::tempdir().unwrap();
    let sim = |name: &str, colour: bool| {
        let cap = tmp.path().join(name);
        #[rustfmt::skip]
        let mut args = vec![
            "simulate".to_string(), "--out".into(), s(&cap), "--width-px".into(), "128".into(),
            "--height-px".into(), "96".into(), "--pixel-pitch-um".into(), "66".into(),
            "--sun-azimuth-deg".into(), "200".into(), "--sun-elevation-deg".into(), "45".into(),
            "--headings-deg".into(), "7,97".into(), "--dmax".into(), "0.70".into(),
            "--read-noise-dn".into(), "1".into(), "--system-gain-dn-per-e".into(), "0.1".into(),
            "--seed".into(), "1".into(),
        ];
        if colour {
            args.extend(BLUE_SKY.map(String::from));
        }
        bpins(&args).ok();
        cap
    };
    let fit = |cap: &std::path::Path, out: &str, effects: &[&str]| {
        let out = tmp.path().join(out);
        let mut args = vec!["fit".to_string(), s(cap), "--out".into(), s(&out)];
        if !effects.is_empty() {
            args.extend(["--effects".to_string(), effects.join(",")]);
        }
        let run = bpins(&args).ok();
        (run.stderr, read_json(&out.join("fit.json")))
    };
    let colour = sim("colour", true);
    let (stderr, v) = fit(&colour, "default", &[]);
    assert!(stderr.contains("a colour capture: sky_spectrum added"), "{stderr}");
    assert_eq!(v["effects"], serde_json::json!(["sky_spectrum"]), "{v}");
    let added = v["added"].as_array().unwrap_or_else(|| panic!("no `added` in {v}"));
    assert!(added.len() == 1 && added[0]["effect"] == "sky_spectrum", "{added:?}");
    assert!(added[0]["why"].as_str().is_some_and(|w| w.contains("colour_tiles")), "{added:?}");
    let chi2 = f64_of(&v, "chi2_per_dof");
    assert!((0.8..1.3).contains(&chi2), "χ²/dof {chi2}");
    for f in v["frames"].as_array().unwrap() {
        let (err, sigma) = (f64_of(f, "heading_error_deg"), f64_of(f, "heading_sigma_deg"));
        assert!(err.abs() < 3.0 * sigma && sigma < 0.05, "error {err}°, 1σ {sigma}°: {f}");
    }
    // Named band_response: the user's choice, nothing added.
    let (stderr, v) = fit(&colour, "band-response", &["band_response"]);
    assert!(!stderr.contains("added"), "{stderr}");
    assert_eq!(v["effects"], serde_json::json!(["band_response"]), "{v}");
    assert!(v.get("added").is_none(), "{v}");
    // A monochrome capture: nothing added, no `added` in fit.json.
    let mono = sim("mono", false);
    let (stderr, v) = fit(&mono, "mono-fit", &[]);
    assert!(!stderr.contains("added"), "{stderr}");
    assert_eq!(v["effects"], serde_json::json!([]), "{v}");
    assert!(v.get("added").is_none(), "{v}");
    // The diagnosis starts from the capture's base model (no band effect), as before.
    let diag = tmp.path().join("diagnosis");
    bpins(&["diagnose", &s(&colour), "--max-added", "0", "--out", &s(&diag)]).ok();
    let d = read_json(&diag.join("diagnosis.json"));
    assert_eq!(d["steps"][0]["model"], serde_json::json!([]), "{}", d["steps"][0]["model"]);
    assert!(f64_of(&d["steps"][0], "chi2_per_dof") > 100.0, "{}", d["steps"][0]["chi2_per_dof"]);
}
