//! A sweep's output folder: the per-trial errors (`trials.csv`, so that a merge
//! computes exact percentiles), the summary (`summary.json`, `summary.csv`,
//! `budget.csv`) and, written last, `shard.toml`, which says the slice is complete.
//!
//! Every file goes through [`crate::output::write_with`] (a temporary beside it,
//! renamed into place), so a killed run leaves no half file under a final name; a
//! folder without `shard.toml`, or with one for another sweep, slice, trial count or
//! backend, is recomputed; a folder whose `shard.toml` matches is not.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::run::{record_columns, unit_count, unit_index, Shard, TrialRecord, Unit};
use super::spec::{bad, SweepSpec};
use super::stats::{summarise, Summary};
use crate::error::{Error, Result};
use crate::output::{write_with, Replace};

/// `shard.toml`'s format name.
pub const SHARD_FORMAT: &str = "bpins-sweep-shard/1";

/// `shard.toml`: which slice of which sweep this folder holds, complete.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShardMeta {
    pub format: String,
    /// The sweep file's name, and its text (a merge needs no other input).
    pub sweep_file: String,
    pub sweep_hash: String,
    pub trials_per_source: usize,
    pub shard_index: usize,
    pub shard_count: usize,
    pub first_unit: usize,
    pub end_unit: usize,
    pub backend: String,
    pub sweep_text: String,
}

impl ShardMeta {
    fn new(spec: &SweepSpec, shard: Shard, backend: &str) -> ShardMeta {
        let r = shard.range(unit_count(spec));
        ShardMeta {
            format: SHARD_FORMAT.into(),
            sweep_file: spec.path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default(),
            sweep_hash: format!("{:016x}", spec.text_hash),
            trials_per_source: spec.trials,
            shard_index: shard.index,
            shard_count: shard.count,
            first_unit: r.start,
            end_unit: r.end,
            backend: backend.into(),
            sweep_text: spec.text.clone(),
        }
    }

    /// Reads `dir/shard.toml`; `None` when there is none.
    pub fn read(dir: &Path) -> Result<Option<ShardMeta>> {
        let p = dir.join("shard.toml");
        let text = match std::fs::read_to_string(&p) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(Error::Io { path: p, source: e }),
        };
        let m: ShardMeta = toml::from_str(&text)
            .map_err(|e| bad(&p, "(file)", format!("not a {SHARD_FORMAT} file: {}", e.message())))?;
        if m.format != SHARD_FORMAT {
            return Err(bad(&p, "format", format!("expected \"{SHARD_FORMAT}\", found \"{}\"", m.format)));
        }
        Ok(Some(m))
    }

    /// The sweep it ran, parsed again from its text, with its trial count.
    pub fn spec(&self, dir: &Path) -> Result<SweepSpec> {
        let mut s = SweepSpec::parse(&dir.join(&self.sweep_file), &self.sweep_text)?;
        s.trials = self.trials_per_source;
        Ok(s)
    }
}

/// What [`run_to_dir`] did.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    /// The slice was computed and written.
    Computed(Summary),
    /// `shard.toml` said the slice was already complete: nothing was recomputed.
    AlreadyComplete,
}

