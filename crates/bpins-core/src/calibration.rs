//! A sensor's calibration on disk: the effects `bpins fit` measured, handed to
//! `bpins heading`, to a later `fit`/`diagnose` (as known, fixed effects) and to the
//! library, instead of retyping each parameter as `--effect`.
//!
//! ```toml
//! format = "bpins-calibration/1"
//! source = "bpins fit samples/hidden-analyzer-angles"   # where it came from (free text)
//! chi2_per_dof = 0.9988                                  # of that fit, where known
//!
//! [effects.analyzer_angles]          # one table per catalog effect (`bpins effects`)
//! d0_deg = 0.0                       # every parameter by its registry name, in its unit
//! d45_deg = 1.0017
//! d90_deg = 0.0
//! d135_deg = -0.5982
//!
//! [sigma.analyzer_angles]            # optional: each parameter's 1σ (inf: not measured)
//! d45_deg = 0.0019
//! ```
//!
//! Names and ranges are the registry's: an unknown effect or parameter, a value out
//! of range, an unknown key, or a `format` this reader does not know is an error
//! naming the file and the key. Parameters not written keep their neutral values.
//!
//! A lab calibration (`bpins calibrate`) adds per-pixel maps
//! (`pixel_analyzers`), stored as float channels of an OpenEXR file beside
//! the toml:
//!
//! ```toml
//! [pixels]
//! file = "pixels.exr"                  # relative to the calibration file
//! width_px = 2448                      # the sensor the maps are for
//! height_px = 2048
//! mosaic = [[90, 45], [135, 0]]
//! maps = ["offset_dn", "gain", "analyzer_deg", "eps"]   # those measured
//! ```
//!
//! Per-pixel analyzers replace the global analyzer and channel effects
//! (`analyzer_angles`, `extinction_ratio`, `channel_response`, `array_rotation`):
//! a file with both is refused. Reading a frame of another size through the maps
//! is refused with both sizes named (`PixelMaps::check_sensor`).

use crate::effects::{EffectSet, Model};
#[cfg(feature = "io")]
use crate::error::Error;
use crate::error::Result;
use crate::pixel_analyzers::PixelMaps;
#[cfg(feature = "io")]
use std::path::Path;
use std::sync::Arc;

/// The value of `format` this reader and writer implement.
pub const FORMAT: &str = "bpins-calibration/1";

/// A calibration: known effects with their values, and (where measured) their 1σ.
///
/// Built in code (a robot's build without the `io` feature), or read from the
/// `calibration.toml` that `bpins fit` writes:
///
/// ```
/// use bpins_core::calibration::Calibration;
/// use bpins_core::effects::EffectSet;
///
/// let mut effects = EffectSet::new();
/// effects.set("array_rotation", "dtheta_deg", 0.31)?;
/// let cal = Calibration { effects, source: "lab, 2026-11-02".into(), ..Default::default() };
/// assert_eq!(cal.effects.get("array_rotation", "dtheta_deg"), Some(0.31));
/// # #[cfg(feature = "io")] {
/// // The file form round-trips (names and units are the registry's).
/// let text = cal.to_toml();
/// assert!(text.starts_with("format = \"bpins-calibration/1\""));
/// let back = Calibration::parse("calibration.toml".as_ref(), &text)?;
/// assert_eq!(back.effects.get("array_rotation", "dtheta_deg"), Some(0.31));
/// # }
/// # Ok::<(), bpins_core::Error>(())
/// ```
#[derive(Clone, Debug, Default)]
pub struct Calibration {
    pub effects: EffectSet,
    /// `effect.param` → 1σ, in the parameter's unit.
    pub sigmas: Vec<(String, f64)>,
    /// Where it came from (free text).
    pub source: String,
    pub chi2_per_dof: Option<f64>,
    /// Per-pixel maps (a lab calibration), where measured.
    pub pixels: Option<Arc<PixelMaps>>,
}

/// The file name `bpins calibrate` gives the pixel maps beside `calibration.toml`.
pub const PIXELS_FILE: &str = "pixels.exr";

impl Calibration {
    /// The chain's parameter block of the known effects.
    pub fn model(&self) -> Model {
        self.effects.model()
    }

