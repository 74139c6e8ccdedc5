//! Unit tests of `capture.toml` parsing, validation and writing (CAPTURE.md rules),
//! on text only; files and images are tested in `tests/capture.rs`.

use std::path::{Path, PathBuf};

use super::spec::parse;
use super::toml_out::to_toml;
use super::validate::validate;
use super::*;
use crate::sky::sun::SunSource;

const MIN: &str = r#"
format = "bpins-capture/1"
[sensor]
layout = "dofp"
width_px = 612
height_px = 512
pixel_pitch_um = 13.8
[lens]
projection = "pinhole"
focal_length_mm = 8
[[frames]]
file = "frames/f000.png"
sun_azimuth_deg = 40
sun_elevation_deg = 25.0
heading_deg = 0
"#;

fn toml_path() -> PathBuf {
    PathBuf::from("/cap/capture.toml")
}

fn load_str(text: &str) -> Result<Capture> {
    let c = parse(Path::new("/cap"), &toml_path(), text, false)?;
    validate(&c, &toml_path())?;
    Ok(c)
}

fn message(text: &str) -> String {
    match load_str(text) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => {
            let s = e.to_string();
            assert!(s.starts_with("/cap/capture.toml: "), "{s}");
            s
        }
    }
}

/// `MIN` with `old` replaced by `new` (which must occur).
fn edit(old: &str, new: &str) -> String {
    assert!(MIN.contains(old), "{old}");
    MIN.replacen(old, new, 1)
}

#[test]
fn minimal_capture_gets_the_defaults() {
    let c = load_str(MIN).unwrap();
    assert_eq!(c.sensor.bit_depth, 16);
    assert_eq!(c.sensor.black_level_dn, 0.0);
    assert_eq!(c.sensor.layout, Layout::Dofp { mosaic: crate::sensor::DEFAULT_MOSAIC });
    assert_eq!(c.lens.principal_point_px, (305.5, 255.5));
    assert_eq!(c.lens.focal_length_mm, 8.0); // integer in the file
    assert_eq!(c.frames[0].sun.azimuth_deg, 40.0);
    assert_eq!(c.frames[0].sun.source, SunSource::Given);
    assert_eq!(c.frames[0].heading_deg, Some(0.0));
    assert_eq!(c.frames[0].tilt_x_deg, None);
    assert!((c.focal_length_px() - 8000.0 / 13.8).abs() < 1e-12);
}

#[test]
fn unknown_keys_are_named_with_their_table_or_frame() {
    let m = message(&edit("heading_deg = 0", "heading_deg = 0\nsun_az = 3"));
    assert!(m.contains("frames[0] (frames/f000.png)") && m.contains("unknown key `sun_az`"), "{m}");
    let m = message(&edit("pixel_pitch_um = 13.8", "pixel_pitch_um = 13.8\ngain = 2"));
    assert!(m.contains("[sensor]") && m.contains("`gain`"), "{m}");
    let m = message(&format!("extra = 1\n{MIN}"));
    assert!(m.contains("`extra`"), "{m}");
}

#[test]
fn missing_required_keys_are_named() {
    for (old, key) in [
        ("format = \"bpins-capture/1\"", "format"),
        ("layout = \"dofp\"", "layout"),
        ("width_px = 612", "width_px"),
        ("height_px = 512", "height_px"),
        ("pixel_pitch_um = 13.8", "pixel_pitch_um"),
        ("projection = \"pinhole\"", "projection"),
        ("focal_length_mm = 8", "focal_length_mm"),
        ("file = \"frames/f000.png\"", "file"),
    ] {
        let m = message(&edit(old, ""));
        assert!(m.contains(&format!("missing required key `{key}`")), "{m}");
    }
    let m = message(&edit("[lens]\nprojection = \"pinhole\"\nfocal_length_mm = 8\n", ""));
    assert!(m.contains("[lens]"), "{m}");
    let i = MIN.find("[[frames]]").unwrap();
    let m = message(&MIN[..i]);
    assert!(m.contains("no frames"), "{m}");
    let m = message(&edit("bpins-capture/1", "bpins-capture/2"));
    assert!(m.contains("bpins-capture/2"), "{m}");
}

