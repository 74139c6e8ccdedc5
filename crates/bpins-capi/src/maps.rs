//! `bpins_stokes_maps_*`: AoP, DoLP, intensity (and AoE) of a raw DoFP frame into the
//! caller's float buffers, through `bpins_core::maps` (the kernel of Python's
//! `stokes_maps` and `bpins maps`). No handle: a frame in, four maps out.
//! `bpins_colour_maps_*`: the same of a colour-polarization frame, per band
//! (`bpins_core::colour_maps_into`).

use crate::types::{colour_tiles_of, mosaic_of_deg};
use crate::{guard, BpinsStatus, Failure};
use bpins_core::compass::{RawDn, RawImage};
use bpins_core::sensor::Band;
use bpins_core::sensor::{Channel, DEFAULT_MOSAIC};
use bpins_core::{colour_maps_into, colour_maps_size, ColourScratch};
use bpins_core::{stokes_maps_into, Interpolation, MapsConfig, MapsOut, Reconstructor};
use std::ffi::c_char;

/// Each channel interpolated bilinearly on its own lattice (the default).
pub const BPINS_MAPS_BILINEAR: u32 = 0;
/// Each 2 × 2 tile one value: maps of (width / 2) × (height / 2).
pub const BPINS_MAPS_SUPERPIXEL: u32 = 1;
/// polanalyser's demosaic (OpenCV's Bayer bilinear, rounded to whole DN), exactly.
pub const BPINS_MAPS_OPENCV: u32 = 2;
/// polanalyser's edge-aware demosaic (OpenCV's `COLOR_Bayer**2BGR_EA`), exactly: on a
/// mono frame the maps of `BPINS_MAPS_OPENCV`, on a colour one `COLOR_PolarRGB_EA`.
pub const BPINS_MAPS_OPENCV_EA: u32 = 3;

/// How the maps are made. `bpins_maps_config_default` fills the defaults.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BpinsMapsConfig {
    /// One of `BPINS_MAPS_*`.
    pub interpolation: u32,
    /// The analyzer angles of the 2 × 2 tile, degrees, mosaic_deg[row][column] from the
    /// image's top-left pixel (each of 0, 45, 90, 135 once).
    pub mosaic_deg: [[u32; 2]; 2],
    /// Black level, DN: subtracted before the Stokes vector.
    pub black_level_dn: f64,
    /// Samples at or above this are saturated and their pixels NaN; 0: no check.
    pub full_scale_dn: f64,
    /// The centre about which the AoE map's β is measured, px (the principal point).
    pub aoe_centre_x_px: f64,
    pub aoe_centre_y_px: f64,
}

/// Fills `*out` with the defaults: bilinear, the IMX250MZR mosaic {{90, 45}, {135, 0}},
/// black level 0 DN, no saturation check, AoE about (0, 0): set the centre.
///
/// # Safety
/// `out` is NULL or points to writable memory for one `BpinsMapsConfig`.
#[no_mangle]
pub unsafe extern "C" fn bpins_maps_config_default(out: *mut BpinsMapsConfig) -> BpinsStatus {
    guard(|| {
        if out.is_null() {
            return Err(Failure::new(BpinsStatus::BPINS_ERR_NULL, "`out` is NULL"));
        }
        let cfg = BpinsMapsConfig {
            interpolation: BPINS_MAPS_BILINEAR,
            mosaic_deg: DEFAULT_MOSAIC.map(|row| row.map(|c| c.angle_deg() as u32)),
            black_level_dn: 0.0,
            full_scale_dn: 0.0,
            aoe_centre_x_px: 0.0,
            aoe_centre_y_px: 0.0,
        };
        // SAFETY: non-NULL and writable by the caller's contract.
        unsafe { out.write(cfg) };
        Ok(())
    })
}

fn config_error(m: String) -> Failure {
    Failure::new(BpinsStatus::BPINS_ERR_CONFIG, m)
}