    /// Why the per-pixel maps cannot be used with the known effects, if they cannot:
    /// both would correct the analyzers and channel responses. A colour sensor's maps
    /// are each pixel's total, as the lab measures it (`lab/bands.rs`): its ε is the
    /// channel's plus the band's (`ε_p = ε_k + ε_b`), its gain carries the band's
    /// (`g_p ∝ q_b (1 + γ_k)`), so `band_response`'s `qe_*` and `eps_*` beside them
    /// would count the band twice (its sky terms, `sky_spectrum`, are the sky's: kept).
    pub fn pixels_conflict(&self) -> Option<String> {
        self.pixels.as_ref()?;
        let m = self.model();
        let d = Model::default();
        let clash = m.channels.analyzer_delta_deg != d.channels.analyzer_delta_deg
            || m.channels.analyzer_eps != d.channels.analyzer_eps
            || m.channels.gain != d.channels.gain
            || m.channels.offset_dn != d.channels.offset_dn
            || m.bands.gain != d.bands.gain
            || m.bands.eps != d.bands.eps;
        clash.then(|| {
            "per-pixel maps ([pixels]) replace the analyzer, channel and band effects (analyzer_angles, \
             extinction_ratio, channel_response, array_rotation, band_response: each pixel's map is its \
             total, the band's ε and gain included); give one or the other"
                .to_string()
        })
    }

    /// From fitted parameters named `effect.param` (as `FitResult::params` has them),
    /// each with its value and 1σ; per-frame nuisances (`frame<k>.…`) are skipped.
    pub fn from_params<'a>(
        params: impl IntoIterator<Item = (&'a str, f64, f64)>,
        source: &str,
        chi2_per_dof: Option<f64>,
    ) -> Result<Self> {
        let mut c = Calibration { source: source.to_string(), chi2_per_dof, ..Default::default() };
        for (name, value, sigma) in params {
            let Some((effect, param)) = name.split_once('.') else { continue };
            if effect.starts_with("frame") && crate::effects::find(effect).is_err() {
                continue;
            }
            c.effects.set(effect, param, value)?;
            c.sigmas.push((name.to_string(), sigma));
        }
        Ok(c)
    }

    /// The calibration as `bpins-calibration/1` TOML.
    #[cfg(feature = "io")]
    pub fn to_toml(&self) -> String {
        let mut top = toml::Table::new();
        if !self.source.is_empty() {
            top.insert("source".into(), self.source.clone().into());
        }
        if let Some(x) = self.chi2_per_dof {
            top.insert("chi2_per_dof".into(), x.into());
        }
        let (mut effects, mut sigma) = (toml::Table::new(), toml::Table::new());
        for (def, vals) in self.effects.iter() {
            let mut t = toml::Table::new();
            let mut s = toml::Table::new();
            for (p, v) in def.params.iter().zip(vals) {
                t.insert(p.name.into(), (*v).into());
                let key = format!("{}.{}", def.name, p.name);
                if let Some((_, sd)) = self.sigmas.iter().find(|(n, _)| *n == key) {
                    s.insert(p.name.into(), (*sd).into());
                }
            }
            effects.insert(def.name.into(), t.into());
            if !s.is_empty() {
                sigma.insert(def.name.into(), s.into());
            }
        }
        top.insert("effects".into(), effects.into());
        if !sigma.is_empty() {
            top.insert("sigma".into(), sigma.into());
        }
        if let Some(px) = &self.pixels {
            let mut t = toml::Table::new();
            t.insert("file".into(), PIXELS_FILE.into());
            t.insert("width_px".into(), (px.width_px as i64).into());
            t.insert("height_px".into(), (px.height_px as i64).into());
            let mosaic: Vec<toml::Value> = px
                .mosaic
                .iter()
                .map(|r| toml::Value::Array(r.iter().map(|c| (c.angle_deg() as i64).into()).collect()))
                .collect();
            t.insert("mosaic".into(), mosaic.into());
            let maps: Vec<toml::Value> = px.present().iter().map(|(n, _)| (*n).into()).collect();
            t.insert("maps".into(), maps.into());
            top.insert("pixels".into(), t.into());
        }
        // `format` first (the table writes its keys in order).
        format!("format = \"{FORMAT}\"\n{}", toml::to_string(&top).unwrap_or_default())
    }

