//! Residual maps on disk: EXR (the numbers: stacked over frames, and each frame's as
//! layers `f<k>_…`) and PNG (a diverging colour scale a person reads at a glance: blue
//! where the data lie below the model, red above, grey masked), and the residual
//! profiles in sky space (`crate::profiles`).

use anyhow::Context;
use bpins_core::capture::write_exr_layers;
use bpins_core::fit::ResidualMaps;
use std::path::Path;

/// One written map: its PNG file name (relative to the step folder) and its scale.
pub struct Written {
    pub png: String,
    pub what: &'static str,
    pub scale: f64,
    pub unit: &'static str,
}

/// What [`write()`] wrote for a report: the map PNGs with their colour scales and the
/// profiles' SVG (file names relative to the folder).
pub struct Figures {
    /// Stacked over frames: χ² excess, DN, AoP, DoLP.
    pub maps: Vec<Written>,
    /// Each frame's DN, AoP and DoLP residual.
    pub frames: Vec<Vec<Written>>,
    pub profiles_svg: String,
}

/// Writes `maps` into `dir` (EXR, PNG, profiles CSV and SVG).
pub fn write(dir: &Path, maps: &ResidualMaps) -> anyhow::Result<Figures> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let names: Vec<[String; 3]> =
        (0..maps.frames.len()).map(|k| [format!("f{k}_dn_z"), format!("f{k}_AoP_deg"), format!("f{k}_DoLP")]).collect();
    let mut dn_layers: Vec<(&str, &[f32])> = vec![("dn_z", &maps.dn_z), ("dn_chi2", &maps.dn_chi2)];
    let mut pol_layers: Vec<(&str, &[f32])> = vec![("AoP_deg", &maps.aop_deg), ("DoLP", &maps.dolp)];
    for (n, f) in names.iter().zip(&maps.frames) {
        dn_layers.push((&n[0], &f.dn_z));
        pol_layers.push((&n[1], &f.aop_deg));
        pol_layers.push((&n[2], &f.dolp));
    }
    write_exr_layers(&dir.join("residual_dn.exr"), maps.width_px, maps.height_px, &dn_layers)?;
    let excess: Vec<f32> = maps.dn_chi2.iter().map(|x| x - 1.0).collect();
    write_exr_layers(&dir.join("residual_pol.exr"), maps.pol_width, maps.pol_height, &pol_layers)?;
    let mut out = Vec::new();
    for (name, what, data, w, h, unit, floor, bin) in [
        ("residual_chi2.png", "χ² per sample − 1", &excess, maps.width_px, maps.height_px, "", 0.1, 8),
        ("residual_dn.png", "DN residual / σ", &maps.dn_z, maps.width_px, maps.height_px, "σ", 0.1, 8),
        ("residual_aop.png", "AoP residual", &maps.aop_deg, maps.pol_width, maps.pol_height, "°", 0.01, 4),
        ("residual_dolp.png", "DoLP residual", &maps.dolp, maps.pol_width, maps.pol_height, "", 0.0005, 4),
    ] {
        let scale = binned_png(&dir.join(name), data, w, h, bin, floor)?;
        out.push(Written { png: name.to_string(), what, scale, unit });
    }
    // Each frame's DN, AoP and DoLP residual (frames/f<k>_….png).
    let mut frames = Vec::new();
    if !maps.frames.is_empty() {
        std::fs::create_dir_all(dir.join("frames")).with_context(|| format!("creating {}/frames", dir.display()))?;
    }
    for (k, f) in maps.frames.iter().enumerate() {
        let mut row = Vec::new();
        for (name, what, data, w, h, unit, floor, bin) in [
            (format!("frames/f{k}_dn.png"), "DN residual / σ", &f.dn_z, maps.width_px, maps.height_px, "σ", 0.3, 8),
            (format!("frames/f{k}_aop.png"), "AoP residual", &f.aop_deg, maps.pol_width, maps.pol_height, "°", 0.02, 4),
            (format!("frames/f{k}_dolp.png"), "DoLP residual", &f.dolp, maps.pol_width, maps.pol_height, "", 0.001, 4),
        ] {
            let scale = binned_png(&dir.join(&name), data, w, h, bin, floor)?;
            row.push(Written { png: name, what, scale, unit });
        }
        frames.push(row);
    }
    let profiles_svg = crate::profiles::write(dir, &maps.profiles)?;
    Ok(Figures { maps: out, frames, profiles_svg })
}

