//! Parsing a sweep file into [`SweepSpec`] (the types are in `spec.rs`, the format is
//! documented in [`super`]): every check runs here, before any trial.
//!
//! Two stages, as for `capture.toml` (`capture/spec.rs`). serde turns the file into
//! raw structs with `deny_unknown_fields` (unknown keys, missing keys and wrong types
//! are errors naming their key, `errors[2].sigma`, through `serde_path_to_error`);
//! the raw values then become the typed spec, each range and each rule that ties keys
//! together checked with an error naming its key and what was expected.

use std::fmt;
use std::path::Path;

use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;

use super::spec::*;
use crate::capture::{parse_sensor_lens, validate_sensor_lens};
use crate::error::{Error, Result};
use crate::heading::Extractor;
use crate::sensor::Layout;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSweep {
    #[allow(dead_code)]
    format: String,
    title: Option<String>,
    seed: Option<u64>,
    trials: Option<u64>,
    extractors: Option<Vec<String>>,
    combined: Option<bool>,
    sources: Option<Vec<String>>,
    /// `[sensor]` and `[lens]` are a capture's, read by its reader.
    sensor: Option<toml::Value>,
    lens: Option<toml::Value>,
    sky: Option<RawSky>,
    response: Option<RawResponse>,
    errors: Option<Vec<RawError>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSky {
    sun_elevations_deg: Option<ListOrRange>,
    sun_azimuths_deg: Option<ListOrRange>,
    trials_per_azimuth: Option<u64>,
    dmax: Option<f64>,
    scene: Option<Vec<String>>,
}

#[derive(Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawResponse {
    peak_dn: Option<f64>,
    quantize: Option<bool>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawError {
    source: String,
    param: String,
    distribution: String,
    mean: Option<f64>,
    sigma: Option<f64>,
    min: Option<f64>,
    max: Option<f64>,
    value: Option<f64>,
    per: Option<String>,
    known: Option<Known>,
}

/// A list of numbers, or `{ from, to, step }` (both ends included when on the grid).
enum ListOrRange {
    List(Vec<f64>),
    Range { from: f64, to: f64, step: f64 },
}

impl<'de> Deserialize<'de> for ListOrRange {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ListOrRange;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a list of numbers or { from, to, step }")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> std::result::Result<ListOrRange, A::Error> {
                let mut out = Vec::new();
                while let Some(x) = seq.next_element::<f64>()? {
                    out.push(x);
                }
                Ok(ListOrRange::List(out))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> std::result::Result<ListOrRange, A::Error> {
                #[derive(Deserialize)]
                #[serde(deny_unknown_fields)]
                struct Range {
                    from: f64,
                    to: f64,
                    step: f64,
                }
                let r = Range::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Ok(ListOrRange::Range { from: r.from, to: r.to, step: r.step })
            }
        }
        d.deserialize_any(V)
    }
}

impl<'de> Deserialize<'de> for Known {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Known;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("true, false or \"both\"")
            }
            fn visit_bool<E: de::Error>(self, b: bool) -> std::result::Result<Known, E> {
                Ok(if b { Known::Yes } else { Known::No })
            }
            fn visit_str<E: de::Error>(self, s: &str) -> std::result::Result<Known, E> {
                match s {
                    "both" => Ok(Known::Both),
                    _ => Err(E::invalid_value(de::Unexpected::Str(s), &self)),
                }
            }
        }
        d.deserialize_any(V)
    }
}

/// serde's refusal as the sweep's error: the key it is about (`sky.trials_per_azimut`
/// for an unknown key, `errors[0].sigma` for a wrong type) and what was expected, in
/// this format's words.
fn serde_error(p: &Path, e: serde_path_to_error::Error<toml::de::Error>) -> Error {
    let path = e.path().to_string();
    let msg = e.inner().message().trim().to_string();
    // The path ends at an unknown key already; a missing key's is its table's.
    let join = |k: &str| match path.as_str() {
        "." => k.to_string(),
        p if p == k || p.ends_with(&format!(".{k}")) => p.to_string(),
        p => format!("{p}.{k}"),
    };
    let named = |prefix: &str| -> Option<(String, String)> {
        let rest = msg.strip_prefix(prefix)?.strip_prefix('`')?;
        let (key, tail) = rest.split_once('`')?;
        Some((key.to_string(), tail.trim_start_matches(',').trim().to_string()))
    };
    if let Some((key, tail)) = named("unknown field ") {
        let expected = tail.strip_prefix("expected one of ").unwrap_or(&tail).replace('`', "");
        return bad(p, &join(&key), format!("unknown key; expected one of {expected}"));
    }
    if let Some((key, _)) = named("missing field ") {
        return bad(p, &join(&key), "missing; expected this key here (docs/sweep.md lists each)".into());
    }
    let words = msg
        .replace("expected f64", "expected a number")
        .replace("expected u64", "expected a whole number ≥ 0")
        .replace("expected a sequence", "expected a list")
        .replace("invalid type: ", "found ");
    bad(p, if path == "." { "(file)" } else { &path }, words)
}

