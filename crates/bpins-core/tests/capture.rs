//! End-to-end tests of `bpins-capture/1` (docs/spec/CAPTURE.md): the two sample
//! captures in samples load and decode; broken copies of them fail with
//! errors naming file, key and frame and are left untouched; writing refuses to touch
//! a capture and reads back exactly. Fixtures are copies in temporary folders;
//! samples/ is only read.

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};

use bpins_core::internal::capture::{read_exr_layers, write_exr_layers, Capture, FrameData};
use bpins_core::internal::sky::sun::{sun_from_time_place, SunSource};
use bpins_core::sensor::{Channel, Layout, DEFAULT_MOSAIC};
use image::{GrayImage, ImageBuffer, Luma, RgbImage};

const CLEAN: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../samples/clean");
const HIDDEN: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../samples/hidden-analyzer-angles");

/// Every file under `dir`: relative path → contents.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    fn walk(root: &Path, d: &Path, out: &mut BTreeMap<PathBuf, Vec<u8>>) {
        for e in fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                out.insert(p.strip_prefix(root).unwrap().to_path_buf(), fs::read(&p).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

/// A writable copy of the clean sample in a fresh temporary folder.
fn fixture() -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("cap");
    fs::create_dir_all(dir.join("frames")).unwrap();
    for (rel, bytes) in snapshot(Path::new(CLEAN)) {
        fs::write(dir.join(rel), bytes).unwrap();
    }
    (tmp, dir)
}

fn set_toml(dir: &Path, f: impl FnOnce(&str) -> String) {
    let p = dir.join("capture.toml");
    let t = fs::read_to_string(&p).unwrap();
    fs::write(&p, f(&t)).unwrap();
}

fn load_err(dir: &Path) -> String {
    let before = snapshot(dir);
    let e = Capture::load(dir).expect_err("load should fail").to_string();
    assert_eq!(snapshot(dir), before, "a failed load changed the folder");
    e
}

fn read_err(dir: &Path, i: usize) -> String {
    let before = snapshot(dir);
    let c = Capture::load(dir).unwrap();
    let e = c.read_frame(i).expect_err("read should fail").to_string();
    assert_eq!(snapshot(dir), before, "a failed read changed the folder");
    e
}

#[test]
fn clean_sample_loads_and_decodes() {
    let before = snapshot(Path::new(CLEAN));
    let c = Capture::load(Path::new(CLEAN)).unwrap();
    assert_eq!(c.frames.len(), 8);
    assert_eq!((c.sensor.geometry.width_px, c.sensor.geometry.height_px), (612, 512));
    assert_eq!(c.sensor.geometry.pixel_pitch_um, 13.8);
    assert_eq!(c.sensor.layout, Layout::Dofp { mosaic: DEFAULT_MOSAIC });
    assert_eq!((c.sensor.bit_depth, c.sensor.black_level_dn), (12, 64.0));
    assert_eq!(c.lens.principal_point_px, (305.5, 255.5));
    assert!((c.focal_length_px() - 8000.0 / 13.8).abs() < 1e-9);
    for (i, f) in c.frames.iter().enumerate() {
        assert_eq!(f.file, PathBuf::from(format!("frames/f{i:03}.png")));
        assert_eq!(f.heading_deg, Some(45.0 * i as f64));
        assert_eq!((f.sun.azimuth_deg, f.sun.elevation_deg), (40.0, 25.0));
        assert_eq!(f.sun.source, SunSource::Given);
    }
    let FrameData::Mosaic { width_px, height_px, dn } = c.read_frame(0).unwrap() else {
        panic!("dofp decodes to a mosaic")
    };
    assert_eq!((width_px, height_px, dn.len()), (612, 512, 612 * 512));
    assert!(dn.iter().all(|&x| (0.0..=4095.0).contains(&x) && x.fract() == 0.0));
    assert!(dn.iter().any(|&x| x > 64.0));
    assert!(c.read_frame(8).is_err());

    let h = Capture::load(Path::new(HIDDEN)).unwrap();
    assert_eq!(h.frames.len(), 8);
    assert_eq!(h.read_frame(7).unwrap().size_px(), (612, 512));
    assert_eq!(snapshot(Path::new(CLEAN)), before);
}

