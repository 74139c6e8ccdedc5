//! ROS messages → what bpins' compass takes: a DoFP mosaic buffer
//! (`sensor_msgs/Image`), intrinsics (`sensor_msgs/CameraInfo`), a tilt with its
//! variances (`sensor_msgs/Imu`, through [`crate::rep103`]). Every refusal says what
//! is wrong and what bpins accepts; nothing here panics on a message's content.

use crate::msgs::{CameraInfo, Image, Imu};
use crate::rep103;
use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::compass::RawImage;
use bpins_core::sensor::{Band, ColourTiles};

/// An image's pixels as the compass reads them: `u8` borrowed from the message
/// (`mono8`, rows `step` bytes apart), `u16` borrowed where the message's byte
/// order is the host's and the rows are 2-byte aligned, copied as they are into a
/// buffer reused from frame to frame where only the alignment is wrong, else
/// converted to host order into that buffer (`mono16`, either byte order, any
/// `step`).
pub enum Mosaic<'a> {
    U8(RawImage<'a, u8>),
    U16(RawImage<'a, u16>),
}

impl Mosaic<'_> {
    /// The DN row by row, `width × height` of them, each row's padding (the `step`
    /// beyond its pixels) left out: what a capture's frame holds. Every route that
    /// copies a bag's pixels goes through this, so that a padded row reads as the
    /// unpadded one whatever the encoding.
    pub fn packed_dn_f32(&self) -> Vec<f32> {
        fn rows<T: Copy + Into<f32>>(r: &RawImage<'_, T>) -> Vec<f32> {
            let mut out = Vec::with_capacity(r.width_px * r.height_px);
            for v in 0..r.height_px {
                out.extend(r.data[v * r.stride..][..r.width_px].iter().map(|&x| x.into()));
            }
            out
        }
        match self {
            Mosaic::U8(r) => rows(r),
            Mosaic::U16(r) => rows(r),
        }
    }
}

/// The colour filters a `bayer_*` encoding names, by analyzer tile: on a
/// colour-polarization sensor (Sony IMX250MYR) each letter of the 2 × 2 Bayer pattern
/// lies over one 2 × 2 analyzer tile of the 4 × 4 superpixel (CONVENTIONS.md), so
/// `bayer_rggb8` is `colour_tiles = [["R", "G"], ["G", "B"]]`: the raw mosaic, never
/// demosaiced. `None` for any other encoding.
pub fn encoding_tiles(encoding: &str) -> Option<[[Band; 2]; 2]> {
    use Band::{B, G, R};
    let rest = encoding.strip_prefix("bayer_")?;
    let pattern = rest.strip_suffix("16").or_else(|| rest.strip_suffix('8'))?;
    Some(match pattern {
        "rggb" => [[R, G], [G, B]],
        "bggr" => [[B, G], [G, R]],
        "gbrg" => [[G, B], [R, G]],
        "grbg" => [[G, R], [B, G]],
        _ => return None,
    })
}

/// The bits per pixel of an encoding [`mosaic`] reads: 8 or 16.
pub fn encoding_bits(encoding: &str) -> Option<u32> {
    match encoding {
        "mono8" | "8UC1" => Some(8),
        "mono16" | "16UC1" => Some(16),
        e if encoding_tiles(e).is_some() => Some(if e.ends_with("16") { 16 } else { 8 }),
        _ => None,
    }
}

