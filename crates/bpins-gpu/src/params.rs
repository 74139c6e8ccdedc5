//! Parameter blocks shared with WGSL: `#[repr(C)]` Pod structs built only from
//! `[f32; 4]` and `[u32; 4]` (no vec3 padding traps). f64 values travel as (hi, lo)
//! f32 pairs ([`Wide4`], reassembled by `wide()` in `shaders/common/math.wgsl`, exact to
//! ~2⁻⁴⁸): the chain runs in f64 on the device, because rounding to DN agrees with the
//! CPU only if the signal before rounding does to far better than f32's 6e-8.
//!
//! Keep every struct here in sync with the WGSL struct of the same name (named in each
//! doc comment); `tests::layouts_match_wgsl` checks sizes and member offsets with naga.

use crate::{GpuError, Result};
use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::effects::{
    AnalyzerParams, SkyParams, ANALYZER_COUNT, MOSAIC_COUNT, RAY_COUNT, SENSOR_COUNT, SKY_COUNT, SKY_WIDTH,
};
use bpins_core::sensor::{Channel, ColourTiles};
use bpins_core::twin::ChainFrame;
use bpins_core::twin::HeadingContext;
use bpins_core::twin::Reconstructor;
use bytemuck::{Pod, Zeroable};

/// Four f64 values as f32 (hi, lo) pairs; WGSL `Wide4` in `common/math.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Wide4 {
    pub hi: [f32; 4],
    pub lo: [f32; 4],
}

impl Wide4 {
    pub fn new(x: [f64; 4]) -> Self {
        let hi = x.map(|v| v as f32);
        let lo = [0, 1, 2, 3].map(|k| (x[k] - hi[k] as f64) as f32);
        Wide4 { hi, lo }
    }

    /// The values as the shader reassembles them.
    pub fn value(&self) -> [f64; 4] {
        [0, 1, 2, 3].map(|k| self.hi[k] as f64 + self.lo[k] as f64)
    }
}

/// The projection's id in WGSL (`PROJ_*` in `common/camera.wgsl`).
pub fn projection_id(p: Projection) -> f64 {
    match p {
        Projection::Pinhole => 0.0,
        Projection::Equidistant => 1.0,
        Projection::Equisolid => 2.0,
        Projection::Stereographic => 3.0,
    }
}

/// (f_px, cx_px, cy_px, projection id), as WGSL `intrinsics_from` reads them.
fn camera(i: &Intrinsics) -> Wide4 {
    Wide4::new([i.f_px, i.cx_px, i.cy_px, projection_id(i.projection)])
}

/// (k1, k2, 0, 0): the camera's radial distortion.
fn distortion(i: &Intrinsics) -> Wide4 {
    Wide4::new([i.distortion[0], i.distortion[1], 0.0, 0.0])
}

/// One frame of the chain; WGSL `FrameParams` in `common/chain.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FrameParams {
    pub camera: Wide4,
    pub distortion: Wide4,
    pub sun: Wide4,
    pub cos2t: Wide4,
    pub sin2t: Wide4,
    pub eps: Wide4,
    pub gain_dn: Wide4,
    pub offset_dn: Wide4,
    pub noise: Wide4,
    /// (quantize (0/1), full_scale_dn, 0, 0).
    pub adc: Wide4,
    /// (mosaic effects on (0/1), analyzer effects on (0/1), 0, 0).
    pub mosaic: Wide4,
    /// The sky effects' vectors in registry order (`ChainFrame::sky`), WGSL
    /// `array<array<Wide4, 5>, SKY_COUNT>`.
    pub sky: [[Wide4; SKY_WIDTH]; SKY_COUNT],
    /// The per-pixel effects' vectors in registry order (`ChainFrame::ray`), WGSL
    /// `array<Wide4, RAY_COUNT>`: sized by the registry, filled without naming an effect.
    pub ray: [Wide4; RAY_COUNT],
    /// The analyzer effects' vectors in registry order (`ChainFrame::analyzer`), WGSL
    /// `array<array<Wide4, 2>, ANALYZER_COUNT>`.
    pub analyzer: [[Wide4; 2]; ANALYZER_COUNT],
    /// The sensor effects' vectors in registry order (`ChainFrame::sensor`), WGSL
    /// `array<Wide4, SENSOR_COUNT>`.
    pub sensor: [Wide4; SENSOR_COUNT],
    /// The mosaic effects' vectors in registry order (`ChainFrame::mosaic`), WGSL
    /// `array<Wide4, MOSAIC_COUNT>`.
    pub mosaic_fx: [Wide4; MOSAIC_COUNT],
    pub key: [u32; 4],
    pub fixed_key: [u32; 4],
}