impl BpinsMapsConfig {
    fn to_core(self) -> Result<(MapsConfig, Reconstructor), Failure> {
        let interpolation = *Interpolation::ALL
            .get(self.interpolation as usize)
            .ok_or_else(|| config_error(format!("interpolation {}: one of BPINS_MAPS_* (0…3)", self.interpolation)))?;
        let mosaic = mosaic_of_deg(self.mosaic_deg).map_err(config_error)?;
        let finite = [self.black_level_dn, self.full_scale_dn, self.aoe_centre_x_px, self.aoe_centre_y_px];
        if !finite.iter().all(|x| x.is_finite()) || self.full_scale_dn < 0.0 {
            return Err(config_error(format!(
                "black_level_dn {}, full_scale_dn {} (≥ 0), aoe centre ({}, {}) px: finite numbers",
                self.black_level_dn, self.full_scale_dn, self.aoe_centre_x_px, self.aoe_centre_y_px
            )));
        }
        let rec = Reconstructor::new(&Default::default(), self.black_level_dn, &Channel::ALL)
            .map_err(|e| config_error(e.to_string()))?;
        let cfg = MapsConfig {
            interpolation,
            mosaic,
            full_scale_dn: if self.full_scale_dn > 0.0 { self.full_scale_dn } else { f64::INFINITY },
            aoe_centre_px: [self.aoe_centre_x_px, self.aoe_centre_y_px],
        };
        Ok((cfg, rec))
    }
}

/// # Safety
/// As the exported functions below.
#[allow(clippy::too_many_arguments)]
unsafe fn maps<T: RawDn>(
    data: *const T,
    width_px: usize,
    height_px: usize,
    stride: usize,
    config: *const BpinsMapsConfig,
    aop_deg: *mut f32,
    dolp: *mut f32,
    intensity_dn: *mut f32,
    aoe_deg: *mut f32,
) -> BpinsStatus {
    let band = BpinsBandMaps { aop_deg, dolp, intensity_dn, aoe_deg };
    // SAFETY: the same contract.
    unsafe { maps_of(data, width_px, height_px, stride, config, None, &band) }
}

