//! Where the per-pixel chain runs: a [`Backend`] renders frames and runs the seed
//! paper's sweep. [`Cpu`] is the rayon reference in this crate; `bpins-gpu`'s `Gpu`
//! implements the same trait with the WGSL twin, so a program (the CLI's `run` and
//! `simulate` among them) picks a backend without knowing which it got.
//!
//! ```
//! use bpins_core::internal::backend::{Backend, Cpu};
//! use bpins_core::internal::chain::ChainFrame;
//! # use bpins_core::camera::{Intrinsics, Projection};
//! # use bpins_core::internal::chain::Scene;
//! # let intr = Intrinsics::new(Projection::Pinhole, 300.0, 31.5, 23.5);
//! # let scene = Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 0.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.6 };
//! let frame = ChainFrame::noise_free(&Default::default(), &intr, &scene);
//! let backend: Box<dyn Backend> = Box::new(Cpu);
//! let dn = backend.render_mosaic(&[frame], 64, 48, &bpins_core::sensor::DEFAULT_MOSAIC)?;
//! assert_eq!((backend.name(), dn[0].len()), ("cpu", 64 * 48));
//! # Ok::<(), bpins_core::Error>(())
//! ```

use crate::chain::ChainFrame;
use crate::error::Result;
use crate::montecarlo::{Source, SweepConfig, TrialResult};
use crate::sensor::{Channel, ColourTiles};
use crate::simulate::SkyMaps;

/// A compute backend for the per-pixel chain. Errors are the core's
/// ([`crate::Error::Backend`] for what a backend itself cannot do).
pub trait Backend: Send + Sync {
    /// A short name: `cpu`, `gpu`.
    fn name(&self) -> &str;

    /// DoFP mosaics (`w × h` DN, row-major) of `frames`, bit-identical per seed.
    fn render_mosaic(
        &self,
        frames: &[ChainFrame],
        w: usize,
        h: usize,
        mosaic: &[[Channel; 2]; 2],
    ) -> Result<Vec<Vec<f32>>>;

    /// Colour-polarization DoFP mosaics (`w × h` DN, row-major; CONVENTIONS.md
    /// `colour_tiles`), one per element of `frames`: its three band frames
    /// ([`ChainFrame::bands`], by [`Band::index`](crate::sensor::Band::index)), each
    /// pixel through the band over it, bit-identical per seed
    /// ([`crate::simulate::render_colour_mosaic`]).
    ///
    /// By default each band's whole mosaic ([`Backend::render_mosaic`]) and each pixel
    /// taken from its band's: the same numbers, since the bands' frames share the
    /// noise keys and a pixel's DN is its own, except where a mosaic effect
    /// (`crosstalk`) mixes a pixel with neighbours of other bands, which this default
    /// refuses ([`crate::Error::Backend`]). The CPU and `bpins-gpu`'s `Gpu` override it
    /// and render that too (each neighbour through its own band's frame).
    fn render_colour_mosaic(
        &self,
        frames: &[[ChainFrame; 3]],
        w: usize,
        h: usize,
        mosaic: &[[Channel; 2]; 2],
        tiles: &ColourTiles,
    ) -> Result<Vec<Vec<f32>>> {
        if frames.iter().flatten().any(ChainFrame::has_mosaic_effects) {
            return Err(crate::Error::Backend {
                backend: self.name().to_string(),
                message: "not yet: a mosaic effect (crosstalk) on a colour sensor mixes bands, which this backend \
                          renders one band at a time; use the CPU or GPU backend"
                    .into(),
            });
        }
        let bands = tiles.bands();
        let all: Vec<ChainFrame> = frames.iter().flat_map(|f| bands.iter().map(|b| f[b.index()].clone())).collect();
        let rendered = self.render_mosaic(&all, w, h, mosaic)?;
        Ok(rendered
            .chunks(bands.len())
            .map(|per_band| {
                let mut out = vec![0f32; w * h];
                for (k, px) in out.iter_mut().enumerate() {
                    let b = tiles.band_at(k % w.max(1), k / w.max(1));
                    let i = bands.iter().position(|x| *x == b).expect("a tile's band is among the tiles' bands");
                    *px = per_band[i][k];
                }
                out
            })
            .collect())
    }

    /// Colocated frames: per frame one `w × h` plane per channel of `channels`.
    fn render_colocated(
        &self,
        frames: &[ChainFrame],
        w: usize,
        h: usize,
        channels: &[Channel],
    ) -> Result<Vec<Vec<Vec<f32>>>>;

    /// The sky's AoP, DoLP and AoE maps of each frame on a `w × h` sensor, without
    /// rendering DN ([`crate::simulate::sky_maps`]).
    fn sky_maps(&self, frames: &[ChainFrame], w: usize, h: usize) -> Result<Vec<SkyMaps>>;