/// Runs slice `shard` of `spec` on `engine` into `dir` (created if needed), unless
/// `dir` already holds that slice complete.
pub fn run_to_dir(
    spec: &SweepSpec,
    shard: Shard,
    engine: &dyn super::run::SumsEngine,
    dir: &Path,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Outcome> {
    let meta = ShardMeta::new(spec, shard, engine.name());
    if ShardMeta::read(dir).ok().flatten().as_ref() == Some(&meta) && dir.join("trials.csv").is_file() {
        return Ok(Outcome::AlreadyComplete);
    }
    // What the engine cannot sweep is refused before the folder is made or touched.
    super::run::check_engine(spec, engine)?;
    std::fs::create_dir_all(dir).map_err(|e| Error::Io { path: dir.to_path_buf(), source: e })?;
    // An earlier, different run's marker goes first: the folder is incomplete until
    // the new one is written.
    let marker = dir.join("shard.toml");
    if marker.exists() {
        std::fs::remove_file(&marker).map_err(|e| Error::Io { path: marker.clone(), source: e })?;
    }
    let records = super::run::run_units(spec, shard.range(unit_count(spec)), engine, progress)?;
    let summary = write_outputs(spec, &records, dir)?;
    write_meta(dir, &meta)?;
    Ok(Outcome::Computed(summary))
}

/// Merges complete shard folders of one sweep into `out`: the same files a whole run
/// writes, bit for bit. Refuses folders of different sweeps, trial counts, shard
/// counts or backends, a missing or repeated slice, or an incomplete folder.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<Summary> {
    let mut metas = Vec::new();
    for d in dirs {
        let m = ShardMeta::read(d)?.ok_or_else(|| {
            bad(&d.join("shard.toml"), "(file)", "missing: the slice is incomplete; run it again (it restarts)".into())
        })?;
        metas.push((d.clone(), m));
    }
    let Some((d0, first)) = metas.first().cloned() else {
        return Err(bad(out, "(shards)", "no shard folders given".into()));
    };
    let spec = first.spec(&d0)?;
    let mut seen = vec![None; first.shard_count];
    for (d, m) in &metas {
        let p = d.join("shard.toml");
        for (key, a, b) in [("sweep_hash", &m.sweep_hash, &first.sweep_hash), ("backend", &m.backend, &first.backend)] {
            if a != b {
                return Err(bad(
                    &p,
                    key,
                    format!("\"{a}\" differs from {}'s \"{b}\": not slices of one sweep", d0.display()),
                ));
            }
        }
        for (key, a, b) in [
            ("trials_per_source", m.trials_per_source, first.trials_per_source),
            ("shard_count", m.shard_count, first.shard_count),
        ] {
            if a != b {
                return Err(bad(&p, key, format!("{a} differs from {}'s {b}: not slices of one sweep", d0.display())));
            }
        }
        if let Some(other) = seen[m.shard_index].replace(d.clone()) {
            return Err(bad(&p, "shard_index", format!("slice {} is also {}", m.shard_index, other.display())));
        }
    }
    if let Some(i) = seen.iter().position(Option::is_none) {
        return Err(bad(out, "(shards)", format!("slice {i}/{} is missing", first.shard_count)));
    }
    let mut records = Vec::new();
    for d in seen.into_iter().flatten() {
        records.extend(read_trials(&spec, &d.join("trials.csv"))?);
    }
    std::fs::create_dir_all(out).map_err(|e| Error::Io { path: out.to_path_buf(), source: e })?;
    let summary = write_outputs(&spec, &records, out)?;
    let mut whole = ShardMeta::new(&spec, Shard::WHOLE, &first.backend);
    whole.sweep_file = first.sweep_file.clone();
    write_meta(out, &whole)?;
    Ok(summary)
}

fn write_meta(dir: &Path, meta: &ShardMeta) -> Result<()> {
    let text =
        toml::to_string(meta).map_err(|e| Error::Encode { what: "shard.toml".into(), message: e.to_string() })?;
    crate::output::write_bytes(&dir.join("shard.toml"), Replace::Allowed, text.as_bytes())
}

/// Writes `trials.csv`, `summary.json`, `summary.csv` and `budget.csv` into `dir`.
pub fn write_outputs(spec: &SweepSpec, records: &[TrialRecord], dir: &Path) -> Result<Summary> {
    let summary = summarise(spec, records);
    write_trials(spec, records, &dir.join("trials.csv"))?;
    let json = serde_json::to_string_pretty(&summary)
        .map_err(|e| Error::Encode { what: "summary.json".into(), message: e.to_string() })?;
    crate::output::write_bytes(&dir.join("summary.json"), Replace::Allowed, (json + "\n").as_bytes())?;
    crate::output::write_bytes(&dir.join("summary.csv"), Replace::Allowed, summary.rows_csv().as_bytes())?;
    crate::output::write_bytes(&dir.join("budget.csv"), Replace::Allowed, summary.budget_csv().as_bytes())?;
    crate::output::write_bytes(
        &dir.join("report.html"),
        Replace::Allowed,
        super::report::html(spec, &summary)?.as_bytes(),
    )?;
    Ok(summary)
}

const TRIALS_HEADER: &str = "sun_elevation_deg,source,trial,sun_azimuth_deg,extractor,known,error_deg";

/// A colour sensor's `trials.csv` header: a line per band (R, G, B) and fused.
const COLOUR_TRIALS_HEADER: &str = "sun_elevation_deg,source,trial,sun_azimuth_deg,extractor,known,band,error_deg";

/// The header of `spec`'s `trials.csv`.
fn trials_header(spec: &SweepSpec) -> &'static str {
    if spec.sensor.colour.is_some() {
        COLOUR_TRIALS_HEADER
    } else {
        TRIALS_HEADER
    }
}

/// Every trial's every error, one line each, in unit order. Numbers are written in
/// Rust's shortest round-trip form, so reading them back gives the same bits.
fn write_trials(spec: &SweepSpec, records: &[TrialRecord], path: &Path) -> Result<()> {
    let mut recs: Vec<&TrialRecord> = records.iter().collect();
    recs.sort_by_key(|r| r.unit);
    write_with(path, Replace::Allowed, |w| {
        let io = |e| Error::Io { path: path.to_path_buf(), source: e };
        writeln!(w, "{}", trials_header(spec)).map_err(io)?;
        for r in recs {
            let cols = record_columns(spec, r.unit.source);
            for ((e, known, band), err) in cols.iter().zip(&r.errors_deg) {
                writeln!(
                    w,
                    "{},{},{},{},{},{},{}{}",
                    spec.sun_elevations_deg[r.unit.elevation],
                    spec.sources[r.unit.source],
                    r.unit.trial,
                    r.sun_azimuth_deg,
                    e.name(),
                    known.map(|k| k.to_string()).unwrap_or_default(),
                    band.map(|b| format!("{},", b.name())).unwrap_or_default(),
                    err
                )
                .map_err(io)?;
            }
        }
        Ok(())
    })
}