    /// Parses `text`, the contents of `path` (named in every error).
    #[cfg(feature = "io")]
    pub fn parse(path: &Path, text: &str) -> Result<Self> {
        let err = |m: String| Error::Calibration { path: path.to_path_buf(), message: m };
        let top: toml::Table =
            text.parse().map_err(|e: toml::de::Error| err(format!("not valid TOML: {}", e.message().trim())))?;
        let mut c = Calibration::default();
        match top.get("format").and_then(|f| f.as_str()) {
            Some(FORMAT) => {}
            Some(f) => return Err(err(format!("format = \"{f}\" is not supported; this reader knows \"{FORMAT}\""))),
            None => return Err(err(format!("missing required key `format` (should be \"{FORMAT}\")"))),
        }
        for (key, v) in &top {
            match (key.as_str(), v) {
                ("format", _) => {}
                ("source", toml::Value::String(s)) => c.source = s.clone(),
                ("chi2_per_dof", v) => match number(v) {
                    Some(x) if x.is_finite() && x >= 0.0 => c.chi2_per_dof = Some(x),
                    _ => return Err(err(format!("chi2_per_dof = {v} must be a finite number ≥ 0"))),
                },
                ("effects" | "sigma", toml::Value::Table(effects)) => {
                    for (effect, params) in effects {
                        let Some(params) = params.as_table() else {
                            return Err(err(format!("[{key}.{effect}] must be a table of parameter = value")));
                        };
                        for (param, value) in params {
                            let Some(x) = number(value) else {
                                return Err(err(format!("{key}.{effect}.{param}: {value} is not a number")));
                            };
                            if key == "effects" {
                                c.effects
                                    .set(effect, param, x)
                                    .map_err(|e| err(format!("{key}.{effect}.{param}: {e}")))?;
                            } else if x.is_nan() || x < 0.0 {
                                return Err(err(format!(
                                    "{key}.{effect}.{param} = {x} must be a 1σ ≥ 0 (inf: not measured)"
                                )));
                            } else {
                                c.sigmas.push((format!("{effect}.{param}"), x));
                            }
                        }
                    }
                }
                ("pixels", toml::Value::Table(t)) => c.pixels = Some(Arc::new(read_pixels(path, t)?)),
                (k, _) => {
                    return Err(err(format!(
                        "unknown key `{k}` (a calibration has format, source, chi2_per_dof, [effects.*], \
                         [sigma.*], [pixels])"
                    )))
                }
            }
        }
        for (name, _) in &c.sigmas {
            let (effect, param) = name.split_once('.').unwrap_or((name, ""));
            if c.effects.get(effect, param).is_none() {
                return Err(err(format!("sigma.{name}: no value for it under [effects.{effect}]")));
            }
        }
        if let Some(m) = c.pixels_conflict() {
            return Err(err(m));
        }
        Ok(c)
    }

    /// Writes the per-pixel maps (if any) as `dir/pixels.exr` ([`PIXELS_FILE`]), the
    /// file `to_toml`'s `[pixels]` names: call it for the folder `calibration.toml`
    /// goes to.
    #[cfg(feature = "io")]
    pub fn write_pixels(&self, dir: &Path) -> Result<()> {
        let Some(px) = &self.pixels else { return Ok(()) };
        let present = px.present();
        crate::output::exr::write_exr_layers_fast(
            &dir.join(PIXELS_FILE),
            px.width_px as u32,
            px.height_px as u32,
            &present,
        )
    }

    /// Reads a calibration file.
    #[cfg(feature = "io")]
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::Io { path: path.to_path_buf(), source: e })?;
        Calibration::parse(path, &text)
    }
}