#[test]
fn toml_errors_name_file_key_and_frame() {
    let (_t, dir) = fixture();
    let toml = dir.join("capture.toml");
    let toml_s = toml.display().to_string();

    set_toml(&dir, |t| t.replacen("heading_deg = 135", "heading_deg = 135\nsun_zenith_deg = 3", 1));
    let e = load_err(&dir);
    assert!(
        e.starts_with(&toml_s) && e.contains("frames[3] (frames/f003.png)") && e.contains("`sun_zenith_deg`"),
        "{e}"
    );

    let (_t, dir) = fixture();
    set_toml(&dir, |t| t.replacen("pixel_pitch_um = 13.8\n", "", 1));
    let e = load_err(&dir);
    assert!(e.contains("capture.toml") && e.contains("[sensor]") && e.contains("pixel_pitch_um"), "{e}");

    let (_t, dir) = fixture();
    let toml_s = dir.join("capture.toml").display().to_string();
    set_toml(&dir, |t| {
        let i = t.find("file = \"frames/f003.png\"").unwrap();
        format!("{}{}", &t[..i], t[i..].replacen("sun_elevation_deg = 25.0", "sun_elevation_deg = 95", 1))
    });
    let e = load_err(&dir);
    assert_eq!(e, format!("{toml_s}: frames[3] (frames/f003.png): sun_elevation_deg = 95 is outside its range [-90, 90] (from the nadir to the zenith)"));

    let (_t, dir) = fixture();
    set_toml(&dir, |t| t.replacen("bit_depth = 12", "bit_depth = 20", 1));
    assert!(load_err(&dir).contains("bit_depth = 20"));

    let (_t, dir) = fixture();
    fs::remove_file(dir.join("frames/f005.png")).unwrap();
    let e = load_err(&dir);
    assert!(e.contains("frames[5] (frames/f005.png)") && e.contains("does not exist"), "{e}");

    let (_t, dir) = fixture();
    fs::remove_file(dir.join("capture.toml")).unwrap();
    assert!(load_err(&dir).contains("capture.toml: not found"));
}

#[test]
fn bad_images_are_errors_naming_the_frame() {
    let (_t, dir) = fixture();
    let img = |i: usize| dir.join(format!("frames/f{i:03}.png"));
    ImageBuffer::<Luma<u16>, Vec<u16>>::from_pixel(610, 512, Luma([100])).save(img(2)).unwrap();
    RgbImage::from_pixel(612, 512, image::Rgb([1, 2, 3])).save(img(3)).unwrap();
    GrayImage::from_pixel(612, 512, Luma([100])).save(img(4)).unwrap();
    // 12-bit DN left-shifted into 16 bits.
    let c = Capture::load(&dir).unwrap();
    let FrameData::Mosaic { dn, .. } = c.read_frame(5).unwrap() else { panic!() };
    let shifted: Vec<u16> = dn.iter().map(|&x| (x as u16) << 4).collect();
    ImageBuffer::<Luma<u16>, Vec<u16>>::from_raw(612, 512, shifted).unwrap().save(img(5)).unwrap();
    let bytes = fs::read(img(6)).unwrap();
    fs::write(img(6), &bytes[..bytes.len() / 2]).unwrap();
    fs::write(img(7), b"not a png at all").unwrap();

    let e = read_err(&dir, 2);
    assert!(e.starts_with(&img(2).display().to_string()), "{e}");
    assert!(e.contains("frames[2] (frames/f002.png)") && e.contains("610 × 512") && e.contains("612 × 512"), "{e}");
    let e = read_err(&dir, 3);
    assert!(e.contains("frames[3]") && e.contains("Rgb8"), "{e}");
    let e = read_err(&dir, 4);
    assert!(e.contains("frames[4]") && e.contains("8-bit"), "{e}");
    let e = read_err(&dir, 5);
    assert!(e.contains("frames[5]") && e.contains("left-shifted"), "{e}");
    assert!(read_err(&dir, 6).contains("frames[6]"));
    assert!(read_err(&dir, 7).contains("frames[7]"));
    assert!(c.read_frame(0).is_ok());
}