/// The sky effects' vectors as [`FrameParams::sky`] carries them.
pub(crate) fn sky_slots(sky: &[SkyParams; SKY_COUNT]) -> [[Wide4; SKY_WIDTH]; SKY_COUNT] {
    sky.map(|p| p.map(Wide4::new))
}

/// The analyzer effects' vectors as [`FrameParams::analyzer`] carries them (8 values as 2 × 4).
pub(crate) fn analyzer_slots(analyzer: &[AnalyzerParams; ANALYZER_COUNT]) -> [[Wide4; 2]; ANALYZER_COUNT] {
    analyzer.map(|p| [Wide4::new([p[0], p[1], p[2], p[3]]), Wide4::new([p[4], p[5], p[6], p[7]])])
}

/// Frames with scene elements (`ChainFrame::field`, field conditions) have no WGSL
/// twin: they are refused with [`GpuError::Unsupported`], never rendered without them.
impl TryFrom<&ChainFrame> for FrameParams {
    type Error = GpuError;

    fn try_from(f: &ChainFrame) -> Result<Self> {
        if f.field.is_some() {
            return Err(GpuError::Unsupported(
                "scene elements (field conditions: sky_radiance, clouds, sun_disc, skyline) run on the CPU \
                 backend only; use --backend cpu"
                    .into(),
            ));
        }
        let r = &f.response;
        Ok(FrameParams {
            camera: camera(&f.intr),
            distortion: distortion(&f.intr),
            sun: Wide4::new([f.sun_cam.x, f.sun_cam.y, f.sun_cam.z, f.dmax]),
            cos2t: Wide4::new(f.analyzers.map(|a| a.cos2t)),
            sin2t: Wide4::new(f.analyzers.map(|a| a.sin2t)),
            eps: Wide4::new(f.analyzers.map(|a| a.eps)),
            gain_dn: Wide4::new(f.gain_dn),
            offset_dn: Wide4::new(f.offset_dn),
            noise: Wide4::new([r.read_noise_dn, r.system_gain_dn_per_e, r.dsnu_dn, r.prnu]),
            adc: Wide4::new([if r.quantize { 1.0 } else { 0.0 }, r.full_scale_dn(), 0.0, 0.0]),
            mosaic: Wide4::new([
                if f.has_mosaic_effects() { 1.0 } else { 0.0 },
                if f.has_analyzer_effects() { 1.0 } else { 0.0 },
                0.0,
                0.0,
            ]),
            sky: sky_slots(&f.sky),
            ray: f.ray.map(Wide4::new),
            analyzer: analyzer_slots(&f.analyzer),
            sensor: f.sensor.map(Wide4::new),
            mosaic_fx: f.mosaic.map(Wide4::new),
            key: f.key.0,
            fixed_key: f.fixed_key.0,
        })
    }
}

/// A Stokes inversion; WGSL `ReconParams` in `common/recon.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ReconParams {
    pub row_i: Wide4,
    pub row_q: Wide4,
    pub row_u: Wide4,
    pub inv_gain: Wide4,
    pub offset_dn: Wide4,
    pub valid: Wide4,
    pub mosaic: [u32; 4],
}