/// The pixels of `im`, checked against its own size and `step`; `u16` pixels go
/// into `scratch` (one frame, reused). `colour` is the sensor's colour layout (`None`:
/// monochrome): a `bayer_*` image is read as the raw colour-polarization mosaic it is
/// where its pattern is the sensor's ([`encoding_tiles`]) and refused otherwise, so a
/// colour mosaic is never read as a monochrome one; a `mono*` image is read with the
/// sensor's layout whatever it is.
pub fn mosaic<'a>(
    im: &'a Image<'_>,
    colour: Option<&ColourTiles>,
    scratch: &'a mut Vec<u16>,
) -> Result<Mosaic<'a>, String> {
    let (w, h, step) = (im.width as usize, im.height as usize, im.step as usize);
    let Some(bits) = encoding_bits(&im.encoding) else {
        return Err(format!(
            "encoding `{}`: a DoFP mosaic is read from `mono8` or `mono16` (also `8UC1`, `16UC1`), a \
             colour-polarization mosaic also from `bayer_rggb8` … `bayer_grbg16`; a colour or debayered image has \
             lost the analyzer channels",
            im.encoding
        ));
    };
    if let Some(tiles) = encoding_tiles(&im.encoding) {
        let name = |t: [[Band; 2]; 2]| t.iter().flatten().map(|b| b.name()).collect::<String>();
        match colour {
            None => {
                return Err(format!(
                    "encoding `{}`: a colour-polarization mosaic ({} tiles), but the sensor is monochrome: give it \
                     `colour_tiles` (a sensor file) or send `mono8`/`mono16`",
                    im.encoding,
                    name(tiles)
                ))
            }
            Some(c) if c.tiles != tiles => {
                return Err(format!(
                    "encoding `{}` says {} tiles, the sensor's colour_tiles are {}",
                    im.encoding,
                    name(tiles),
                    name(c.tiles)
                ))
            }
            Some(_) => {}
        }
    }
    let bytes_px = (bits / 8) as usize;
    if w == 0 || h == 0 {
        return Err(format!("an empty image ({w} × {h} px)"));
    }
    let row_bytes = w.checked_mul(bytes_px).ok_or("width overflows")?;
    if step < row_bytes {
        return Err(format!("step {step} bytes is shorter than a row of {w} px × {bytes_px} bytes"));
    }
    let need = (h - 1).checked_mul(step).and_then(|x| x.checked_add(row_bytes)).ok_or("size overflows")?;
    if im.data.len() < need {
        return Err(format!(
            "{} data bytes for {w} × {h} px with step {step}: at least {need} needed (truncated image)",
            im.data.len()
        ));
    }
    if bytes_px == 1 {
        return Ok(Mosaic::U8(RawImage { data: &im.data[..need], width_px: w, height_px: h, stride: step }));
    }
    let big = match im.is_bigendian {
        0 => false,
        1 => true,
        b => return Err(format!("is_bigendian = {b}: must be 0 or 1")),
    };
    // Pixels in the host's byte order, rows 2-byte aligned: read in place.
    if big == cfg!(target_endian = "big") && step % 2 == 0 {
        if let Ok(px) = bytemuck::try_cast_slice::<u8, u16>(&im.data[..need]) {
            return Ok(Mosaic::U16(RawImage { data: px, width_px: w, height_px: h, stride: step / 2 }));
        }
    }
    // The host's byte order but rows not 2-byte aligned in memory (a message borrowed
    // from an MCAP file's map lies where the file puts it): one copy of the rows as
    // they are, the buffer reused (resized only when the frame's size changes).
    if big == cfg!(target_endian = "big") && step % 2 == 0 {
        if scratch.len() != need / 2 {
            scratch.clear();
            scratch.resize(need / 2, 0);
        }
        bytemuck::cast_slice_mut::<u16, u8>(&mut scratch[..]).copy_from_slice(&im.data[..need]);
        return Ok(Mosaic::U16(RawImage { data: &scratch[..], width_px: w, height_px: h, stride: step / 2 }));
    }
    scratch.clear();
    scratch.reserve(w * h);
    for v in 0..h {
        let row = &im.data[v * step..][..row_bytes];
        scratch.extend(row.chunks_exact(2).map(|p| {
            let b = [p[0], p[1]];
            if big {
                u16::from_be_bytes(b)
            } else {
                u16::from_le_bytes(b)
            }
        }));
    }
    Ok(Mosaic::U16(RawImage::packed(&scratch[..], w, h)))
}

