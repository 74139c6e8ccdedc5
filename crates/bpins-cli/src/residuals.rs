//! Residual maps on disk: EXR (the numbers: stacked over frames, and each frame's in
//! `frames/f<k>_residual_{dn,pol}.exr`, written as it is made) and PNG (a diverging colour scale a person reads at a glance: blue
//! where the data lie below the model, red above, grey masked), and the residual
//! profiles in sky space (`crate::profiles`).

use anyhow::Context;
use bpins_core::tool::capture::write_exr_layers;
use bpins_core::tool::fit::{FrameMaps, ResidualMaps};
use rayon::prelude::*;
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

/// Writes the stacked `maps` into `dir` (EXR, PNG, profiles CSV and SVG); `frames`:
/// what [`write_frame`] wrote of each frame, and every frame `maps` still holds is
/// written now.
pub fn write(dir: &Path, maps: &ResidualMaps, mut frames: Vec<Vec<Written>>) -> anyhow::Result<Figures> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    // The two EXR files (each compressed block by block in parallel) beside the four
    // PNGs (encoded in parallel): every map of the folder on every core.
    let excess: Vec<f32> = maps.dn_chi2.iter().map(|x| x - 1.0).collect();
    let (exr, pngs) = rayon::join(
        || -> anyhow::Result<()> {
            write_exr_layers(
                &dir.join("residual_dn.exr"),
                maps.width_px,
                maps.height_px,
                &[("dn_z", &maps.dn_z), ("dn_chi2", &maps.dn_chi2)],
            )?;
            write_exr_layers(
                &dir.join("residual_pol.exr"),
                maps.pol_width,
                maps.pol_height,
                &[("AoP_deg", &maps.aop_deg), ("DoLP", &maps.dolp)],
            )?;
            Ok(())
        },
        || {
            [
                ("residual_chi2.png", "χ² per sample − 1", &excess, maps.width_px, maps.height_px, "", 0.1, 8),
                ("residual_dn.png", "DN residual / σ", &maps.dn_z, maps.width_px, maps.height_px, "σ", 0.1, 8),
                ("residual_aop.png", "AoP residual", &maps.aop_deg, maps.pol_width, maps.pol_height, "°", 0.01, 4),
                ("residual_dolp.png", "DoLP residual", &maps.dolp, maps.pol_width, maps.pol_height, "", 0.0005, 4),
            ]
            .into_par_iter()
            .map(|(name, what, data, w, h, unit, floor, bin)| {
                let scale = binned_png(&dir.join(name), data, w, h, bin, floor)?;
                Ok(Written { png: name.to_string(), what, scale, unit })
            })
            .collect::<anyhow::Result<Vec<_>>>()
        },
    );
    exr?;
    let out = pngs?;
    for f in &maps.frames {
        let k = frames.len();
        frames.push(write_frame(dir, k, maps, f)?);
    }
    let profiles_svg = crate::profiles::write(dir, &maps.profiles)?;
    Ok(Figures { maps: out, frames, profiles_svg })
}

/// Writes frame `k`'s DN, AoP and DoLP residual `f` (sizes as in `size`) into
/// `dir/frames/`: EXR `f<k>_residual_dn.exr` (layer `dn_z`) and `f<k>_residual_pol.exr`
/// (`AoP_deg`, `DoLP`), PNG `f<k>_{dn,aop,dolp}.png`.
pub fn write_frame(dir: &Path, k: usize, size: &ResidualMaps, f: &FrameMaps) -> anyhow::Result<Vec<Written>> {
    let fd = dir.join("frames");
    std::fs::create_dir_all(&fd).with_context(|| format!("creating {}", fd.display()))?;
    let (w, h, pw, ph) = (size.width_px, size.height_px, size.pol_width, size.pol_height);
    // The EXR files beside the PNGs, each set in parallel (as in [`write`]).
    let (exr, row) = rayon::join(
        || -> anyhow::Result<()> {
            write_exr_layers(&fd.join(format!("f{k}_residual_dn.exr")), w, h, &[("dn_z", &f.dn_z)])?;
            write_exr_layers(
                &fd.join(format!("f{k}_residual_pol.exr")),
                pw,
                ph,
                &[("AoP_deg", &f.aop_deg), ("DoLP", &f.dolp)],
            )
            .map_err(Into::into)
        },
        || {
            [
                (format!("frames/f{k}_dn.png"), "DN residual / σ", &f.dn_z, w, h, "σ", 0.3, 8),
                (format!("frames/f{k}_aop.png"), "AoP residual", &f.aop_deg, pw, ph, "°", 0.02, 4),
                (format!("frames/f{k}_dolp.png"), "DoLP residual", &f.dolp, pw, ph, "", 0.001, 4),
            ]
            .into_par_iter()
            .map(|(name, what, data, w, h, unit, floor, bin)| {
                let scale = binned_png(&dir.join(&name), data, w, h, bin, floor)?;
                Ok(Written { png: name, what, scale, unit })
            })
            .collect::<anyhow::Result<Vec<_>>>()
        },
    );
    exr?;
    let row = row?;
    Ok(row)
}

/// The residual maps of `state` under `opts` on every pixel of `frames`, each frame's
/// written into `dir` as it is made ([`write_frame`]), then the stacked ones
/// ([`write`]): one frame's maps in memory at a time.
pub fn compute_and_write(
    dir: &Path,
    c: &bpins_core::Capture,
    frames: &bpins_core::tool::fit::FitFrames,
    opts: &bpins_core::FitOptions,
    fit: &bpins_core::FitResult,
) -> anyhow::Result<(Figures, ResidualMaps)> {
    // The map sizes, for the frames written before the stacked maps exist.
    let g = &c.sensor.geometry;
    let dofp = matches!(c.sensor.layout, bpins_core::sensor::Layout::Dofp { .. });
    let (pw, ph) = if dofp { (g.width_px / 2, g.height_px / 2) } else { (g.width_px, g.height_px) };
    let size = ResidualMaps {
        width_px: g.width_px,
        height_px: g.height_px,
        dn_z: Vec::new(),
        dn_chi2: Vec::new(),
        pol_width: pw,
        pol_height: ph,
        aop_deg: Vec::new(),
        dolp: Vec::new(),
        frames: Vec::new(),
        profiles: Vec::new(),
    };
    let mut written = Vec::new();
    let mut failed = None;
    let maps = bpins_core::tool::fit::residual_maps_of(c, frames, opts, &fit.state, fit.noise, &mut |k, f| {
        if failed.is_none() {
            match write_frame(dir, k, &size, &f) {
                Ok(w) => written.push(w),
                Err(e) => failed = Some(e),
            }
        }
    })
    .context("residual maps")?;
    if let Some(e) = failed {
        return Err(e);
    }
    let figures = write(dir, &maps, written)?;
    Ok((figures, maps))
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
