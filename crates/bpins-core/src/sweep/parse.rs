//! Parsing a sweep file into [`SweepSpec`] (the types are in `spec.rs`, the format is
//! documented in [`super`]): every check runs here, before any trial.
//! (Over 500 lines: one linear reader of one format, key by key, each with its error.)

use std::path::Path;

use toml::{Table, Value};

use super::spec::*;
use crate::camera::Intrinsics;
use crate::capture::{parse_sensor_lens, validate_sensor_lens};
use crate::error::{Error, Result};
use crate::heading::Extractor;
use crate::sensor::{Channel, Layout};
impl SweepSpec {
    /// Reads and checks the sweep file at `path`.
    pub fn load(path: &Path) -> Result<SweepSpec> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::Io { path: path.to_path_buf(), source: e })?;
        SweepSpec::parse(path, &text)
    }

    /// Parses `text`, the contents of `path` (which errors name).
    pub fn parse(path: &Path, text: &str) -> Result<SweepSpec> {
        let p = path;
        let table: Table = text.parse().map_err(|e: toml::de::Error| {
            let at = e.span().map(|r| {
                let before = text.get(..r.start).unwrap_or(text);
                let line = before.matches('\n').count() + 1;
                format!(" at line {line}")
            });
            bad(p, "(file)", format!("not valid TOML{}: {}", at.unwrap_or_default(), e.message().trim()))
        })?;
        check_keys(
            p,
            "",
            &table,
            &[
                "format",
                "title",
                "seed",
                "trials",
                "extractors",
                "combined",
                "sources",
                "sensor",
                "lens",
                "sky",
                "response",
                "errors",
            ],
        )?;
        match table.get("format") {
            Some(Value::String(f)) if f == FORMAT => {}
            Some(v) => return Err(bad(p, "format", format!("expected \"{FORMAT}\", found {v}"))),
            None => return Err(bad(p, "format", format!("missing; expected format = \"{FORMAT}\""))),
        }
        let title = opt_str(p, "title", table.get("title"))?.unwrap_or_default();
        let seed = opt_int(p, "seed", table.get("seed"), 0, i64::MAX)?.unwrap_or(0) as u64;
        let trials =
            req(p, "trials", opt_int(p, "trials", table.get("trials"), 1, 10_000_000)?, "a whole number ≥ 1")? as usize;
        let extractors = match table.get("extractors") {
            None => Extractor::ALL.iter().map(|&e| SweepExtractor::Plain(e)).collect(),
            Some(v) => {
                let list = v.as_array().ok_or_else(|| bad(p, "extractors", expected_list_of_extractors()))?;
                let mut out = Vec::new();
                for (i, e) in list.iter().enumerate() {
                    let key = format!("extractors[{i}]");
                    let x = e
                        .as_str()
                        .and_then(SweepExtractor::from_name)
                        .ok_or_else(|| bad(p, &key, format!("found {e}; expected one of {}", extractor_names())))?;
                    if out.contains(&x) {
                        return Err(bad(p, &key, format!("`{}` is listed twice", x.name())));
                    }
                    out.push(x);
                }
                if out.is_empty() {
                    return Err(bad(p, "extractors", expected_list_of_extractors()));
                }
                out
            }
        };
        let combined = opt_bool(p, "combined", table.get("combined"))?.unwrap_or(true);

        let (sensor, lens) = parse_sensor_lens(p, table.get("sensor").cloned(), table.get("lens").cloned())?;
        validate_sensor_lens(&sensor, &lens, p)?;
        if let (Some(i), Layout::Dofp { .. }) =
            (extractors.iter().position(|e| *e == SweepExtractor::EdgePoint), &sensor.layout)
        {
            return Err(bad(
                p,
                &format!("extractors[{i}]"),
                "edge_point reads the ring pixel by pixel: it needs [sensor] layout = \"colocated\"".into(),
            ));
        }
        if let Layout::Dofp { .. } = sensor.layout {
            if sensor.geometry.width_px < 2 || sensor.geometry.height_px < 2 {
                return Err(bad(p, "sensor.width_px", "a DoFP sensor needs at least 2 × 2 px".into()));
            }
        }

        // [sky]
        let sky = table_of(p, "sky", table.get("sky"))?;
        check_keys(
            p,
            "sky.",
            &sky,
            &["sun_elevations_deg", "sun_azimuths_deg", "trials_per_azimuth", "dmax", "scene"],
        )?;
        let sun_elevations_deg = req(
            p,
            "sky.sun_elevations_deg",
            list_or_range(p, "sky.sun_elevations_deg", sky.get("sun_elevations_deg"))?,
            "a list of degrees or { from, to, step }",
        )?;
        for (i, &e) in sun_elevations_deg.iter().enumerate() {
            if !(e > 0.0 && e < 90.0) {
                return Err(bad(
                    p,
                    &format!("sky.sun_elevations_deg[{i}]"),
                    format!("{e}° is outside (0°, 90°): the plain extractors need the sun above the horizon and off the zenith"),
                ));
            }
        }
        let sun_azimuths_deg =
            list_or_range(p, "sky.sun_azimuths_deg", sky.get("sun_azimuths_deg"))?.unwrap_or_else(|| vec![0.0]);
        for (i, &a) in sun_azimuths_deg.iter().enumerate() {
            if !(-360.0..=360.0).contains(&a) {
                return Err(bad(
                    p,
                    &format!("sky.sun_azimuths_deg[{i}]"),
                    format!("{a}° is outside [−360°, 360°] (one turn either way of north, as in a capture)"),
                ));
            }
        }
        let trials_per_azimuth =
            opt_int(p, "sky.trials_per_azimuth", sky.get("trials_per_azimuth"), 1, i64::MAX)?.unwrap_or(1) as usize;
        let dmax = opt_num(p, "sky.dmax", sky.get("dmax"))?.unwrap_or(0.6);
        if !(dmax > 0.0 && dmax <= 1.0) {
            return Err(bad(p, "sky.dmax", format!("{dmax} is outside (0, 1]")));
        }

        let scene = match sky.get("scene") {
            None => Vec::new(),
            Some(Value::Array(a)) => {
                let mut out = Vec::new();
                let mut check = crate::scene::FieldScene::new(0);
                for (i, x) in a.iter().enumerate() {
                    let key = format!("sky.scene[{i}]");
                    let spec = x.as_str().ok_or_else(|| bad(p, &key, format!("found {x}; expected a string")))?;
                    check.parse(spec).map_err(|e| {
                        bad(
                            p,
                            &key,
                            format!("{e}; expected an element of `bpins simulate --scene` or element.param=value"),
                        )
                    })?;
                    out.push(spec.to_string());
                }
                out
            }
            Some(v) => {
                return Err(bad(
                    p,
                    "sky.scene",
                    format!("found {v}; expected a list like [\"clouds\", \"clouds.count=8\"]"),
                ))
            }
        };

        // [response]
        let resp = match table.get("response") {
            None => Table::new(),
            v => table_of(p, "response", v)?,
        };
        check_keys(p, "response.", &resp, &["peak_dn", "quantize"])?;
        let peak_dn = opt_num(p, "response.peak_dn", resp.get("peak_dn"))?.unwrap_or(1000.0);
        let full = sensor.full_scale_dn();
        if !(peak_dn > 0.0 && peak_dn <= full) {
            return Err(bad(
                p,
                "response.peak_dn",
                format!("{peak_dn} DN is outside (0, {full}] DN (the bit depth's full scale)"),
            ));
        }
        let quantize = opt_bool(p, "response.quantize", resp.get("quantize"))?.unwrap_or(false);

        // [[errors]]
        let list = match table.get("errors") {
            None => Vec::new(),
            Some(Value::Array(a)) => a.clone(),
            Some(v) => return Err(bad(p, "errors", format!("found {v}; expected [[errors]] tables"))),
        };
        if list.is_empty() {
            return Err(bad(p, "errors", "missing; expected at least one [[errors]] table".into()));
        }
        let mut errors: Vec<ErrorSpec> = Vec::new();
        for (i, v) in list.iter().enumerate() {
            let e = parse_error(p, i, v, &extractors)?;
            if let Some(j) = errors.iter().position(|o| o.source == e.source && o.target == e.target) {
                return Err(bad(
                    p,
                    &format!("errors[{i}].param"),
                    format!("`{}` is already errors[{j}] of source `{}`", e.target.name(), e.source),
                ));
            }
            errors.push(e);
        }
        let mut sources: Vec<String> = Vec::new();
        for e in &errors {
            if !sources.contains(&e.source) {
                sources.push(e.source.clone());
            }
        }
        // An explicit order (its index keys each source's draws).
        if let Some(v) = table.get("sources") {
            let list = v
                .as_array()
                .ok_or_else(|| bad(p, "sources", format!("found {v}; expected a list of the errors' sources")))?;
            let mut order: Vec<String> = Vec::new();
            for (i, x) in list.iter().enumerate() {
                let key = format!("sources[{i}]");
                let name = x.as_str().ok_or_else(|| bad(p, &key, format!("found {x}; expected a source name")))?;
                if !sources.iter().any(|s| s == name) {
                    return Err(bad(
                        p,
                        &key,
                        format!(
                            "`{name}` is the source of no [[errors]] table; expected one of {}",
                            sources.join(", ")
                        ),
                    ));
                }
                if order.iter().any(|s| s == name) {
                    return Err(bad(p, &key, format!("`{name}` is listed twice")));
                }
                order.push(name.to_string());
            }
            if let Some(missing) = sources.iter().find(|s| !order.contains(s)) {
                return Err(bad(p, "sources", format!("`{missing}` is missing; expected every errors' source once")));
            }
            sources = order;
        }
        if combined && sources.len() > 1 {
            sources.push(COMBINED.to_string());
        }
        let combined = combined && sources.last().map(String::as_str) == Some(COMBINED);

        Ok(SweepSpec {
            path: path.to_path_buf(),
            text: text.to_string(),
            text_hash: fnv1a(text.as_bytes()),
            title,
            sensor,
            lens,
            sun_elevations_deg,
            sun_azimuths_deg,
            trials_per_azimuth,
            dmax,
            scene,
            peak_dn,
            quantize,
            errors,
            sources,
            combined,
            extractors,
            trials,
            seed,
        })
    }

    /// Sensor width and height, pixels.
    pub fn size_px(&self) -> (usize, usize) {
        (self.sensor.geometry.width_px as usize, self.sensor.geometry.height_px as usize)
    }

    /// The nominal camera (what the reconstruction assumes unless an error is known).
    pub fn intrinsics(&self) -> Intrinsics {
        let (cx, cy) = self.lens.principal_point_px;
        Intrinsics {
            projection: self.lens.projection,
            f_px: self.lens.focal_length_mm * 1000.0 / self.sensor.geometry.pixel_pitch_um,
            cx_px: cx,
            cy_px: cy,
            distortion: [0.0; 2],
        }
    }

    /// Squared normalised radius of the field's farthest corner.
    pub fn corner_r2(&self) -> f64 {
        let i = self.intrinsics();
        let (w, h) = self.size_px();
        let (x, y) = i.normalised(0.0, 0.0);
        let (x2, y2) = i.normalised(w as f64 - 1.0, h as f64 - 1.0);
        let (x3, y3) = i.normalised(w as f64 - 1.0, 0.0);
        let (x4, y4) = i.normalised(0.0, h as f64 - 1.0);
        (x * x + y * y).max(x2 * x2 + y2 * y2).max(x3 * x3 + y3 * y3).max(x4 * x4 + y4 * y4)
    }

    /// The analyzer channels the sensor has.
    pub fn channels(&self) -> Vec<Channel> {
        match &self.sensor.layout {
            Layout::Colocated { channels } => channels.clone(),
            Layout::Dofp { .. } => Channel::ALL.to_vec(),
        }
    }

    /// Whether error `e` is drawn in source `s` (index into `sources`).
    pub fn in_source(&self, e: &ErrorSpec, s: usize) -> bool {
        let name = &self.sources[s];
        (self.combined && name == COMBINED) || &e.source == name
    }

    /// Whether source `s` has rows with the `Known::Both` errors known and unknown.
    pub fn has_both(&self, s: usize) -> bool {
        self.errors.iter().any(|e| e.known == Known::Both && self.in_source(e, s))
    }

    /// The field conditions of trial `trial`: drawn anew per trial (their seed mixes
    /// the sweep's seed and the trial), the same at every sun elevation; `None` for
    /// the lab-clean sky.
    pub fn field_scene(&self, trial: usize) -> Option<crate::scene::FieldScene> {
        if self.scene.is_empty() {
            return None;
        }
        let mut f = crate::scene::FieldScene::new(self.seed ^ (trial as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        for s in &self.scene {
            f.parse(s).expect("checked when the file was read");
        }
        Some(f)
    }

    /// The trial's sun azimuth, degrees.
    pub fn sun_azimuth_deg(&self, trial: usize) -> f64 {
        let n = self.sun_azimuths_deg.len();
        self.sun_azimuths_deg[(trial / self.trials_per_azimuth) % n]
    }
}

fn parse_error(p: &Path, i: usize, v: &Value, extractors: &[SweepExtractor]) -> Result<ErrorSpec> {
    let pre = format!("errors[{i}]");
    let t = v.as_table().ok_or_else(|| bad(p, &pre, format!("found {v}; expected a table")))?;
    let k = |name: &str| format!("{pre}.{name}");
    check_keys(
        p,
        &format!("{pre}."),
        t,
        &["source", "param", "distribution", "mean", "sigma", "min", "max", "value", "per", "known"],
    )?;
    let source = req(p, &k("source"), opt_str(p, &k("source"), t.get("source"))?, "the name of the row, a string")?;
    if source.is_empty() || source == COMBINED {
        return Err(bad(p, &k("source"), format!("`{source}` is reserved or empty; name the source")));
    }
    let pname = req(p, &k("param"), opt_str(p, &k("param"), t.get("param"))?, "a parameter name")?;
    let target = Target::parse(&pname).ok_or_else(|| {
        bad(
            p,
            &k("param"),
            format!(
                "`{pname}` is unknown; expected `effect.param` from `bpins effects`, or one of \
                 lens.rho_corner, imu.tilt_x_deg, imu.tilt_y_deg, sun.azimuth_deg, sun.elevation_deg, \
                 sensor.dsnu_dn, sensor.prnu, sensor.read_noise_dn"
            ),
        )
    })?;
    let num = |name: &str| opt_num(p, &k(name), t.get(name));
    let dist_name = req(
        p,
        &k("distribution"),
        opt_str(p, &k("distribution"), t.get("distribution"))?,
        "\"normal\", \"uniform\" or \"fixed\"",
    )?;
    let unused = |names: &[&str], d: &str| -> Result<()> {
        for n in names {
            if t.contains_key(*n) {
                return Err(bad(p, &k(n), format!("is not a parameter of distribution = \"{d}\"")));
            }
        }
        Ok(())
    };
    let distribution = match dist_name.as_str() {
        "normal" => {
            unused(&["min", "max", "value"], "normal")?;
            let mean = num("mean")?.unwrap_or(0.0);
            let sigma = req(p, &k("sigma"), num("sigma")?, "σ ≥ 0, a number")?;
            if sigma < 0.0 {
                return Err(bad(p, &k("sigma"), format!("{sigma} is negative; expected σ ≥ 0")));
            }
            Distribution::Normal { mean, sigma }
        }
        "uniform" => {
            unused(&["mean", "sigma", "value"], "uniform")?;
            let min = req(p, &k("min"), num("min")?, "a number")?;
            let max = req(p, &k("max"), num("max")?, "a number")?;
            if min > max {
                return Err(bad(p, &k("max"), format!("{max} is below min = {min}")));
            }
            Distribution::Uniform { min, max }
        }
        "fixed" => {
            unused(&["mean", "sigma", "min", "max"], "fixed")?;
            Distribution::Fixed { value: req(p, &k("value"), num("value")?, "a number")? }
        }
        other => {
            return Err(bad(
                p,
                &k("distribution"),
                format!("\"{other}\" is unknown; expected \"normal\", \"uniform\" or \"fixed\""),
            ))
        }
    };
    // Every draw finite: a normal's draws reach a few σ (|n| < 7 from 32-bit uniforms),
    // a uniform's span max − min.
    let reach = match distribution {
        Distribution::Normal { mean, sigma } => mean.abs() + 10.0 * sigma,
        Distribution::Uniform { min, max } => max - min,
        Distribution::Fixed { value } => value,
    };
    if !reach.is_finite() {
        return Err(bad(
            p,
            &k("distribution"),
            format!("{} can draw values beyond any finite number", distribution.describe()),
        ));
    }
    let per = match opt_str(p, &k("per"), t.get("per"))?.as_deref() {
        None | Some("trial") => Per::Trial,
        Some("pixel") => Per::Pixel,
        Some(o) => return Err(bad(p, &k("per"), format!("\"{o}\" is unknown; expected \"trial\" or \"pixel\""))),
    };
    let known = match t.get("known") {
        None | Some(Value::Boolean(false)) => Known::No,
        Some(Value::Boolean(true)) => Known::Yes,
        Some(Value::String(s)) if s == "both" => Known::Both,
        Some(v) => return Err(bad(p, &k("known"), format!("found {v}; expected true, false or \"both\""))),
    };
    // What fits what.
    match (target, per) {
        (Target::PixelNoise(_), Per::Pixel) => match distribution {
            Distribution::Normal { mean: 0.0, .. } => {}
            _ => {
                return Err(bad(
                    p,
                    &k("distribution"),
                    "per-pixel noise is drawn per pixel as N(0, σ): expected distribution = \"normal\" with mean 0"
                        .into(),
                ))
            }
        },
        (Target::PixelNoise(_), Per::Trial) => {
            return Err(bad(p, &k("per"), format!("`{}` is per-pixel noise: expected per = \"pixel\"", pname)))
        }
        (_, Per::Pixel) => {
            return Err(bad(
                p,
                &k("per"),
                format!("`{pname}` is drawn once per trial; per = \"pixel\" is for sensor.dsnu_dn, sensor.prnu, sensor.read_noise_dn"),
            ))
        }
        _ => {}
    }
    if known != Known::No && !target.compensable() {
        return Err(bad(
            p,
            &k("known"),
            format!("the reconstruction cannot compensate `{pname}`; expected known = false"),
        ));
    }
    if matches!(target, Target::ImuTilt { .. })
        && known != Known::No
        && extractors.iter().any(|e| *e != SweepExtractor::Plain(Extractor::SunVector))
    {
        return Err(bad(
            p,
            &k("known"),
            "the plain meridian_line reads a level camera only: a known tilt needs extractors = [\"sun_vector\"]"
                .into(),
        ));
    }
    if let Target::Effect { effect, param } = target {
        let spec = &effect.params[param];
        let (lo, hi) = match distribution {
            Distribution::Normal { mean, .. } => (mean, mean),
            Distribution::Uniform { min, max } => (min, max),
            Distribution::Fixed { value } => (value, value),
        };
        if lo < spec.min || hi > spec.max {
            return Err(bad(
                p,
                &k("distribution"),
                format!(
                    "`{pname}` must lie in [{}, {}] {}; this distribution reaches [{lo}, {hi}]",
                    spec.min, spec.max, spec.unit
                ),
            ));
        }
    }
    Ok(ErrorSpec { source, target, distribution, per, known })
}

fn extractor_names() -> String {
    SweepExtractor::ALL.iter().map(|e| format!("\"{}\"", e.name())).collect::<Vec<_>>().join(", ")
}

fn expected_list_of_extractors() -> String {
    format!("expected a non-empty list of {}", extractor_names())
}

fn check_keys(p: &Path, prefix: &str, t: &Table, allowed: &[&str]) -> Result<()> {
    for key in t.keys() {
        if !allowed.contains(&key.as_str()) {
            return Err(bad(
                p,
                &format!("{prefix}{key}"),
                format!("unknown key; expected one of {}", allowed.join(", ")),
            ));
        }
    }
    Ok(())
}

fn req<T>(p: &Path, key: &str, v: Option<T>, expected: &str) -> Result<T> {
    v.ok_or_else(|| bad(p, key, format!("missing; expected {expected}")))
}

fn table_of(p: &Path, key: &str, v: Option<&Value>) -> Result<Table> {
    match v {
        Some(Value::Table(t)) => Ok(t.clone()),
        Some(v) => Err(bad(p, key, format!("found {v}; expected a table [{key}]"))),
        None => Err(bad(p, key, format!("missing; expected a table [{key}]"))),
    }
}

fn opt_num(p: &Path, key: &str, v: Option<&Value>) -> Result<Option<f64>> {
    match v {
        None => Ok(None),
        Some(Value::Float(x)) if x.is_finite() => Ok(Some(*x)),
        Some(Value::Integer(i)) => Ok(Some(*i as f64)),
        Some(v) => Err(bad(p, key, format!("found {v}; expected a finite number"))),
    }
}

fn opt_int(p: &Path, key: &str, v: Option<&Value>, min: i64, max: i64) -> Result<Option<i64>> {
    match v {
        None => Ok(None),
        Some(Value::Integer(i)) if (min..=max).contains(i) => Ok(Some(*i)),
        Some(v) => Err(bad(p, key, format!("found {v}; expected a whole number in [{min}, {max}]"))),
    }
}

fn opt_str(p: &Path, key: &str, v: Option<&Value>) -> Result<Option<String>> {
    match v {
        None => Ok(None),
        Some(Value::String(s)) => Ok(Some(s.clone())),
        Some(v) => Err(bad(p, key, format!("found {v}; expected a string"))),
    }
}

fn opt_bool(p: &Path, key: &str, v: Option<&Value>) -> Result<Option<bool>> {
    match v {
        None => Ok(None),
        Some(Value::Boolean(b)) => Ok(Some(*b)),
        Some(v) => Err(bad(p, key, format!("found {v}; expected true or false"))),
    }
}

/// A list of numbers, or `{ from, to, step }` (both ends included when on the grid).
fn list_or_range(p: &Path, key: &str, v: Option<&Value>) -> Result<Option<Vec<f64>>> {
    let out = match v {
        None => return Ok(None),
        Some(Value::Array(a)) => {
            let mut out = Vec::with_capacity(a.len());
            for (i, x) in a.iter().enumerate() {
                out.push(opt_num(p, &format!("{key}[{i}]"), Some(x))?.expect("present"));
            }
            out
        }
        Some(Value::Table(t)) => {
            let pre = format!("{key}.");
            check_keys(p, &pre, t, &["from", "to", "step"])?;
            let get = |n: &str| req(p, &format!("{pre}{n}"), opt_num(p, &format!("{pre}{n}"), t.get(n))?, "a number");
            let (from, to, step) = (get("from")?, get("to")?, get("step")?);
            if step.is_nan() || step <= 0.0 || to < from {
                return Err(bad(
                    p,
                    key,
                    format!("expected from ≤ to and step > 0, found from = {from}, to = {to}, step = {step}"),
                ));
            }
            // Counted in floating point first: a tiny step (1e-320) or a huge span
            // overflows any integer.
            let count = ((to - from) / step + 1e-9).floor() + 1.0;
            if count > 100_000.0 {
                return Err(bad(p, key, format!("{count:.3e} values; expected at most 100000")));
            }
            (0..count as usize).map(|k| from + step * k as f64).collect()
        }
        Some(v) => return Err(bad(p, key, format!("found {v}; expected a list of numbers or {{ from, to, step }}"))),
    };
    if out.is_empty() {
        return Err(bad(p, key, "empty; expected at least one value".into()));
    }
    Ok(Some(out))
}