/// The camera's intrinsics from `CameraInfo`: `K` (square pixels, no skew) and the
/// distortion: `plumb_bob` (OpenCV's k1, k2, p1, p2, k3) is bpins' pinhole with
/// radial k1, k2 (CONVENTIONS.md, `distorted = ideal·(1 + k1 r² + k2 r⁴)`);
/// `equidistant` (OpenCV's fisheye, θ_d = θ(1 + k1θ² + k2θ⁴ + k3θ⁶ + k4θ⁸)) is bpins'
/// equidistant projection with k1, k2. Coefficients bpins does not model (p1, p2, k3;
/// k3, k4) must be 0, and other models are refused by name. A region of interest
/// moves the principal point; binning is refused (it mixes a DoFP mosaic's
/// analyzers). Pixel centres at integer coordinates, as in ROS and OpenCV.
pub fn intrinsics(ci: &CameraInfo) -> Result<Intrinsics, String> {
    let k = ci.k;
    if k.iter().any(|x| !x.is_finite()) {
        return Err(format!("K {k:?} holds a value that is not a number"));
    }
    let (fx, fy, cx, cy) = (k[0], k[4], k[2], k[5]);
    if !(fx > 0.0 && fy > 0.0) {
        return Err(format!("K: focal lengths fx = {fx}, fy = {fy} px must be > 0 (an uncalibrated camera?)"));
    }
    if (fx - fy).abs() > 1e-3 * fx {
        return Err(format!("K: fx = {fx} px and fy = {fy} px differ; bpins models square pixels (one focal length)"));
    }
    if k[1] != 0.0 {
        return Err(format!("K: skew {} is not 0; bpins models no skew", k[1]));
    }
    if ci.binning_x > 1 || ci.binning_y > 1 {
        return Err(format!(
            "binning {} × {}: a binned DoFP image mixes the analyzer channels; record unbinned",
            ci.binning_x, ci.binning_y
        ));
    }
    let roi = ci.roi;
    if roi.x_offset % 2 == 1 || roi.y_offset % 2 == 1 {
        return Err(format!(
            "region of interest offset ({}, {}) px is odd: it moves the DoFP mosaic by one pixel",
            roi.x_offset, roi.y_offset
        ));
    }
    let d = |i: usize| ci.d.get(i).copied().unwrap_or(0.0);
    if ci.d.iter().any(|x| !x.is_finite()) {
        return Err(format!("D {:?} holds a value that is not a number", ci.d));
    }
    let unmodelled = |names: &[(&str, usize)], model: &str| -> Result<(), String> {
        for &(name, i) in names {
            if d(i) != 0.0 {
                return Err(format!(
                    "distortion_model `{model}`: {name} = {} is not modelled by bpins (radial k1, k2 only); it must be 0",
                    d(i)
                ));
            }
        }
        Ok(())
    };
    let (projection, n_max) = match ci.distortion_model.as_str() {
        "plumb_bob" | "" => {
            unmodelled(&[("p1", 2), ("p2", 3), ("k3", 4)], "plumb_bob")?;
            (Projection::Pinhole, 5)
        }
        "equidistant" => {
            unmodelled(&[("k3", 2), ("k4", 3)], "equidistant")?;
            (Projection::Equidistant, 4)
        }
        other => {
            return Err(format!(
                "distortion_model `{other}` cannot be mapped to bpins' projections: use `plumb_bob` (pinhole, \
                 radial k1, k2) or `equidistant` (fisheye, k1, k2)"
            ))
        }
    };
    if ci.d.len() > n_max {
        return Err(format!("D has {} coefficients; `{}` has {n_max}", ci.d.len(), ci.distortion_model));
    }
    let mut intr =
        Intrinsics::new(projection, 0.5 * (fx + fy), cx - f64::from(roi.x_offset), cy - f64::from(roi.y_offset));
    intr.distortion = [d(0), d(1)];
    Ok(intr)
}

/// The size (width, height) of the images `ci` describes (its region of interest
/// where one is set).
pub fn camera_size_px(ci: &CameraInfo) -> (u32, u32) {
    if ci.roi.width > 0 && ci.roi.height > 0 {
        (ci.roi.width, ci.roi.height)
    } else {
        (ci.width, ci.height)
    }
}

/// An IMU sample as bpins uses it: the camera's tilt (CONVENTIONS.md) and the
/// variances of roll and pitch, rad² (REP 145: the orientation covariance's
/// diagonal about x and y of the IMU's frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tilt {
    pub tilt_x_deg: f64,
    pub tilt_y_deg: f64,
    pub roll_var_rad2: f64,
    pub pitch_var_rad2: f64,
}

impl Tilt {
    /// 1σ of each tilt angle for the compass (the larger of the two), degrees.
    pub fn sigma_deg(&self) -> f64 {
        self.roll_var_rad2.max(self.pitch_var_rad2).sqrt().to_degrees()
    }
}

/// The orientation of `imu` as a unit quaternion (x, y, z, w) and its roll and
/// pitch variances, checked: finite, not "not provided" (`covariance[0]` = −1), a
/// quaternion of norm 1 ± 1 %.
pub fn imu_orientation(imu: &Imu) -> Result<([f64; 4], f64, f64), String> {
    let q = imu.orientation;
    let c = imu.orientation_covariance;
    if c[0] == -1.0 {
        return Err("orientation not provided (orientation_covariance[0] = −1, REP 145)".into());
    }
    let v = [q.x, q.y, q.z, q.w];
    if v.iter().chain(c.iter()).any(|x| !x.is_finite()) {
        return Err(format!("orientation {v:?} or its covariance holds NaN or infinity"));
    }
    let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    if (n - 1.0).abs() > 0.01 {
        return Err(format!("orientation quaternion of norm {n}: not a rotation"));
    }
    if c[0] < 0.0 || c[4] < 0.0 {
        return Err(format!("negative variance in orientation_covariance {c:?}"));
    }
    Ok((v.map(|x| x / n), c[0], c[4]))
}