    /// The seed paper's Monte Carlo sweep (`bpins run`).
    fn run_sweep(
        &self,
        cfg: &SweepConfig,
        sources: &[Source],
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Vec<TrialResult>>;
}

/// The rayon reference implementation.
#[derive(Clone, Copy, Debug, Default)]
pub struct Cpu;

impl Backend for Cpu {
    fn name(&self) -> &str {
        "cpu"
    }

    fn render_mosaic(
        &self,
        frames: &[ChainFrame],
        w: usize,
        h: usize,
        mosaic: &[[Channel; 2]; 2],
    ) -> Result<Vec<Vec<f32>>> {
        Ok(frames.iter().map(|f| crate::simulate::render_mosaic(f, w, h, mosaic)).collect())
    }

    fn render_colour_mosaic(
        &self,
        frames: &[[ChainFrame; 3]],
        w: usize,
        h: usize,
        mosaic: &[[Channel; 2]; 2],
        tiles: &ColourTiles,
    ) -> Result<Vec<Vec<f32>>> {
        Ok(frames.iter().map(|f| crate::simulate::render_colour_mosaic(f, w, h, mosaic, tiles)).collect())
    }

    fn render_colocated(
        &self,
        frames: &[ChainFrame],
        w: usize,
        h: usize,
        channels: &[Channel],
    ) -> Result<Vec<Vec<Vec<f32>>>> {
        Ok(frames.iter().map(|f| crate::simulate::render_colocated(f, w, h, channels)).collect())
    }

    fn sky_maps(&self, frames: &[ChainFrame], w: usize, h: usize) -> Result<Vec<SkyMaps>> {
        Ok(frames.iter().map(|f| crate::simulate::sky_maps(f, w, h)).collect())
    }

    fn run_sweep(
        &self,
        cfg: &SweepConfig,
        sources: &[Source],
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Vec<TrialResult>> {
        crate::montecarlo::run_sweep(cfg, sources, progress)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::tests::{intrinsics, scene};
    use crate::chain::NoiseIndex;
    use crate::effects::EffectSet;
    use crate::sensor::{Response, DEFAULT_MOSAIC};

    /// A backend with the trait's default colour path over the CPU's mosaics.
    struct OneBandAtATime;

    impl Backend for OneBandAtATime {
        fn name(&self) -> &str {
            "bands"
        }
        fn render_mosaic(&self, f: &[ChainFrame], w: usize, h: usize, m: &[[Channel; 2]; 2]) -> Result<Vec<Vec<f32>>> {
            Cpu.render_mosaic(f, w, h, m)
        }
        fn render_colocated(&self, f: &[ChainFrame], w: usize, h: usize, c: &[Channel]) -> Result<Vec<Vec<Vec<f32>>>> {
            Cpu.render_colocated(f, w, h, c)
        }
        fn sky_maps(&self, f: &[ChainFrame], w: usize, h: usize) -> Result<Vec<SkyMaps>> {
            Cpu.sky_maps(f, w, h)
        }
        fn run_sweep(
            &self,
            cfg: &SweepConfig,
            s: &[Source],
            p: &(dyn Fn(usize, usize) + Sync),
        ) -> Result<Vec<TrialResult>> {
            Cpu.run_sweep(cfg, s, p)
        }
    }

    fn band_frames(set: &EffectSet, frame: u32) -> [ChainFrame; 3] {
        let resp = Response {
            read_noise_dn: 1.0,
            system_gain_dn_per_e: 0.1,
            quantize: true,
            bit_depth: 12,
            ..Response::ideal(3000.0)
        };
        let (model, sc) = (set.model(), scene());
        ChainFrame::new(&model, &intrinsics(), &sc, &resp, NoiseIndex { seed: 5, trial: 0, frame }).bands(&model, &sc)
    }

    #[test]
    fn the_default_colour_path_is_the_cpus_and_refuses_crosstalk_across_bands() {
        let mut set = EffectSet::new();
        set.set("sky_spectrum", "radiance_b", 1.25).unwrap();
        set.set("sky_spectrum", "dmax_b", 0.886).unwrap();
        set.set("band_response", "qe_r", 0.8).unwrap();
        set.set("band_response", "eps_b", 0.008).unwrap();
        let frames = [band_frames(&set, 0), band_frames(&set, 1)];
        let tiles = ColourTiles::imx250myr();
        let (w, h) = (45, 31);
        let cpu = Cpu.render_colour_mosaic(&frames, w, h, &DEFAULT_MOSAIC, &tiles).unwrap();
        assert_eq!(OneBandAtATime.render_colour_mosaic(&frames, w, h, &DEFAULT_MOSAIC, &tiles).unwrap(), cpu);
        assert_ne!(cpu[0], cpu[1]);
        set.set("crosstalk", "c", 0.01).unwrap();
        let e = OneBandAtATime.render_colour_mosaic(&[band_frames(&set, 0)], w, h, &DEFAULT_MOSAIC, &tiles);
        assert!(e.unwrap_err().to_string().contains("crosstalk"));
    }
}