impl ReconParams {
    /// `rec` on a sensor with this `mosaic` (any, for colocated frames); samples with a
    /// DN outside (0, mask_full_scale_dn) are masked, none when it is 0.
    pub fn new(rec: &Reconstructor, mosaic: &[[Channel; 2]; 2], mask_full_scale_dn: f64) -> Self {
        let (rows, inv_gain, offset_dn) = rec.parts();
        ReconParams {
            row_i: Wide4::new(rows[0]),
            row_q: Wide4::new(rows[1]),
            row_u: Wide4::new(rows[2]),
            inv_gain: Wide4::new(inv_gain),
            offset_dn: Wide4::new(offset_dn),
            valid: Wide4::new([mask_full_scale_dn, 0.0, 0.0, 0.0]),
            mosaic: mosaic_positions(mosaic),
        }
    }
}

/// Channel index at tile position `2·dv + du` (WGSL reads `mosaic[2·(v & 1) + (u & 1)]`).
pub fn mosaic_positions(mosaic: &[[Channel; 2]; 2]) -> [u32; 4] {
    [mosaic[0][0], mosaic[0][1], mosaic[1][0], mosaic[1][1]].map(|c| c.index() as u32)
}

/// A colour sensor's band index ([`Band::index`](bpins_core::sensor::Band::index)) at
/// tile position `2·tv + tu` (WGSL `band_at` reads `tiles[2·((v / 2) & 1) + ((u / 2) & 1)]`).
pub fn tile_bands(tiles: &ColourTiles) -> [u32; 4] {
    let t = &tiles.tiles;
    [t[0][0], t[0][1], t[1][0], t[1][1]].map(|b| b.index() as u32)
}

/// Where a frame's samples sit: sample (i, j) at `(x0 + step·i, y0 + step·j)` px.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleGrid {
    pub x0_px: f64,
    pub y0_px: f64,
    pub step_px: f64,
}

/// One heading context; WGSL `HeadingParams` in `common/heading.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct HeadingParams {
    pub camera: Wide4,
    pub distortion: Wide4,
    pub band: Wide4,
    pub grid: Wide4,
}

impl HeadingParams {
    pub fn new(ctx: &HeadingContext, grid: SampleGrid) -> Self {
        let cos_2band = bpins_core::twin::HeadingSums::cos_2band(ctx);
        HeadingParams {
            camera: camera(&ctx.intr),
            distortion: distortion(&ctx.intr),
            band: Wide4::new([ctx.lens_rho2, cos_2band, ctx.r_min_px * ctx.r_min_px, ctx.r_max_px * ctx.r_max_px]),
            grid: Wide4::new([grid.x0_px, grid.y0_px, grid.step_px, 1.0]),
        }
    }

    /// A context slot that contributes nothing (frames with fewer contexts than the batch).
    pub fn disabled() -> Self {
        HeadingParams { grid: Wide4::new([0.0, 0.0, 1.0, 0.0]), ..Default::default() }
    }
}

/// WGSL `RenderDims` in `kernels/render.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RenderDims {
    /// (width_px, height_px, frames of the batch, 0).
    pub size: [u32; 4],
    /// [`mosaic_positions`].
    pub mosaic: [u32; 4],
    /// A colour sensor's [`tile_bands`] (`render_colour_mosaic`; zero for the others).
    pub tiles: [u32; 4],
}

/// WGSL `SumsDims` in `kernels/sums.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SumsDims {
    pub samples: [u32; 4],
    pub image: [u32; 4],
    /// A colour sensor's [`tile_bands`] (`colour_mosaic_heading_sums`; zero for the others).
    pub tiles: [u32; 4],
}