/// The tilt of a unit quaternion of the body frame of [`crate::rep103`].
pub fn tilt_of(q: [f64; 4], roll_var_rad2: f64, pitch_var_rad2: f64) -> Result<Tilt, String> {
    let (tilt_x_deg, tilt_y_deg) = rep103::tilt_from_enu(q);
    if tilt_x_deg.abs() >= 90.0 || tilt_y_deg.abs() >= 90.0 {
        return Err(format!("tilt ({tilt_x_deg:.1}°, {tilt_y_deg:.1}°): the camera looks below the horizon"));
    }
    Ok(Tilt { tilt_x_deg, tilt_y_deg, roll_var_rad2, pitch_var_rad2 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgs::{Header, RegionOfInterest};
    use std::borrow::Cow;

    fn image(encoding: &str, big: u8, w: u32, h: u32, step: u32, data: Vec<u8>) -> Image<'static> {
        Image {
            header: Header::default(),
            height: h,
            width: w,
            encoding: encoding.into(),
            is_bigendian: big,
            step,
            data: Cow::Owned(data),
        }
    }

    #[test]
    fn mono16_of_either_byte_order_and_any_step_reads_the_same_dn() {
        let dn: Vec<u16> = (0..12).map(|i| 1000 + 7 * i).collect();
        let mut scratch = Vec::new();
        for (big, step) in [(0u8, 8u32), (1, 8), (0, 10), (1, 13)] {
            let mut data = Vec::new();
            for v in 0..3 {
                let mut row: Vec<u8> = dn[v * 4..][..4]
                    .iter()
                    .flat_map(|x| if big == 1 { x.to_be_bytes() } else { x.to_le_bytes() })
                    .collect();
                row.resize(step as usize, 0xAB);
                data.extend(row);
            }
            // The same bytes at an odd address too (as in a file's memory map).
            let mut odd = vec![0u8; data.len() + 1];
            odd[1..].copy_from_slice(&data);
            let im = image("mono16", big, 4, 3, step, data);
            let mut im_odd = im.clone();
            im_odd.data = Cow::Borrowed(&odd[1..]);
            assert_eq!(im_odd.data.as_ptr() as usize % 2, 1);
            for im in [&im, &im_odd] {
                match mosaic(im, None, &mut scratch).unwrap() {
                    Mosaic::U16(r) => {
                        let packed: Vec<u16> = (0..3).flat_map(|v| r.data[v * r.stride..][..4].to_vec()).collect();
                        assert_eq!(packed, dn, "big-endian {big}, step {step}");
                    }
                    Mosaic::U8(_) => panic!("u8"),
                }
            }
        }
        let im = image("mono8", 0, 4, 3, 5, (0..15).collect());
        match mosaic(&im, None, &mut scratch).unwrap() {
            Mosaic::U8(r) => assert_eq!((r.stride, r.data[5], r.data[13]), (5, 5, 13)),
            Mosaic::U16(_) => panic!("u16"),
        }
        for (im, want) in [
            (image("rgb8", 0, 4, 3, 12, vec![0; 36]), "encoding `rgb8`"),
            (image("mono16", 0, 4, 3, 6, vec![0; 36]), "step 6 bytes is shorter"),
            (image("mono16", 0, 4, 3, 8, vec![0; 20]), "truncated image"),
            (image("mono16", 2, 4, 3, 8, vec![0; 24]), "is_bigendian = 2"),
            (image("mono8", 0, 0, 3, 8, vec![]), "empty image"),
        ] {
            let e = mosaic(&im, None, &mut scratch).err().expect("refused");
            assert!(e.contains(want), "{e}");
        }
    }

    #[test]
    fn bayer_images_are_the_raw_colour_mosaic_of_a_colour_sensor_only() {
        use bpins_core::sensor::Band::{B, G, R};
        assert_eq!(encoding_tiles("bayer_rggb8"), Some([[R, G], [G, B]]));
        assert_eq!(encoding_tiles("bayer_grbg16"), Some([[G, R], [B, G]]));
        assert_eq!(encoding_tiles("bayer_gbrg8"), Some([[G, B], [R, G]]));
        assert_eq!(encoding_tiles("bayer_bggr16"), Some([[B, G], [G, R]]));
        assert_eq!(
            (encoding_tiles("bayer_xyzw8"), encoding_tiles("mono8"), encoding_tiles("bayer_")),
            (None, None, None)
        );
        assert_eq!(
            (encoding_bits("bayer_rggb16"), encoding_bits("bayer_rggb8"), encoding_bits("rgb8")),
            (Some(16), Some(8), None)
        );
        let mut scratch = Vec::new();
        let rggb = ColourTiles::imx250myr();
        // Read as it is, byte for byte the mono8 image's pixels, for the sensor it names.
        let im = image("bayer_rggb8", 0, 4, 3, 4, (0..12).collect());
        match mosaic(&im, Some(&rggb), &mut scratch).unwrap() {
            Mosaic::U8(r) => assert_eq!((r.data[5], r.data[11]), (5, 11)),
            Mosaic::U16(_) => panic!("u16"),
        }
        // Never as a monochrome sensor's, nor another colour layout's.
        let e = mosaic(&im, None, &mut scratch).err().expect("refused");
        assert!(e.contains("monochrome") && e.contains("RGGB"), "{e}");
        let grbg = ColourTiles { tiles: encoding_tiles("bayer_grbg8").unwrap(), ..rggb.clone() };
        let e = mosaic(&im, Some(&grbg), &mut scratch).err().expect("refused");
        assert!(e.contains("RGGB") && e.contains("GRBG"), "{e}");
        // A mono image of a colour sensor is read with the layout the sensor gives.
        assert!(mosaic(&image("mono8", 0, 4, 3, 4, vec![0; 12]), Some(&rggb), &mut scratch).is_ok());
    }

    #[test]
    fn camera_info_maps_to_projections_or_is_refused_by_name() {
        let mut ci = CameraInfo {
            width: 612,
            height: 512,
            distortion_model: "plumb_bob".into(),
            d: vec![-0.1, 0.02, 0.0, 0.0, 0.0],
            k: [580.0, 0.0, 305.5, 0.0, 580.0, 255.5, 0.0, 0.0, 1.0],
            ..Default::default()
        };
        let i = intrinsics(&ci).unwrap();
        assert_eq!(
            (i.projection, i.f_px, i.cx_px, i.cy_px, i.distortion),
            (Projection::Pinhole, 580.0, 305.5, 255.5, [-0.1, 0.02])
        );
        ci.roi = RegionOfInterest { x_offset: 100, y_offset: 50, width: 200, height: 100, do_rectify: false };
        let i = intrinsics(&ci).unwrap();
        assert_eq!((i.cx_px, i.cy_px), (205.5, 205.5));
        assert_eq!(camera_size_px(&ci), (200, 100));
        ci.roi = RegionOfInterest::default();
        ci.distortion_model = "equidistant".into();
        ci.d = vec![0.05, -0.01, 0.0, 0.0];
        assert_eq!(intrinsics(&ci).unwrap().projection, Projection::Equidistant);
        for (model, d, want) in [
            ("plumb_bob", vec![0.1, 0.0, 0.001, 0.0, 0.0], "p1 = 0.001 is not modelled"),
            ("equidistant", vec![0.1, 0.0, 0.0, 0.2], "k4 = 0.2 is not modelled"),
            ("rational_polynomial", vec![0.0; 8], "`rational_polynomial` cannot be mapped"),
        ] {
            let c = CameraInfo { distortion_model: model.into(), d, ..ci.clone() };
            let e = intrinsics(&c).unwrap_err();
            assert!(e.contains(want), "{e}");
        }
        let c = CameraInfo { binning_x: 2, ..ci.clone() };
        assert!(intrinsics(&c).unwrap_err().contains("binning"));
        let c = CameraInfo { k: [580.0, 0.0, 305.5, 0.0, 600.0, 255.5, 0.0, 0.0, 1.0], ..ci.clone() };
        assert!(intrinsics(&c).unwrap_err().contains("square pixels"));
    }

    #[test]
    fn imu_orientations_are_checked() {
        let mut imu = Imu::default();
        imu.orientation.w = 1.0;
        imu.orientation_covariance[0] = 1e-4;
        imu.orientation_covariance[4] = 4e-4;
        let (q, vr, vp) = imu_orientation(&imu).unwrap();
        assert_eq!((q, vr, vp), ([0.0, 0.0, 0.0, 1.0], 1e-4, 4e-4));
        let t = tilt_of(q, vr, vp).unwrap();
        assert!((t.sigma_deg() - 0.02f64.to_degrees()).abs() < 1e-12);
        imu.orientation.x = f64::NAN;
        assert!(imu_orientation(&imu).unwrap_err().contains("NaN"));
        imu.orientation.x = 0.0;
        imu.orientation_covariance[0] = -1.0;
        assert!(imu_orientation(&imu).unwrap_err().contains("not provided"));
    }
}
