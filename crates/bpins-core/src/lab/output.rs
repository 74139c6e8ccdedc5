//! The maps of a lab calibration on disk: one float OpenEXR file holding every map
//! (`maps.exr`, full precision) and one 8-bit greyscale PNG per map (`png/<name>.png`,
//! for eyes and the report), each stretched over its 0.5 … 99.5 % range (the range is
//! returned, so that the report can print it). Written whole or not at all
//! (`crate::output`).

use std::path::Path;

use image::{ImageBuffer, Luma};

use super::LabCalibration;
use crate::output::{write_with, Replace};
use crate::{Error, Result};

/// One map as written: its name, unit and the value range its PNG spans.
#[derive(Clone, Debug, serde::Serialize)]
pub struct MapFile {
    pub name: String,
    pub unit: String,
    pub png: String,
    pub low: f64,
    pub high: f64,
}

/// Every map of `cal` by name and unit: the pixel maps, the analyzer angles' offset
/// from their channel's nominal angle (`analyzer_offset_deg`, what a picture can
/// show), the 1σ maps, the dark noise.
pub fn maps_of(cal: &LabCalibration) -> Vec<(String, &'static str, std::borrow::Cow<'_, [f32]>)> {
    use std::borrow::Cow;
    let mut out: Vec<(String, &'static str, Cow<[f32]>)> = Vec::new();
    let units = [("offset_dn", "DN"), ("gain", "1"), ("analyzer_deg", "deg"), ("eps", "1")];
    for (name, m) in cal.maps.present() {
        let unit = units.iter().find(|u| u.0 == name).map_or("1", |u| u.1);
        out.push((name.to_string(), unit, Cow::Borrowed(m)));
    }
    let px = &cal.maps;
    if let Some(a) = &px.analyzer_deg {
        let off = a
            .iter()
            .enumerate()
            .map(|(i, &x)| {
                let nominal =
                    crate::sensor::Layout::dofp_channel(&px.mosaic, i % px.width_px, i / px.width_px).angle_deg();
                (x as f64 - nominal) as f32
            })
            .collect();
        out.push(("analyzer_offset_deg".into(), "deg", Cow::Owned(off)));
    }
    if let Some(s) = &cal.sigma {
        out.push(("analyzer_deg_sigma".into(), "deg", Cow::Borrowed(&s.analyzer_deg)));
        out.push(("eps_sigma".into(), "1", Cow::Borrowed(&s.eps)));
        out.push(("gain_sigma".into(), "1", Cow::Borrowed(&s.gain)));
    }
    if let Some(n) = cal.dark.as_ref().and_then(|d| d.noise_dn.as_deref()) {
        out.push(("dark_noise_dn".into(), "DN", Cow::Borrowed(n)));
    }
    out
}

/// Writes `dir/maps.exr` and `dir/png/<name>.png` for every map of `cal`.
pub fn write_maps(cal: &LabCalibration, dir: &Path) -> Result<Vec<MapFile>> {
    let (w, h) = (cal.maps.width_px as u32, cal.maps.height_px as u32);
    let maps = maps_of(cal);
    let layers: Vec<(&str, &[f32])> = maps.iter().map(|(n, _, m)| (n.as_str(), m.as_ref())).collect();
    crate::output::exr::write_exr_layers_fast(&dir.join("maps.exr"), w, h, &layers)?;
    let png_dir = dir.join("png");
    std::fs::create_dir_all(&png_dir).map_err(|e| Error::Io { path: png_dir.clone(), source: e })?;
    // One PNG per map, encoded in parallel (the EXR above compresses its blocks in
    // parallel too).
    use rayon::prelude::*;
    maps.par_iter()
        .map(|(name, unit, m)| {
            let mut finite: Vec<f32> = m.iter().copied().filter(|x| x.is_finite()).collect();
            let mut at = |q: f64| {
                if finite.is_empty() {
                    return 0.0;
                }
                let k = ((finite.len() - 1) as f64 * q) as usize;
                *finite.select_nth_unstable_by(k, f32::total_cmp).1 as f64
            };
            let (low, high) = (at(0.005), at(0.995));
            let span = if high > low { high - low } else { 1.0 };
            let px: Vec<u8> =
                m.iter().map(|&x| (((x as f64 - low) / span).clamp(0.0, 1.0) * 255.0).round() as u8).collect();
            let img: ImageBuffer<Luma<u8>, Vec<u8>> = ImageBuffer::from_raw(w, h, px).ok_or_else(|| Error::Encode {
                what: format!("map {name}"),
                message: format!("size does not match {w} × {h}"),
            })?;
            let rel = format!("png/{name}.png");
            let path = dir.join(&rel);
            write_with(&path, Replace::Allowed, |out| {
                img.write_to(out, image::ImageFormat::Png)
                    .map_err(|e| Error::Capture { path: path.clone(), message: format!("cannot write the PNG: {e}") })
            })?;
            Ok(MapFile { name: name.clone(), unit: (*unit).into(), png: rel, low, high })
        })
        .collect()
}