#[test]
fn out_of_range_values_are_errors_naming_key_and_frame() {
    for (old, new, want) in [
        ("width_px = 612", "width_px = 0", "width_px"),
        ("width_px = 612", "width_px = -3", "width_px"),
        ("pixel_pitch_um = 13.8", "pixel_pitch_um = -13.8", "pixel_pitch_um"),
        ("pixel_pitch_um = 13.8", "pixel_pitch_um = nan", "pixel_pitch_um"),
        ("pixel_pitch_um = 13.8", "pixel_pitch_um = 13.8\nbit_depth = 17", "bit_depth = 17"),
        ("pixel_pitch_um = 13.8", "pixel_pitch_um = 13.8\nbit_depth = 0", "bit_depth = 0"),
        ("pixel_pitch_um = 13.8", "pixel_pitch_um = 13.8\nbit_depth = 12\nblack_level_dn = 4095", "black_level_dn"),
        ("pixel_pitch_um = 13.8", "pixel_pitch_um = 13.8\nblack_level_dn = -1", "black_level_dn"),
        ("focal_length_mm = 8", "focal_length_mm = 0", "focal_length_mm"),
        ("focal_length_mm = 8", "focal_length_mm = 8\nprincipal_point_px = [1, inf]", "principal_point_px"),
        ("focal_length_mm = 8", "focal_length_mm = 8\nprincipal_point_px = [1]", "principal_point_px"),
        ("sun_elevation_deg = 25.0", "sun_elevation_deg = 95", "sun_elevation_deg = 95 is outside its range [-90, 90]"),
        ("sun_elevation_deg = 25.0", "sun_elevation_deg = -91", "sun_elevation_deg"),
        ("sun_azimuth_deg = 40", "sun_azimuth_deg = inf", "sun_azimuth_deg"),
        ("heading_deg = 0", "heading_deg = nan", "heading_deg"),
        ("heading_deg = 0", "heading_deg = 1e308", "heading_deg = 1e308 is outside its range [-360, 360]"),
        ("sun_azimuth_deg = 40", "sun_azimuth_deg = -1e308", "sun_azimuth_deg = -1e308 is outside"),
        ("pixel_pitch_um = 13.8", "pixel_pitch_um = 1e9", "pixel_pitch_um = 1e9 is outside its range [0.1, 1000]"),
        ("focal_length_mm = 8", "focal_length_mm = 1e30", "focal_length_mm = 1e30 is outside"),
        ("width_px = 612", "width_px = 100000", "width_px = 100000 is outside its range [1, 65536]"),
        ("focal_length_mm = 8", "focal_length_mm = 8\nprincipal_point_px = [1e12, 2]", "principal_point_px"),
        ("heading_deg = 0", "tilt_x_deg = 90", "tilt_x_deg"),
        ("heading_deg = 0", "tilt_y_deg = -95", "tilt_y_deg"),
        ("projection = \"pinhole\"", "projection = \"fisheye\"", "fisheye"),
        ("layout = \"dofp\"", "layout = \"rgb\"", "rgb"),
        ("width_px = 612", "width_px = \"612\"", "width_px"),
    ] {
        let m = message(&edit(old, new));
        assert!(m.contains(want), "{new}: {m}");
        if new.contains("sun") || new.contains("heading") || new.contains("tilt") {
            assert!(m.contains("frames[0] (frames/f000.png)"), "{m}");
        }
    }
}

#[test]
fn mosaic_and_channels_follow_the_layout() {
    let c = load_str(&edit("pixel_pitch_um = 13.8", "pixel_pitch_um = 13.8\nmosaic = [[0, 45], [135, 90.0]]")).unwrap();
    assert_eq!(c.sensor.layout, Layout::Dofp { mosaic: [[Channel::C0, Channel::C45], [Channel::C135, Channel::C90]] });
    for bad in ["[[0, 45], [135, 45]]", "[[0, 45, 90], [135, 0]]", "[[0, 30], [135, 90]]", "[0, 45, 90, 135]"] {
        let m = message(&edit("pixel_pitch_um = 13.8", &format!("pixel_pitch_um = 13.8\nmosaic = {bad}")));
        assert!(m.contains("mosaic"), "{bad}: {m}");
    }
    let m = message(&edit("pixel_pitch_um = 13.8", "pixel_pitch_um = 13.8\nchannels = [0, 45, 90]"));
    assert!(m.contains("channels"), "{m}");

    let colo = edit("layout = \"dofp\"", "layout = \"colocated\"").replace("f000.png", "f000.exr");
    let c = load_str(&colo).unwrap();
    assert_eq!(c.sensor.layout, Layout::Colocated { channels: Channel::ALL.to_vec() });
    let three = colo.replace("pixel_pitch_um = 13.8", "pixel_pitch_um = 13.8\nchannels = [90, 0, 45]");
    let c = load_str(&three).unwrap();
    assert_eq!(c.sensor.channels(), vec![Channel::C90, Channel::C0, Channel::C45]);
    for bad in ["[0, 45]", "[0, 45, 135]", "[0, 45, 90, 90]", "[0, 45, 90, 135, 0]", "[0, 45, 91]"] {
        let t = colo.replace("pixel_pitch_um = 13.8", &format!("pixel_pitch_um = 13.8\nchannels = {bad}"));
        let m = message(&t);
        assert!(m.contains("channels"), "{bad}: {m}");
    }
    let m = message(&colo.replace("pixel_pitch_um = 13.8", "pixel_pitch_um = 13.8\nmosaic = [[90, 45], [135, 0]]"));
    assert!(m.contains("mosaic"), "{m}");
    let m = message(&colo.replace("f000.exr", "f000.png"));
    assert!(m.contains("colocated frame must be one multi-channel .exr"), "{m}");
}