/// WGSL `ReduceDims` in `kernels/reduce.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ReduceDims {
    pub size: [u32; 4],
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Size and member offsets of `name` in the WGSL module of `kernel`, by naga's layouter.
    fn wgsl_layout(kernel: &str, name: &str) -> (u32, Vec<(String, u32)>) {
        let src = crate::shaders::module_source(kernel).unwrap();
        let module = naga::front::wgsl::parse_str(&src).unwrap();
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        for (handle, ty) in module.types.iter() {
            if ty.name.as_deref() == Some(name) {
                if let naga::TypeInner::Struct { members, span } = &ty.inner {
                    let m = members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset)).collect();
                    assert_eq!(layouter[handle].size, *span);
                    return (*span, m);
                }
            }
        }
        panic!("struct {name} not in {kernel}");
    }

    macro_rules! check {
        ($kernel:expr, $ty:ident, [$($field:ident),*]) => {{
            let (size, members) = wgsl_layout($kernel, stringify!($ty));
            assert_eq!(size as usize, std::mem::size_of::<$ty>(), "{} size", stringify!($ty));
            let rust = vec![$((stringify!($field).to_string(), std::mem::offset_of!($ty, $field) as u32)),*];
            assert_eq!(members, rust, "{} members and offsets", stringify!($ty));
        }};
    }

    #[test]
    fn layouts_match_wgsl() {
        check!("render", Wide4, [hi, lo]);
        check!(
            "render",
            FrameParams,
            [
                camera, distortion, sun, cos2t, sin2t, eps, gain_dn, offset_dn, noise, adc, mosaic, sky, ray, analyzer,
                sensor, mosaic_fx, key, fixed_key
            ]
        );
        check!("sums", ReconParams, [row_i, row_q, row_u, inv_gain, offset_dn, valid, mosaic]);
        check!("sums", HeadingParams, [camera, distortion, band, grid]);
        check!("render", RenderDims, [size, mosaic, tiles]);
        check!("sums", SumsDims, [samples, image, tiles]);
        check!("reduce", ReduceDims, [size]);
    }

    /// WGSL `band_at` reads `tile_bands` as `ColourTiles::band_at` reads the tiles.
    #[test]
    fn tile_bands_are_read_as_the_cpu_reads_the_tiles() {
        use bpins_core::sensor::Band;
        let tiles = ColourTiles { tiles: [[Band::G, Band::B], [Band::R, Band::G]], ..ColourTiles::imx250myr() };
        let t = tile_bands(&tiles);
        for (u, v) in (0..9u32).flat_map(|u| (0..7u32).map(move |v| (u, v))) {
            let wgsl = t[(2 * ((v >> 1) & 1) + ((u >> 1) & 1)) as usize];
            assert_eq!(wgsl as usize, tiles.band_at(u as usize, v as usize).index(), "({u}, {v})");
        }
        assert_eq!(tile_bands(&ColourTiles::imx250myr()), [0, 1, 1, 2]);
    }

    #[test]
    fn frames_with_scene_elements_are_refused_with_a_typed_error() {
        use bpins_core::camera::{Intrinsics, Projection};
        use bpins_core::scene::FieldScene;
        use bpins_core::twin::{NoiseIndex, Scene};
        let intr = Intrinsics::new(Projection::Equidistant, 160.0, 63.5, 63.5);
        let scene =
            Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 0.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.6 };
        let resp = bpins_core::sensor::Response::ideal(1.0);
        let idx = NoiseIndex { seed: 1, trial: 0, frame: 0 };
        let model = bpins_core::effects::Model::default();
        let clean = ChainFrame::new_in_field(&model, &intr, &scene, &resp, idx, None);
        assert!(FrameParams::try_from(&clean).is_ok());
        let mut field = FieldScene::new(1);
        field.enable("clouds").unwrap();
        let f = ChainFrame::new_in_field(&model, &intr, &scene, &resp, idx, Some(&field));
        match FrameParams::try_from(&f) {
            Err(GpuError::Unsupported(m)) => assert!(m.contains("scene elements") && m.contains("cpu"), "{m}"),
            other => panic!("expected Unsupported, got {other:?}"),
        }
    }

    #[test]
    fn wide_values_carry_f64_precision() {
        for x in [0.1, 2318.840579710145, -1e-9, 4095.0, std::f64::consts::PI] {
            let w = Wide4::new([x, -x, 0.0, 1.0]);
            let back = w.value();
            assert!((back[0] - x).abs() <= 1e-14 * x.abs(), "{x}: {}", back[0]);
            assert_eq!(back[2], 0.0);
            assert_eq!(back[3], 1.0);
        }
    }
}