/// # Safety
/// As the exported functions below; `colour`: None (mono, `out` one band's maps) or
/// the tiles' four chars (colour, `out` three bands' maps).
#[allow(clippy::too_many_arguments)]
unsafe fn maps_of<T: RawDn>(
    data: *const T,
    width_px: usize,
    height_px: usize,
    stride: usize,
    config: *const BpinsMapsConfig,
    colour: Option<*const c_char>,
    out: *const BpinsBandMaps,
) -> BpinsStatus {
    guard(|| {
        let null = |name: &str| Failure::new(BpinsStatus::BPINS_ERR_NULL, format!("`{name}` is NULL"));
        for (p, name) in [
            (data as *const u8, "data"),
            (config as *const u8, "config"),
            (colour.unwrap_or(config as *const c_char) as *const u8, "colour_tiles"),
            (out as *const u8, "out"),
        ] {
            if p.is_null() {
                return Err(null(name));
            }
        }
        let tiles = match colour {
            // SAFETY: non-NULL; four readable chars by the caller's contract.
            Some(t) => Some(
                colour_tiles_of(unsafe { *(t as *const [c_char; 4]) })
                    .map_err(config_error)?
                    .ok_or_else(|| config_error("colour_tiles: four zero chars; give 'R', 'G', 'B'".into()))?,
            ),
            None => None,
        };
        // SAFETY: non-NULL; one or three band maps by the caller's contract.
        let bands: Vec<(Band, BpinsBandMaps)> = match &tiles {
            None => vec![(Band::G, unsafe { *out })],
            Some(_) => Band::ALL
                .iter()
                .map(|&b| (b, unsafe { *out.add(b.index()) }))
                .filter(|(_, m)| !m.aop_deg.is_null())
                .collect(),
        };
        if bands.is_empty() {
            return Err(null("out[R].aop_deg, out[G].aop_deg and out[B].aop_deg"));
        }
        for (_, m) in &bands {
            for (p, name) in [(m.aop_deg, "aop_deg"), (m.dolp, "dolp"), (m.intensity_dn, "intensity_dn")] {
                if p.is_null() {
                    return Err(null(name));
                }
            }
        }
        // SAFETY: non-NULL; a valid config by the caller's contract.
        let (cfg, rec) = unsafe { *config }.to_core()?;
        let size = |m: String| Failure::new(BpinsStatus::BPINS_ERR_FRAME_SIZE, m);
        let len = height_px
            .checked_sub(1)
            .and_then(|r| r.checked_mul(stride))
            .and_then(|n| n.checked_add(width_px))
            .filter(|n| {
                stride >= width_px && n.checked_mul(std::mem::size_of::<T>()).is_some_and(|b| b <= isize::MAX as usize)
            })
            .ok_or_else(|| {
                size(format!(
                    "frame of {width_px} × {height_px} px (stride {stride}): a height ≥ 1 and a stride ≥ the width"
                ))
            })?;
        if !(data as usize).is_multiple_of(std::mem::align_of::<T>()) {
            return Err(size(format!("`data` at {data:p} is not aligned to {} bytes", std::mem::align_of::<T>())));
        }
        let (mw, mh) = match tiles {
            Some(_) => colour_maps_size(cfg.interpolation, width_px, height_px),
            None => cfg.interpolation.maps_size(width_px, height_px),
        };
        let n = mw * mh;
        for (_, m) in &bands {
            for p in [m.aop_deg, m.dolp, m.intensity_dn, m.aoe_deg] {
                if !p.is_null() && !(p as usize).is_multiple_of(std::mem::align_of::<f32>()) {
                    return Err(size(format!("an output buffer at {p:p} is not aligned to 4 bytes")));
                }
            }
        }
        // SAFETY: non-NULL, aligned, `len` readable samples and `n` writable floats per
        // map by the caller's contract; the maps do not overlap.
        let raw = RawImage { data: unsafe { std::slice::from_raw_parts(data, len) }, width_px, height_px, stride };
        let mut outs: Vec<(Band, MapsOut)> = bands
            .iter()
            .map(|(b, m)| unsafe {
                let o = MapsOut {
                    aop_deg: std::slice::from_raw_parts_mut(m.aop_deg, n),
                    dolp: std::slice::from_raw_parts_mut(m.dolp, n),
                    intensity_dn: std::slice::from_raw_parts_mut(m.intensity_dn, n),
                    aoe_deg: if m.aoe_deg.is_null() {
                        None
                    } else {
                        Some(std::slice::from_raw_parts_mut(m.aoe_deg, n))
                    },
                };
                (*b, o)
            })
            .collect();
        match &tiles {
            Some(t) => colour_maps_into(&raw, &rec, &cfg, t, &mut ColourScratch::default(), &mut outs),
            None => stokes_maps_into(&raw, &rec, &cfg, outs.pop().expect("one band").1),
        }
        .map_err(|e| match e {
            bpins_core::MapsError::NotBayer { .. } => config_error(e.to_string()),
            e => size(e.to_string()),
        })
    })
}

/// One band's maps for `bpins_colour_maps_*`, each NULL or (maps' size) writable
/// floats; `aoe_deg` may be NULL (no AoE map), and a band whose `aop_deg` is NULL is
/// not made.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct BpinsBandMaps {
    pub aop_deg: *mut f32,
    pub dolp: *mut f32,
    pub intensity_dn: *mut f32,
    pub aoe_deg: *mut f32,
}

/// AoP (degrees, image frame, (−90°, 90°]), DoLP, intensity (DN above the black level)
/// and, where `aoe_deg` is not NULL, AoE of one raw DoFP frame of 16-bit samples, into
/// the caller's buffers of (width × height) floats each, or (width / 2) × (height / 2)
/// for `BPINS_MAPS_SUPERPIXEL`; row-major, packed. `stride` is in samples (≥ width).
/// The frame is read in place; NaN marks a pixel without a valid value.
///
/// # Safety
/// `data` is NULL or holds (height − 1)·stride + width readable samples; `config` is
/// NULL or points to a config; each map is NULL or holds the maps' size of writable
/// floats, and no two overlap.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn bpins_stokes_maps_u16(
    data: *const u16,
    width_px: usize,
    height_px: usize,
    stride: usize,
    config: *const BpinsMapsConfig,
    aop_deg: *mut f32,
    dolp: *mut f32,
    intensity_dn: *mut f32,
    aoe_deg: *mut f32,
) -> BpinsStatus {
    // SAFETY: the same contract.
    unsafe { maps(data, width_px, height_px, stride, config, aop_deg, dolp, intensity_dn, aoe_deg) }
}