#[test]
fn the_sun_is_given_or_from_time_and_place_never_both_or_partial() {
    let timed = edit(
        "sun_azimuth_deg = 40\nsun_elevation_deg = 25.0",
        "time_utc = \"2026-06-21T04:00:00Z\"\nlatitude_deg = 36.07\nlongitude_deg = 120.38",
    );
    let c = load_str(&timed).unwrap();
    let s = &c.frames[0].sun;
    let want = crate::sky::sun::sun_from_time_place("2026-06-21T04:00:00Z", 36.07, 120.38).unwrap();
    assert_eq!(s, &want);
    assert!(matches!(s.source, SunSource::Spa { .. }));
    // An unquoted TOML date-time works too.
    let c2 = load_str(&timed.replace("\"2026-06-21T04:00:00Z\"", "2026-06-21T04:00:00Z")).unwrap();
    assert_eq!(c2.frames[0].sun, want);

    let m = message(&timed.replace("latitude_deg = 36.07\n", ""));
    assert!(m.contains("missing latitude_deg"), "{m}");
    let m = message(&timed.replace("latitude_deg = 36.07", "latitude_deg = 95"));
    assert!(m.contains("frames[0]") && m.contains("latitude_deg"), "{m}");
    let m = message(&timed.replace("04:00:00Z", "04:00:00"));
    assert!(m.contains("frames[0]") && m.contains("time_utc"), "{m}");
    let m = message(&timed.replace("heading_deg = 0", "heading_deg = 0\nsun_azimuth_deg = 3"));
    assert!(m.contains("not both"), "{m}");
    let m = message(&edit("sun_elevation_deg = 25.0\n", ""));
    assert!(m.contains("sun_azimuth_deg needs sun_elevation_deg"), "{m}");
    let m = message(&edit("sun_azimuth_deg = 40\nsun_elevation_deg = 25.0\n", ""));
    assert!(m.contains("no sun position"), "{m}");
}

#[test]
fn frame_files_must_be_distinct_relative_paths_with_a_known_extension() {
    for bad in ["/abs/f.png", "../f.png", "frames/../../f.png", "", "frames/f000.jpg", "."] {
        let m = message(&edit("\"frames/f000.png\"", &format!("{bad:?}")));
        assert!(m.contains("frames[0]"), "{bad}: {m}");
    }
    let two = format!("{MIN}\n[[frames]]\nfile = \"./frames/f000.png\"\nsun_azimuth_deg = 1\nsun_elevation_deg = 2\n");
    let m = message(&two);
    assert!(m.contains("frames[1] (./frames/f000.png)") && m.contains("frames[0]"), "{m}");
}

#[test]
fn toml_text_round_trips_exactly() {
    let text = format!(
        "{}\n[[frames]]\nfile = \"frames/f001.tif\"\ntime_utc = \"2026-06-21T06:30:00+02:00\"\n\
         latitude_deg = -33.9\nlongitude_deg = 18.4\ntilt_x_deg = 0.1\ntilt_y_deg = -2.5e-3\n\
         \n[[frames]]\nfile = \"frames/we\\\"ird\\\\name.exr\"\nsun_azimuth_deg = 359.99999999999994\n\
         sun_elevation_deg = 0.1\n",
        MIN.replace("pixel_pitch_um = 13.8", "pixel_pitch_um = 3.45\nbit_depth = 12\nblack_level_dn = 64.5")
    );
    let c = load_str(&text).unwrap();
    let out = to_toml(&c);
    let back = load_str(&out).unwrap();
    assert_eq!(back, c, "{out}");
    assert!(out.contains("mosaic = [[90, 45], [135, 0]]"), "{out}");
    assert!(out.contains("principal_point_px = [305.5, 255.5]"), "{out}");
    assert!(out.contains("time_utc = \"2026-06-21T04:30:00Z\""), "{out}");
    assert_eq!(to_toml(&back), out);

    let colo =
        edit("layout = \"dofp\"", "layout = \"colocated\"\nchannels = [0, 90, 45]").replace("f000.png", "f000.exr");
    let c = load_str(&colo).unwrap();
    let out = to_toml(&c);
    assert!(out.contains("channels = [0, 90, 45]"), "{out}");
    assert_eq!(load_str(&out).unwrap(), c);
}