#[test]
fn write_never_touches_a_capture() {
    let (t, dir) = fixture();
    let c = Capture::load(&dir).unwrap();
    let frames: Vec<FrameData> = (0..8).map(|i| c.read_frame(i).unwrap()).collect();
    let before = snapshot(&dir);
    let e = c.write(&dir, &frames).unwrap_err().to_string();
    assert!(e.contains("capture.toml") && e.contains("already exists"), "{e}");
    let e = c.write(&dir.join("frames"), &frames).unwrap_err().to_string();
    assert!(e.contains("inside the capture"), "{e}");
    let e = c.write(&dir.join("sub/../frames/x"), &frames).unwrap_err().to_string();
    assert!(e.contains("inside the capture"), "{e}");
    // A frame file that would land inside the capture, from a folder around it.
    let mut around = c.clone();
    around.frames[3].file = "cap/frames/new.png".into();
    let e = around.write(t.path(), &frames).unwrap_err().to_string();
    assert!(e.contains("new.png") && e.contains("inside the capture"), "{e}");
    assert_eq!(snapshot(&dir), before);
    assert!(!t.path().join("capture.toml").exists());

    // An existing image in the output folder is refused before anything is written.
    let out = t.path().join("out");
    fs::create_dir_all(out.join("frames")).unwrap();
    fs::write(out.join("frames/f004.png"), b"x").unwrap();
    let e = c.write(&out, &frames).unwrap_err().to_string();
    assert!(e.contains("f004.png") && e.contains("already exists"), "{e}");
    assert_eq!(snapshot(&out).len(), 1);

    // Data that would not read back is refused before anything is written.
    let mut bad = frames.clone();
    if let FrameData::Mosaic { dn, .. } = &mut bad[1] {
        dn[10] = 4095.6;
    }
    let out2 = t.path().join("out2");
    let e = c.write(&out2, &bad).unwrap_err().to_string();
    assert!(e.contains("frames[1]") && e.contains("full scale"), "{e}");
    assert!(!out2.exists());
    assert!(c.write(&out2, &frames[..3]).is_err());
}

#[test]
fn dofp_round_trips_exactly_through_png_tiff_and_exr() {
    let src = Capture::load(Path::new(CLEAN)).unwrap();
    let mut c = src.clone();
    c.frames.truncate(3);
    c.frames[1].file = "a/b/f001.tif".into();
    c.frames[2].file = "f002.exr".into();
    let mut frames: Vec<FrameData> = (0..3).map(|i| src.read_frame(i).unwrap()).collect();
    if let FrameData::Mosaic { dn, .. } = &mut frames[2] {
        dn[0] = 0.1;
        dn[1] = 4094.99;
        dn[2] = -3.25;
    }
    let t = tempfile::tempdir().unwrap();
    let out = t.path().join("new/capture");
    c.write(&out, &frames).unwrap();
    let back = Capture::load(&out).unwrap();
    assert_eq!(back.to_toml_string(), c.to_toml_string());
    assert_eq!(Capture { dir: c.dir.clone(), ..back.clone() }, c);
    for (i, want) in frames.iter().enumerate() {
        assert_eq!(&back.read_frame(i).unwrap(), want, "frame {i}");
    }
    // PNG rounds and clamps.
    let mut f = frames[0].clone();
    if let FrameData::Mosaic { dn, .. } = &mut f {
        dn[0] = 7.5;
        dn[1] = -2.0;
    }
    let mut one = c.clone();
    one.frames.truncate(1);
    one.write(&t.path().join("rounded"), &[f]).unwrap();
    let FrameData::Mosaic { dn, .. } = Capture::load(&t.path().join("rounded")).unwrap().read_frame(0).unwrap() else {
        panic!()
    };
    assert_eq!((dn[0], dn[1]), (8.0, 0.0));
}