/// `x` as a finite number, or the error naming `key`.
fn finite(p: &Path, key: &str, x: f64) -> Result<f64> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(bad(p, key, format!("found {x}; expected a finite number")))
    }
}

impl SweepSpec {
    /// Reads and checks the sweep file at `path`.
    pub fn load(path: &Path) -> Result<SweepSpec> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::Io { path: path.to_path_buf(), source: e })?;
        SweepSpec::parse(path, &text)
    }

    /// Parses `text`, the contents of `path` (which errors name).
    pub fn parse(path: &Path, text: &str) -> Result<SweepSpec> {
        let p = path;
        let table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
            let at = e.span().map(|r| {
                let before = text.get(..r.start).unwrap_or(text);
                let line = before.matches('\n').count() + 1;
                format!(" at line {line}")
            });
            bad(p, "(file)", format!("not valid TOML{}: {}", at.unwrap_or_default(), e.message().trim()))
        })?;
        // The format first: a file of another version is named as such, not by the
        // keys this reader does not know.
        match table.get("format") {
            Some(toml::Value::String(f)) if f == FORMAT => {}
            Some(v) => return Err(bad(p, "format", format!("expected \"{FORMAT}\", found {v}"))),
            None => return Err(bad(p, "format", format!("missing; expected format = \"{FORMAT}\""))),
        }
        let raw: RawSweep =
            serde_path_to_error::deserialize(toml::Value::Table(table)).map_err(|e| serde_error(p, e))?;
        let title = raw.title.unwrap_or_default();
        let seed = raw.seed.unwrap_or(0);
        let trials = match raw.trials {
            None => return Err(bad(p, "trials", "missing; expected a whole number ≥ 1".into())),
            Some(t @ 1..=10_000_000) => t as usize,
            Some(t) => return Err(bad(p, "trials", format!("found {t}; expected a whole number in [1, 10000000]"))),
        };
        let extractors = match raw.extractors {
            None => Extractor::ALL.iter().map(|&e| SweepExtractor::Plain(e)).collect(),
            Some(list) => {
                let mut out = Vec::new();
                for (i, e) in list.iter().enumerate() {
                    let key = format!("extractors[{i}]");
                    let x = SweepExtractor::from_name(e)
                        .ok_or_else(|| bad(p, &key, format!("found \"{e}\"; expected one of {}", extractor_names())))?;
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
        let combined = raw.combined.unwrap_or(true);

        let (sensor, lens) = parse_sensor_lens(p, raw.sensor, raw.lens)?;
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
        let sky = raw.sky.ok_or_else(|| bad(p, "sky", "missing; expected a table [sky]".into()))?;
        let sun_elevations_deg = match sky.sun_elevations_deg {
            Some(v) => values(p, "sky.sun_elevations_deg", v)?,
            None => {
                return Err(bad(
                    p,
                    "sky.sun_elevations_deg",
                    "missing; expected a list of degrees or { from, to, step }".into(),
                ))
            }
        };
        for (i, &e) in sun_elevations_deg.iter().enumerate() {
            if !(e > 0.0 && e < 90.0) {
                return Err(bad(
                    p,
                    &format!("sky.sun_elevations_deg[{i}]"),
                    format!("{e}° is outside (0°, 90°): the plain extractors need the sun above the horizon and off the zenith"),
                ));
            }
        }
        let sun_azimuths_deg = match sky.sun_azimuths_deg {
            Some(v) => values(p, "sky.sun_azimuths_deg", v)?,
            None => vec![0.0],
        };
        for (i, &a) in sun_azimuths_deg.iter().enumerate() {
            if !(-360.0..=360.0).contains(&a) {
                return Err(bad(
                    p,
                    &format!("sky.sun_azimuths_deg[{i}]"),
                    format!("{a}° is outside [−360°, 360°] (one turn either way of north, as in a capture)"),
                ));
            }
        }
        let trials_per_azimuth = match sky.trials_per_azimuth {
            None => 1,
            Some(n @ 1..) => n as usize,
            Some(n) => return Err(bad(p, "sky.trials_per_azimuth", format!("found {n}; expected a whole number ≥ 1"))),
        };
        let dmax = finite(p, "sky.dmax", sky.dmax.unwrap_or(0.6))?;
        if !(dmax > 0.0 && dmax <= 1.0) {
            return Err(bad(p, "sky.dmax", format!("{dmax} is outside (0, 1]")));
        }
        let scene = sky.scene.unwrap_or_default();
        let mut check = crate::scene::FieldScene::new(0);
        for (i, spec) in scene.iter().enumerate() {
            check.parse(spec).map_err(|e| {
                bad(
                    p,
                    &format!("sky.scene[{i}]"),
                    format!("{e}; expected an element of `bpins simulate --scene` or element.param=value"),
                )
            })?;
        }

        // [response]
        let resp = raw.response.unwrap_or_default();
        let peak_dn = finite(p, "response.peak_dn", resp.peak_dn.unwrap_or(1000.0))?;
        let full = sensor.full_scale_dn();
        if !(peak_dn > 0.0 && peak_dn <= full) {
            return Err(bad(
                p,
                "response.peak_dn",
                format!("{peak_dn} DN is outside (0, {full}] DN (the bit depth's full scale)"),
            ));
        }
        let quantize = resp.quantize.unwrap_or(false);

        // [[errors]]
        let list = raw.errors.unwrap_or_default();
        if list.is_empty() {
            return Err(bad(p, "errors", "missing; expected at least one [[errors]] table".into()));
        }
        let mut errors: Vec<ErrorSpec> = Vec::new();
        for (i, e) in list.into_iter().enumerate() {
            let e = parse_error(p, i, e, &extractors)?;
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
        if let Some(list) = raw.sources {
            let mut order: Vec<String> = Vec::new();
            for (i, name) in list.iter().enumerate() {
                let key = format!("sources[{i}]");
                if !sources.contains(name) {
                    return Err(bad(
                        p,
                        &key,
                        format!(
                            "`{name}` is the source of no [[errors]] table; expected one of {}",
                            sources.join(", ")
                        ),
                    ));
                }
                if order.contains(name) {
                    return Err(bad(p, &key, format!("`{name}` is listed twice")));
                }
                order.push(name.clone());
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
}

fn parse_error(p: &Path, i: usize, t: RawError, extractors: &[SweepExtractor]) -> Result<ErrorSpec> {
    let k = |name: &str| format!("errors[{i}].{name}");
    let source = t.source;
    if source.is_empty() || source == COMBINED {
        return Err(bad(p, &k("source"), format!("`{source}` is reserved or empty; name the source")));
    }
    let pname = t.param;
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
    // Each number of the distribution: given or not, and finite where given.
    let given = [("mean", t.mean), ("sigma", t.sigma), ("min", t.min), ("max", t.max), ("value", t.value)];
    for (name, v) in given {
        if let Some(x) = v {
            finite(p, &k(name), x)?;
        }
    }
    let unused = |names: &[&str], d: &str| -> Result<()> {
        for (name, v) in given {
            if names.contains(&name) && v.is_some() {
                return Err(bad(p, &k(name), format!("is not a parameter of distribution = \"{d}\"")));
            }
        }
        Ok(())
    };
    let need = |name: &str, v: Option<f64>, expected: &str| {
        v.ok_or_else(|| bad(p, &k(name), format!("missing; expected {expected}")))
    };
    let distribution = match t.distribution.as_str() {
        "normal" => {
            unused(&["min", "max", "value"], "normal")?;
            let sigma = need("sigma", t.sigma, "σ ≥ 0, a number")?;
            if sigma < 0.0 {
                return Err(bad(p, &k("sigma"), format!("{sigma} is negative; expected σ ≥ 0")));
            }
            Distribution::Normal { mean: t.mean.unwrap_or(0.0), sigma }
        }
        "uniform" => {
            unused(&["mean", "sigma", "value"], "uniform")?;
            let min = need("min", t.min, "a number")?;
            let max = need("max", t.max, "a number")?;
            if min > max {
                return Err(bad(p, &k("max"), format!("{max} is below min = {min}")));
            }
            Distribution::Uniform { min, max }
        }
        "fixed" => {
            unused(&["mean", "sigma", "min", "max"], "fixed")?;
            Distribution::Fixed { value: need("value", t.value, "a number")? }
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
    let per = match t.per.as_deref() {
        None | Some("trial") => Per::Trial,
        Some("pixel") => Per::Pixel,
        Some(o) => return Err(bad(p, &k("per"), format!("\"{o}\" is unknown; expected \"trial\" or \"pixel\""))),
    };
    let known = t.known.unwrap_or(Known::No);
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

/// The values of a list or of `{ from, to, step }` (both ends included when on the
/// grid), each finite, at least one and at most 100 000.
fn values(p: &Path, key: &str, v: ListOrRange) -> Result<Vec<f64>> {
    let out = match v {
        ListOrRange::List(list) => {
            for (i, &x) in list.iter().enumerate() {
                finite(p, &format!("{key}[{i}]"), x)?;
            }
            list
        }
        ListOrRange::Range { from, to, step } => {
            for (n, x) in [("from", from), ("to", to), ("step", step)] {
                finite(p, &format!("{key}.{n}"), x)?;
            }
            if step <= 0.0 || to < from {
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
    };
    if out.is_empty() {
        return Err(bad(p, key, "empty; expected at least one value".into()));
    }
    Ok(out)
}