/// `[pixels]` of the calibration file `path`: the maps read from the EXR it names.
#[cfg(feature = "io")]
fn read_pixels(path: &Path, t: &toml::Table) -> Result<PixelMaps> {
    use crate::pixel_analyzers::MAP_NAMES;
    use crate::sensor::Channel;
    let err = |m: String| Error::Calibration { path: path.to_path_buf(), message: format!("[pixels] {m}") };
    for k in t.keys() {
        if !["file", "width_px", "height_px", "mosaic", "maps"].contains(&k.as_str()) {
            return Err(err(format!("unknown key `{k}` (file, width_px, height_px, mosaic, maps)")));
        }
    }
    let file = t.get("file").and_then(|v| v.as_str()).ok_or_else(|| err("missing required key `file`".into()))?;
    let size = |k: &str| {
        t.get(k)
            .and_then(|v| v.as_integer())
            .filter(|&x| x > 0)
            .map(|x| x as usize)
            .ok_or_else(|| err(format!("`{k}` must be a positive integer")))
    };
    let (w, h) = (size("width_px")?, size("height_px")?);
    let mut mosaic = crate::sensor::DEFAULT_MOSAIC;
    if let Some(v) = t.get("mosaic") {
        let rows =
            v.as_array().filter(|r| r.len() == 2).ok_or_else(|| err("mosaic must be 2 rows of 2 angles".into()))?;
        for (r, row) in rows.iter().enumerate() {
            let row = row
                .as_array()
                .filter(|x| x.len() == 2)
                .ok_or_else(|| err("mosaic must be 2 rows of 2 angles".into()))?;
            for (col, a) in row.iter().enumerate() {
                mosaic[r][col] = number(a)
                    .and_then(Channel::from_angle_deg)
                    .ok_or_else(|| err(format!("mosaic: {a} is not an analyzer angle (0, 45, 90 or 135)")))?;
            }
        }
    }
    let maps: Vec<String> = match t.get("maps").and_then(|v| v.as_array()) {
        Some(a) => a
            .iter()
            .map(|x| x.as_str().map(str::to_string).ok_or_else(|| err("maps must be names".into())))
            .collect::<Result<_>>()?,
        None => return Err(err("missing required key `maps`".into())),
    };
    for m in &maps {
        if !MAP_NAMES.contains(&m.as_str()) {
            return Err(err(format!("maps: unknown map `{m}` (known: {})", MAP_NAMES.join(", "))));
        }
    }
    let exr_path = path.parent().unwrap_or(Path::new(".")).join(file);
    let (ew, eh, layers) = crate::output::exr::read_exr_layers(&exr_path)?;
    if (ew as usize, eh as usize) != (w, h) {
        return Err(err(format!("{} is {ew} × {eh} px but width_px × height_px is {w} × {h}", exr_path.display())));
    }
    let mut px = PixelMaps::nominal(w, h, mosaic);
    for m in &maps {
        let plane = layers
            .iter()
            .find(|(n, _)| n == m)
            .map(|(_, p)| p.clone())
            .ok_or_else(|| err(format!("{} has no channel `{m}` (maps lists it)", exr_path.display())))?;
        match m.as_str() {
            "offset_dn" => px.offset_dn = Some(plane),
            "gain" => px.gain = Some(plane),
            "analyzer_deg" => px.analyzer_deg = Some(plane),
            _ => px.eps = Some(plane),
        }
    }
    px.check().map_err(|m| err(format!("{}: {m}", exr_path.display())))?;
    Ok(px)
}

#[cfg(feature = "io")]
fn number(v: &toml::Value) -> Option<f64> {
    match v {
        toml::Value::Float(x) => Some(*x),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

#[cfg(all(test, feature = "io"))]
mod tests {
    use super::*;

    #[test]
    fn a_calibration_round_trips_through_toml() {
        let params = [
            ("analyzer_angles.d45_deg", 1.0017, 0.0019),
            ("analyzer_angles.d135_deg", -0.5982, 0.0019),
            ("frame0.heading_deg", 12.0, 0.001),
            ("lens_diattenuation.rho2", 0.3, f64::INFINITY),
        ];
        let c = Calibration::from_params(params, "bpins fit test", Some(0.9988)).unwrap();
        let text = c.to_toml();
        assert!(text.contains("format = \"bpins-calibration/1\""), "{text}");
        let back = Calibration::parse(Path::new("cal.toml"), &text).unwrap();
        assert_eq!(back.effects.get("analyzer_angles", "d45_deg"), Some(1.0017));
        assert_eq!(back.effects.get("analyzer_angles", "d0_deg"), Some(0.0));
        assert_eq!(back.effects.get("lens_diattenuation", "rho2"), Some(0.3));
        assert!(back.effects.get("frame0", "heading_deg").is_none());
        assert_eq!(back.model(), c.model());
        assert_eq!(back.chi2_per_dof, Some(0.9988));
        assert!(back.sigmas.iter().any(|(n, s)| n == "lens_diattenuation.rho2" && s.is_infinite()));
    }

    #[test]
    fn bad_calibrations_are_refused_with_file_and_key() {
        let bad = [
            ("effects.analyzer_angles.d45_deg = 1.0", "format"),
            ("format = \"bpins-calibration/9\"", "bpins-calibration/9"),
            ("format = \"bpins-calibration/1\"\n[effects.no_such]\nx = 1.0", "no_such"),
            ("format = \"bpins-calibration/1\"\n[effects.analyzer_angles]\nd46_deg = 1.0", "d46_deg"),
            ("format = \"bpins-calibration/1\"\n[effects.crosstalk]\nc = 5.0", "crosstalk.c"),
            ("format = \"bpins-calibration/1\"\n[effects.crosstalk]\nc = \"x\"", "not a number"),
            ("format = \"bpins-calibration/1\"\nextra = 1", "extra"),
            ("format = \"bpins-calibration/1\"\n[sigma.crosstalk]\nc = 0.1", "sigma.crosstalk.c"),
        ];
        for (text, want) in bad {
            let e = Calibration::parse(Path::new("dir/cal.toml"), text).unwrap_err().to_string();
            assert!(e.contains("dir/cal.toml") && e.contains(want), "{text:?}: {e}");
        }
    }
}