#[test]
fn colocated_round_trips_exactly_through_exr() {
    let t = tempfile::tempdir().unwrap();
    let text = "format = \"bpins-capture/1\"\n[sensor]\nlayout = \"colocated\"\nwidth_px = 7\nheight_px = 5\n\
                pixel_pitch_um = 3.45\nchannels = [90, 0, 45]\n[lens]\nprojection = \"equisolid\"\n\
                focal_length_mm = 1.8\n[[frames]]\nfile = \"f0.exr\"\nsun_azimuth_deg = 10\nsun_elevation_deg = 60\n";
    let src = t.path().join("src");
    fs::create_dir_all(&src).unwrap();
    fs::write(src.join("capture.toml"), text).unwrap();
    fs::write(src.join("f0.exr"), b"").unwrap();
    let c = Capture::load(&src).unwrap();
    assert!(c.read_frame(0).unwrap_err().to_string().contains("frames[0] (f0.exr)"));
    let plane = |k: f32| (0..35).map(|i| k + i as f32 * 0.123_456_7 - 1.0).collect::<Vec<f32>>();
    let data = FrameData::Colocated {
        width_px: 7,
        height_px: 5,
        channels: vec![(Channel::C90, plane(10.0)), (Channel::C0, plane(20.5)), (Channel::C45, plane(1e3))],
    };
    let out = t.path().join("out");
    c.write(&out, std::slice::from_ref(&data)).unwrap();
    let back = Capture::load(&out).unwrap();
    assert_eq!(back.read_frame(0).unwrap(), data);

    // A missing or unexpected channel is named.
    let p = src.join("f0.exr");
    fs::remove_file(&p).unwrap();
    write_exr_layers(&p, 7, 5, &[("I0", &plane(1.0)), ("I90", &plane(1.0))]).unwrap();
    let e = c.read_frame(0).unwrap_err().to_string();
    assert!(e.contains("frames[0]") && e.contains("missing channel I45"), "{e}");
    write_exr_layers(
        &p,
        7,
        5,
        &[("I0", &plane(1.0)), ("I45", &plane(1.0)), ("I90", &plane(1.0)), ("I135", &plane(1.0))],
    )
    .unwrap();
    let e = c.read_frame(0).unwrap_err().to_string();
    assert!(e.contains("unexpected channel I135"), "{e}");
    write_exr_layers(&p, 5, 7, &[("I0", &plane(1.0)), ("I45", &plane(1.0)), ("I90", &plane(1.0))]).unwrap();
    let e = c.read_frame(0).unwrap_err().to_string();
    assert!(e.contains("5 × 7 px, expected 7 × 5 px"), "{e}");
    let mut nan = plane(1.0);
    nan[3] = f32::NAN;
    write_exr_layers(&p, 7, 5, &[("I0", &nan), ("I45", &plane(1.0)), ("I90", &plane(1.0))]).unwrap();
    let e = c.read_frame(0).unwrap_err().to_string();
    assert!(e.contains("channel I0") && e.contains("(3, 0)"), "{e}");
}

#[test]
fn exr_layers_round_trip_exactly() {
    let t = tempfile::tempdir().unwrap();
    let p = t.path().join("dump.exr");
    let a: Vec<f32> = (0..12).map(|i| (i as f32).sin() * 1e-3).collect();
    let b: Vec<f32> = (0..12).map(|i| -(i as f32) * 7.25).collect();
    write_exr_layers(&p, 4, 3, &[("DoLP", &a), ("AoP", &b)]).unwrap();
    let (w, h, layers) = read_exr_layers(&p).unwrap();
    assert_eq!((w, h), (4, 3));
    assert_eq!(layers, vec![("AoP".to_string(), b.clone()), ("DoLP".to_string(), a.clone())]);
    assert!(write_exr_layers(&p, 4, 3, &[("AoP", &b[..5])]).is_err());
    assert!(write_exr_layers(&p, 4, 3, &[("AoP", &b), ("AoP", &b)]).is_err());
    assert!(write_exr_layers(&p, 4, 3, &[("Ä", &b)]).is_err());
    fs::write(&p, b"v/1\x01garbage").unwrap();
    assert!(read_exr_layers(&p).is_err());
}

#[test]
fn time_and_place_frames_resolve_through_spa() {
    let (t, dir) = fixture();
    set_toml(&dir, |s| {
        s.replacen(
            "sun_azimuth_deg = 40.0\nsun_elevation_deg = 25.0\nheading_deg = 90",
            "time_utc = \"2026-06-21T04:00:00Z\"\nlatitude_deg = 36.07\nlongitude_deg = 120.38\nheading_deg = 90",
            1,
        )
    });
    let c = Capture::load(&dir).unwrap();
    let s = &c.frames[2].sun;
    assert_eq!(s, &sun_from_time_place("2026-06-21T04:00:00Z", 36.07, 120.38).unwrap());
    assert!(s.source.describe().starts_with("NREL SPA from 2026-06-21T04:00:00Z at 36.07°N 120.38°E"));
    assert!(s.elevation_deg > 40.0 && s.elevation_deg < 80.0, "{s:?}");
    assert_eq!(c.frames[1].sun.source, SunSource::Given);
    let frames: Vec<FrameData> = (0..8).map(|i| c.read_frame(i).unwrap()).collect();
    let out = t.path().join("out");
    c.write(&out, &frames).unwrap();
    let text = fs::read_to_string(out.join("capture.toml")).unwrap();
    assert!(text.contains("time_utc = \"2026-06-21T04:00:00Z\""), "{text}");
    assert_eq!(Capture::load(&out).unwrap().frames, c.frames);
}