/// As `bpins_stokes_maps_u16`, for 8-bit samples.
///
/// # Safety
/// As `bpins_stokes_maps_u16`.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn bpins_stokes_maps_u8(
    data: *const u8,
    width_px: usize,
    height_px: usize,
    stride: usize,
    config: *const BpinsMapsConfig,
    aop_deg: *mut f32,
    dolp: *mut f32,
    intensity_dn: *mut f32,
    aoe_deg: *mut f32,
) -> BpinsStatus {
    // SAFETY: the same contract.
    unsafe { maps(data, width_px, height_px, stride, config, aop_deg, dolp, intensity_dn, aoe_deg) }
}

/// As `bpins_stokes_maps_u16`, for `float` samples in DN.
///
/// # Safety
/// As `bpins_stokes_maps_u16`.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn bpins_stokes_maps_f32(
    data: *const f32,
    width_px: usize,
    height_px: usize,
    stride: usize,
    config: *const BpinsMapsConfig,
    aop_deg: *mut f32,
    dolp: *mut f32,
    intensity_dn: *mut f32,
    aoe_deg: *mut f32,
) -> BpinsStatus {
    // SAFETY: the same contract.
    unsafe { maps(data, width_px, height_px, stride, config, aop_deg, dolp, intensity_dn, aoe_deg) }
}

/// Each band's AoP, DoLP, intensity and (where `aoe_deg` is not NULL) AoE maps of one
/// raw colour-polarization frame of 16-bit samples, every band from its own pixels:
/// `colour_tiles` points to the four colour filters over the 2 × 2 analyzer tiles,
/// row-major ("RGGB" for the Sony IMX250MYR); `out` to three `BpinsBandMaps`, at
/// `BPINS_BAND_R`, `BPINS_BAND_G`, `BPINS_BAND_B`. Maps of (width × height) floats, or
/// (width / 4) × (height / 4) for `BPINS_MAPS_SUPERPIXEL` (one value per 4 × 4
/// superpixel); `BPINS_MAPS_OPENCV` is polanalyser's `COLOR_PolarRGB` demosaic,
/// `BPINS_MAPS_OPENCV_EA` its `COLOR_PolarRGB_EA`, exactly (docs/colour.md).
/// Otherwise as `bpins_stokes_maps_u16`.
///
/// # Safety
/// As `bpins_stokes_maps_u16`; `colour_tiles` NULL or four readable chars; `out` NULL
/// or three readable `BpinsBandMaps` whose non-NULL maps hold the maps' size of
/// writable floats, no two overlapping.
#[no_mangle]
pub unsafe extern "C" fn bpins_colour_maps_u16(
    data: *const u16,
    width_px: usize,
    height_px: usize,
    stride: usize,
    config: *const BpinsMapsConfig,
    colour_tiles: *const c_char,
    out: *const BpinsBandMaps,
) -> BpinsStatus {
    // SAFETY: the same contract.
    unsafe { maps_of(data, width_px, height_px, stride, config, Some(colour_tiles), out) }
}

/// As `bpins_colour_maps_u16`, for 8-bit samples.
///
/// # Safety
/// As `bpins_colour_maps_u16`.
#[no_mangle]
pub unsafe extern "C" fn bpins_colour_maps_u8(
    data: *const u8,
    width_px: usize,
    height_px: usize,
    stride: usize,
    config: *const BpinsMapsConfig,
    colour_tiles: *const c_char,
    out: *const BpinsBandMaps,
) -> BpinsStatus {
    // SAFETY: the same contract.
    unsafe { maps_of(data, width_px, height_px, stride, config, Some(colour_tiles), out) }
}

/// As `bpins_colour_maps_u16`, for `float` samples in DN.
///
/// # Safety
/// As `bpins_colour_maps_u16`.
#[no_mangle]
pub unsafe extern "C" fn bpins_colour_maps_f32(
    data: *const f32,
    width_px: usize,
    height_px: usize,
    stride: usize,
    config: *const BpinsMapsConfig,
    colour_tiles: *const c_char,
    out: *const BpinsBandMaps,
) -> BpinsStatus {
    // SAFETY: the same contract.
    unsafe { maps_of(data, width_px, height_px, stride, config, Some(colour_tiles), out) }
}