/// Reads `trials.csv` back into records.
pub fn read_trials(spec: &SweepSpec, path: &Path) -> Result<Vec<TrialRecord>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::Io { path: path.to_path_buf(), source: e })?;
    let mut lines = text.lines().enumerate();
    let header = trials_header(spec);
    let fields = header.split(',').count();
    match lines.next() {
        Some((_, h)) if h == header => {}
        _ => return Err(bad(path, "line 1", format!("expected the header {header}"))),
    }
    let mut by_unit: BTreeMap<usize, TrialRecord> = BTreeMap::new();
    for (i, line) in lines {
        let at = format!("line {}", i + 1);
        let f: Vec<&str> = line.split(',').collect();
        let num = |s: &str| s.parse::<f64>().map_err(|_| bad(path, &at, format!("`{s}` is not a number")));
        if f.len() != fields {
            return Err(bad(path, &at, format!("expected {fields} comma-separated fields")));
        }
        let el = num(f[0])?;
        let elevation = spec
            .sun_elevations_deg
            .iter()
            .position(|&e| e == el)
            .ok_or_else(|| bad(path, &at, format!("sun elevation {el}° is not in the sweep")))?;
        let source = spec
            .sources
            .iter()
            .position(|s| s == f[1])
            .ok_or_else(|| bad(path, &at, format!("source `{}` is not in the sweep", f[1])))?;
        let trial: usize = f[2].parse().map_err(|_| bad(path, &at, format!("`{}` is not a trial number", f[2])))?;
        if trial >= spec.trials {
            return Err(bad(path, &at, format!("trial {trial} is beyond the sweep's {}", spec.trials)));
        }
        let u = Unit { elevation, source, trial };
        let rec = by_unit.entry(unit_index(spec, u)).or_insert_with(|| TrialRecord {
            unit: u,
            sun_azimuth_deg: f64::NAN,
            errors_deg: Vec::new(),
        });
        rec.sun_azimuth_deg = num(f[3])?;
        let col = rec.errors_deg.len();
        let cols = record_columns(spec, source);
        let want = cols.get(col).ok_or_else(|| bad(path, &at, "more columns than the sweep has".into()))?;
        let known = want.1.map(|k| k.to_string()).unwrap_or_default();
        if want.0.name() != f[4] || known != f[5] {
            return Err(bad(path, &at, format!("expected extractor {} known `{known}`", want.0.name())));
        }
        if let Some(b) = want.2 {
            if f[6] != b.name() {
                return Err(bad(path, &at, format!("expected band {}", b.name())));
            }
        }
        rec.errors_deg.push(num(f[fields - 1])?);
    }
    let out: Vec<TrialRecord> = by_unit.into_values().collect();
    if let Some(r) = out.iter().find(|r| r.errors_deg.len() != record_columns(spec, r.unit.source).len()) {
        return Err(bad(
            path,
            "(file)",
            format!("trial {} of `{}` is incomplete", r.unit.trial, spec.sources[r.unit.source]),
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::run::{tests::tiny, CpuSums};
    use super::*;

    #[test]
    fn merged_slices_equal_the_whole_run_bit_for_bit() {
        let spec = tiny();
        let t = tempfile::tempdir().unwrap();
        let whole = t.path().join("whole");
        assert!(matches!(run_to_dir(&spec, Shard::WHOLE, &CpuSums, &whole, &|_, _| {}).unwrap(), Outcome::Computed(_)));
        let mut dirs = Vec::new();
        for i in 0..3 {
            let d = t.path().join(format!("s{i}"));
            run_to_dir(&spec, Shard { index: i, count: 3 }, &CpuSums, &d, &|_, _| {}).unwrap();
            dirs.push(d);
        }
        let merged = t.path().join("merged");
        merge(&dirs, &merged).unwrap();
        for f in ["summary.json", "summary.csv", "budget.csv", "trials.csv", "report.html"] {
            assert_eq!(std::fs::read(whole.join(f)).unwrap(), std::fs::read(merged.join(f)).unwrap(), "{f}");
        }
        // A finished slice is not recomputed; one without its marker is.
        assert_eq!(
            run_to_dir(&spec, Shard { index: 1, count: 3 }, &CpuSums, &dirs[1], &|_, _| {}).unwrap(),
            Outcome::AlreadyComplete
        );
        std::fs::remove_file(dirs[1].join("shard.toml")).unwrap();
        assert!(merge(&dirs, &merged).unwrap_err().to_string().contains("incomplete"));
        assert!(matches!(
            run_to_dir(&spec, Shard { index: 1, count: 3 }, &CpuSums, &dirs[1], &|_, _| {}).unwrap(),
            Outcome::Computed(_)
        ));
        // A missing slice is named.
        let e = merge(&dirs[..2], &merged).unwrap_err().to_string();
        assert!(e.contains("slice 2/3 is missing"), "{e}");
    }
}