#[test]
fn syntax_errors_name_the_file() {
    let m = message("format = \"bpins-capture/1\"\n[sensor\n");
    assert!(m.contains("not valid TOML"), "{m}");
    let m = message("format = \"bpins-capture/1\"\nsensor = 3\n");
    assert!(m.contains("[sensor]"), "{m}");
    let i = MIN.find("[[frames]]").unwrap();
    let m = message(&format!("frames = [1]\n{}", &MIN[..i]));
    assert!(m.contains("frames[0] must be a table"), "{m}");
    let m = message(&format!("{MIN}\n[lens]\nprojection = \"pinhole\"\n"));
    assert!(m.contains("not valid TOML at line"), "{m}");
}

/// A frame with `time_utc` alone (a robot without GNSS): refused by the strict reader
/// with a pointer to `bpins locate`, read by `load_unplaced`'s parser with NaN
/// angles, its stamp normalised to UTC, and its gyro's yaw kept; written back the
/// same way.
#[test]
fn a_stamp_without_a_place_is_for_locate_only() {
    let stamped = edit(
        "sun_azimuth_deg = 40\nsun_elevation_deg = 25.0\nheading_deg = 0",
        "time_utc = \"2026-06-21T06:00:00+02:00\"\nyaw_deg = 12.5\nyaw_sigma_deg = 0.1",
    );
    let m = message(&stamped);
    assert!(m.contains("missing latitude_deg, longitude_deg") && m.contains("bpins locate"), "{m}");
    let c = parse(Path::new("/cap"), &toml_path(), &stamped, true).unwrap();
    validate(&c, &toml_path()).unwrap();
    let f = &c.frames[0];
    assert!(!f.sun.is_known() && f.sun.azimuth_deg.is_nan());
    assert_eq!(f.sun.source, SunSource::Unplaced { time_utc: "2026-06-21T04:00:00Z".into() });
    assert_eq!((f.yaw_deg, f.yaw_sigma_deg), (Some(12.5), Some(0.1)));
    let again = parse(Path::new("/cap"), &toml_path(), &c.to_toml_string(), true).unwrap();
    let g = &again.frames[0];
    assert_eq!((&g.sun.source, g.yaw_deg, g.yaw_sigma_deg), (&f.sun.source, f.yaw_deg, f.yaw_sigma_deg));
    let bad =
        parse(Path::new("/cap"), &toml_path(), &stamped.replace("yaw_sigma_deg = 0.1", "yaw_sigma_deg = 50"), true);
    let m = validate(&bad.unwrap(), &toml_path()).unwrap_err().to_string();
    assert!(m.contains("yaw_sigma_deg"), "{m}");
}

/// `colour_tiles` and `band_centre_nm` (CAPTURE.md): read, written back, and every bad
/// form refused naming the key.
#[test]
fn colour_tiles_are_read_written_back_and_refused_when_malformed() {
    let key = |extra: &str| edit("pixel_pitch_um = 13.8", &format!("pixel_pitch_um = 13.8\n{extra}"));
    let c = load_str(&key("colour_tiles = [[\"R\", \"G\"], [\"G\", \"B\"]]\nband_centre_nm = { B = 450.0 }")).unwrap();
    let colour = c.sensor.colour.clone().expect("a colour sensor");
    assert_eq!(colour.tiles, crate::sensor::ColourTiles::imx250myr().tiles);
    assert_eq!(colour.centre_nm, [615.0, 530.0, 450.0], "defaults for the bands not given");
    let text = to_toml(&c);
    assert!(text.contains("colour_tiles") && text.contains("450"), "{text}");
    assert_eq!(load_str(&text).unwrap().sensor.colour, Some(colour));
    assert_eq!(load_str(MIN).unwrap().sensor.colour, None);
    for (extra, want) in [
        ("colour_tiles = [[\"R\", \"G\"], [\"G\", \"X\"]]", "band \"X\" is unknown"),
        ("colour_tiles = [[\"R\", \"G\", \"B\"], [\"G\", \"B\"]]", "expected 2 rows of 2 bands"),
        ("colour_tiles = \"RGGB\"", "expected 2 rows of 2 bands"),
        ("band_centre_nm = { R = 615.0 }", "band_centre_nm is for a colour-polarization sensor"),
        ("colour_tiles = [[\"R\", \"G\"], [\"G\", \"B\"]]\nband_centre_nm = { R = -1.0 }", "band_centre_nm.R = -1"),
        ("colour_tiles = [[\"R\", \"G\"], [\"G\", \"B\"]]\nband_centre_nm = { V = 400.0 }", "band \"V\" is unknown"),
    ] {
        let m = message(&key(extra));
        assert!(m.contains("[sensor]") && m.contains(want), "{extra}: {m}");
    }
    let m =
        message(&edit("layout = \"dofp\"", "layout = \"colocated\"\ncolour_tiles = [[\"R\", \"G\"], [\"G\", \"B\"]]"));
    assert!(m.contains("colour_tiles is for layout = \"dofp\""), "{m}");
}
