//! `bpins maps CAPTURE --out DIR`: each frame's AoP, DoLP, intensity and AoE maps
//! (`bpins_core::maps`, the kernel of Python's `stokes_maps` and the C ABI), one
//! OpenEXR per frame. Frames stream: each is read and decoded on a worker while
//! others are mapped and written, so a capture of any length holds a few frames in
//! memory (about one per core), and each worker keeps its map buffers from frame to
//! frame. A colour-polarization capture (`colour_tiles`) gets each band's maps, from
//! its own pixels (`bpins_core::colour_maps_into`), as layers named with the band:
//! `AoP_deg_R`, `DoLP_R`, …, `AoE_deg_B`.

use crate::ensure_not_in_capture;
use anyhow::{bail, Context};
use bpins_core::compass::RawImage;
use bpins_core::sensor::{Channel, Layout};
use bpins_core::tool::capture::write_exr_layers_fast;
use bpins_core::Reconstructor;
use bpins_core::{colour_maps_into, colour_maps_size, ColourScratch};
use bpins_core::{stokes_maps_into, Interpolation, MapsConfig, MapsOut};
use bpins_core::{Capture, FrameData};
use rayon::prelude::*;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Capture folder holding capture.toml (bpins-capture/1), a DoFP sensor.
    capture: PathBuf,
    /// Output folder (never inside the capture): f<k>_maps.exr per frame (a colour
    /// capture: each band's maps, layers AoP_deg_R, DoLP_R, …).
    #[arg(long)]
    out: PathBuf,
    /// How each channel is found at a pixel: bilinear (each channel on its own
    /// lattice), superpixel (2 × 2 tiles, half size), opencv (polanalyser's
    /// demosaic, exactly) or opencv_ea (its edge-aware one, exactly; on a mono
    /// capture the same maps as opencv). A colour capture: bilinear, opencv and
    /// opencv_ea full size (polanalyser's COLOR_PolarRGB, COLOR_PolarRGB_EA),
    /// superpixel one value per 4 × 4 per band.
    #[arg(long, value_parser = crate::names::by_name(&Interpolation::ALL, Interpolation::name), default_value = "bilinear")]
    interpolation: Interpolation,
    /// Only these frames (0-based, comma-separated); default every frame.
    #[arg(long, value_delimiter = ',')]
    frames: Vec<usize>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let c = Capture::load(&a.capture).with_context(|| format!("reading {}", a.capture.display()))?;
    let mosaic = match &c.sensor.layout {
        Layout::Dofp { mosaic } => *mosaic,
        Layout::Colocated { .. } => bail!(
            "{}: a colocated sensor; `bpins maps` makes maps of DoFP mosaics (a colocated frame's channels \
             are already one image each: `bpins simulate --exr` shows their maps)",
            a.capture.display()
        ),
    };
    let frames: Vec<usize> = if a.frames.is_empty() { (0..c.frames.len()).collect() } else { a.frames.clone() };
    if let Some(&k) = frames.iter().find(|&&k| k >= c.frames.len()) {
        bail!(
            "--frames: frame {k} does not exist; the capture has {} frames (0…{})",
            c.frames.len(),
            c.frames.len().saturating_sub(1)
        );
    }
    ensure_not_in_capture(&a.out)?;
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let g = &c.sensor.geometry;
    let (w, h) = (g.width_px as usize, g.height_px as usize);
    let (pp_x, pp_y) = c.lens.principal_point_px;
    let cfg = MapsConfig {
        interpolation: a.interpolation,
        mosaic,
        full_scale_dn: c.sensor.full_scale_dn(),
        aoe_centre_px: [pp_x, pp_y],
    };
    let rec = Reconstructor::new(&Default::default(), c.sensor.black_level_dn, &Channel::ALL)?;
    let colour = c.sensor.colour.clone();
    // The maps' bands: one unnamed for a mono capture.
    let (bands, (mw, mh)) = match &colour {
        Some(t) => (t.bands().into_iter().map(Some).collect(), colour_maps_size(a.interpolation, w, h)),
        None => (vec![None], a.interpolation.maps_size(w, h)),
    };
    let layer = |name: &str, b: &Option<bpins_core::sensor::Band>| match b {
        Some(b) => format!("{name}_{}", b.name()),
        None => name.to_string(),
    };
    let names: Vec<[String; 4]> =
        bands.iter().map(|b| ["AoP_deg", "DoLP", "I_dn", "AoE_deg"].map(|n| layer(n, b))).collect();
    let pb = crate::progress::bar(frames.len() as u64, "maps");
    let t0 = std::time::Instant::now();
    // One frame per task, a task per core at a time: read and decode, map, write.
    frames.par_iter().with_max_len(1).try_for_each_init(
        || (vec![[(); 4].map(|_| vec![0f32; mw * mh]); bands.len()], ColourScratch::default()),
        |(bufs, scratch), &k| -> anyhow::Result<()> {
            let FrameData::Mosaic { dn, .. } = c.read_frame(k)? else {
                bail!("frame {k}: not a mosaic");
            };
            let raw = RawImage::packed(&dn, w, h);
            let mut outs: Vec<_> = bufs
                .iter_mut()
                .zip(&bands)
                .map(|([aop, dolp, int, aoe], b)| {
                    (
                        b.unwrap_or(bpins_core::sensor::Band::G),
                        MapsOut { aop_deg: aop, dolp, intensity_dn: int, aoe_deg: Some(aoe) },
                    )
                })
                .collect();
            match &colour {
                Some(t) => colour_maps_into(&raw, &rec, &cfg, t, scratch, &mut outs),
                None => stokes_maps_into(&raw, &rec, &cfg, outs.pop().expect("one band").1),
            }
            .with_context(|| format!("frame {k} ({})", c.frames[k].file.display()))?;
            drop(dn);
            let path = a.out.join(format!("f{k}_maps.exr"));
            let layers: Vec<(&str, &[f32])> = names
                .iter()
                .zip(bufs.iter())
                .flat_map(|(n, b)| n.iter().zip(b.iter()).map(|(n, b)| (n.as_str(), &b[..])))
                .collect();
            write_exr_layers_fast(&path, mw as u32, mh as u32, &layers)
                .with_context(|| format!("writing {}", path.display()))?;
            pb.inc(1);
            Ok(())
        },
    )?;
    pb.finish_and_clear();
    let s = t0.elapsed().as_secs_f64();
    // try_for_each stopped at the first error: here every frame was written.
    let n = frames.len();
    let what = match &colour {
        Some(t) => format!("each of bands {}", t.bands().iter().map(|b| b.name()).collect::<Vec<_>>().join(", ")),
        None => "one mono band".to_string(),
    };
    say!(
        "wrote {n} frames' maps ({mw} × {mh} px: AoP_deg, DoLP, I_dn, AoE_deg for {what}; {} interpolation) to {} \
         in {s:.2} s ({:.1} ms per frame)",
        a.interpolation.name(),
        a.out.display(),
        1e3 * s / n.max(1) as f64
    );
    Ok(())
}