/// Writes `data` (w × h, NaN masked) to `path` as a PNG binned to blocks of `bin` px
/// (mean of the finite values, so that a systematic misfit stands out of the per-pixel
/// noise; the EXR keeps every pixel) on a symmetric diverging scale of four RMS of the
/// binned map, at least `floor`; returns that scale.
fn binned_png(path: &Path, data: &[f32], w: u32, h: u32, bin: u32, floor: f64) -> anyhow::Result<f64> {
    let b = Binned::new(data, w, h, bin);
    let scale = b.scale(floor);
    b.write_png(path, scale)?;
    Ok(scale)
}

/// A map binned to blocks (mean of the finite values; NaN where none).
struct Binned {
    values: Vec<f64>,
    w: u32,
    h: u32,
}

impl Binned {
    fn new(data: &[f32], w: u32, h: u32, bin: u32) -> Binned {
        let (bw, bh) = (w.div_ceil(bin), h.div_ceil(bin));
        let mut sums = vec![(0.0f64, 0u32); (bw * bh) as usize];
        for y in 0..h {
            for x in 0..w {
                let t = data[(y * w + x) as usize];
                if t.is_finite() {
                    let b = &mut sums[((y / bin) * bw + x / bin) as usize];
                    b.0 += t as f64;
                    b.1 += 1;
                }
            }
        }
        let values = sums.iter().map(|&(s, n)| if n > 0 { s / n as f64 } else { f64::NAN }).collect();
        Binned { values, w: bw, h: bh }
    }

    /// Four RMS of the binned values, at least `floor`.
    fn scale(&self, floor: f64) -> f64 {
        let v: Vec<f64> = self.values.iter().copied().filter(|x| x.is_finite()).collect();
        let rms = (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt();
        (4.0 * rms).max(floor)
    }

    fn write_png(&self, path: &Path, scale: f64) -> anyhow::Result<()> {
        let img = image::RgbImage::from_fn(self.w, self.h, |x, y| {
            image::Rgb(colour(self.values[(y * self.w + x) as usize] / scale))
        });
        let mut png = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .with_context(|| format!("encoding {}", path.display()))?;
        crate::write_output(path, &png)
    }
}

/// The χ² per sample − 1 of `before` and `after` (stacked over frames), on one colour
/// scale so that the two compare at a glance: `dir/before_chi2.png` and
/// `dir/after_chi2.png` (names relative to `dir`'s parent: `<dir name>/…`).
pub fn before_after(dir: &Path, before: &ResidualMaps, after: &ResidualMaps) -> anyhow::Result<[Written; 2]> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let binned = [before, after].map(|m| {
        let excess: Vec<f32> = m.dn_chi2.iter().map(|x| x - 1.0).collect();
        Binned::new(&excess, m.width_px, m.height_px, 8)
    });
    let scale = binned.iter().map(|b| b.scale(0.1)).fold(0.0, f64::max);
    let folder = dir.file_name().map_or(String::new(), |n| format!("{}/", n.to_string_lossy()));
    let mut out = Vec::new();
    for (b, name) in binned.iter().zip(["before_chi2.png", "after_chi2.png"]) {
        b.write_png(&dir.join(name), scale)?;
        out.push(Written { png: format!("{folder}{name}"), what: "χ² per sample − 1", scale, unit: "" });
    }
    Ok(out.try_into().unwrap_or_else(|_| unreachable!("two maps")))
}

/// Blue (−1) – white (0) – red (+1); grey for NaN.
fn colour(t: f64) -> [u8; 3] {
    if !t.is_finite() {
        return [128, 128, 128];
    }
    let t = t.clamp(-1.0, 1.0);
    let fade = |a: f64| (255.0 * (1.0 - a.abs())).round() as u8;
    if t >= 0.0 {
        [255, fade(t), fade(t)]
    } else {
        [fade(t), fade(t), 255]
    }
}
