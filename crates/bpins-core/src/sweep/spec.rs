//! A sweep file (`bpins-sweep/1`, the format is documented in [`super`]) as types:
//! the spec, its error sources, targets and distributions. `parse.rs` reads one.
//!
//! Everything is checked while parsing, before any trial runs: unknown keys, missing
//! keys, wrong types, ranges, parameters the registry does not know, distributions that
//! do not fit their parameter, `known` where the reconstruction cannot compensate.
//! Every error is [`Error::Sweep`]: the file, the key (`errors[2].sigma`) and what
//! was expected.

use std::path::{Path, PathBuf};

use crate::camera::Intrinsics;
use crate::capture::{LensSpec, SensorSpec};
use crate::effects::{find, EffectDef, Stage};
use crate::error::Error;
use crate::heading::Extractor;
use crate::sensor::{Channel, Layout};

/// The value of the `format` key this reader implements.
pub const FORMAT: &str = "bpins-sweep/1";

/// Name of the row that draws every error source at once.
pub const COMBINED: &str = "combined";

/// A parsed, checked sweep file.
#[derive(Clone, Debug)]
pub struct SweepSpec {
    /// The file it was read from (errors and outputs name it).
    pub path: PathBuf,
    /// The file's text, kept so that a shard's output carries the sweep it ran.
    pub text: String,
    /// FNV-1a hash of `text`: shards of different sweeps are never merged.
    pub text_hash: u64,
    pub title: String,
    pub sensor: SensorSpec,
    pub lens: LensSpec,
    /// Sun elevations, degrees: one set of rows each.
    pub sun_elevations_deg: Vec<f64>,
    /// Sun azimuths, degrees: trial `t` uses `[(t / trials_per_azimuth) mod len]`.
    pub sun_azimuths_deg: Vec<f64>,
    pub trials_per_azimuth: usize,
    /// The sky's peak degree of linear polarization.
    pub dmax: f64,
    /// Field conditions (`bpins simulate --scene` elements: clouds, skyline, …) as
    /// written in `[sky] scene`; empty: the lab-clean Rayleigh sky.
    pub scene: Vec<String>,
    /// The nominal sensor's largest noise-free response, DN (sets the gain).
    pub peak_dn: f64,
    /// Round and clip the DN to `[sensor] bit_depth` (default off: a continuous sensor).
    pub quantize: bool,
    /// Every error, in file order; its index keys its random draw.
    pub errors: Vec<ErrorSpec>,
    /// The sources (rows), in order of first appearance, then [`COMBINED`] when on.
    pub sources: Vec<String>,
    pub combined: bool,
    pub extractors: Vec<SweepExtractor>,
    /// Trials per source and sun elevation.
    pub trials: usize,
    pub seed: u64,
}

impl SweepSpec {
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

/// A heading extractor a sweep can use: bpins' two ([`Extractor`], solved from the
/// additive sums, on either backend) or `edge_point`, the seed paper's own as the
/// README reads it (`sweep/edge_point.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SweepExtractor {
    Plain(Extractor),
    EdgePoint,
}

impl SweepExtractor {
    pub const ALL: [SweepExtractor; 3] = [
        SweepExtractor::Plain(Extractor::SunVector),
        SweepExtractor::Plain(Extractor::MeridianLine),
        SweepExtractor::EdgePoint,
    ];

    pub fn name(self) -> &'static str {
        match self {
            SweepExtractor::Plain(e) => e.name(),
            SweepExtractor::EdgePoint => "edge_point",
        }
    }

    pub fn from_name(name: &str) -> Option<SweepExtractor> {
        SweepExtractor::ALL.into_iter().find(|e| e.name() == name)
    }
}

/// One error: a parameter, its distribution, and whether the reconstruction knows it.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorSpec {
    /// The row it reports under; errors sharing a source are drawn together.
    pub source: String,
    pub target: Target,
    pub distribution: Distribution,
    pub per: Per,
    pub known: Known,
}

/// What an error changes.
#[derive(Clone, Copy, Debug)]
pub enum Target {
    /// A catalog effect's parameter (`effect.param`, as `bpins effects` lists them).
    Effect {
        effect: &'static EffectDef,
        param: usize,
    },
    /// `lens.rho_corner`: the lens diattenuation ρ at the field's corner; sets
    /// `lens_diattenuation.rho2 = ρ / r²_corner` (the seed paper's reading of its ρ).
    LensRhoCorner,
    /// `imu.tilt_x_deg` / `imu.tilt_y_deg`: the camera's true tilt; the reconstruction
    /// believes it level unless the error is known.
    ImuTilt {
        axis: usize,
    },
    /// `sun.azimuth_deg` / `sun.elevation_deg`: the error of the sun position the
    /// reconstruction assumes (the true sun is the nominal one).
    SunAzimuth,
    SunElevation,
    /// `sensor.dsnu_dn`, `sensor.prnu`, `sensor.read_noise_dn`: per-pixel noise, σ.
    PixelNoise(PixelNoise),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelNoise {
    /// Offset non-uniformity (the seed's "grayscale response inconsistency"), DN.
    Dsnu,
    /// Gain non-uniformity, relative.
    Prnu,
    /// Temporal read noise, DN.
    ReadNoise,
}

impl PartialEq for Target {
    fn eq(&self, other: &Target) -> bool {
        self.name() == other.name()
    }
}

impl Target {
    /// The name as written in a sweep file.
    pub fn name(&self) -> String {
        match self {
            Target::Effect { effect, param } => format!("{}.{}", effect.name, effect.params[*param].name),
            Target::LensRhoCorner => "lens.rho_corner".into(),
            Target::ImuTilt { axis } => format!("imu.tilt_{}_deg", ["x", "y"][*axis]),
            Target::SunAzimuth => "sun.azimuth_deg".into(),
            Target::SunElevation => "sun.elevation_deg".into(),
            Target::PixelNoise(PixelNoise::Dsnu) => "sensor.dsnu_dn".into(),
            Target::PixelNoise(PixelNoise::Prnu) => "sensor.prnu".into(),
            Target::PixelNoise(PixelNoise::ReadNoise) => "sensor.read_noise_dn".into(),
        }
    }

    /// The value at which it does nothing.
    pub fn neutral(&self) -> f64 {
        match self {
            Target::Effect { effect, param } => effect.params[*param].neutral,
            _ => 0.0,
        }
    }

    pub(super) fn parse(name: &str) -> Option<Target> {
        Some(match name {
            "lens.rho_corner" => Target::LensRhoCorner,
            "imu.tilt_x_deg" => Target::ImuTilt { axis: 0 },
            "imu.tilt_y_deg" => Target::ImuTilt { axis: 1 },
            "sun.azimuth_deg" => Target::SunAzimuth,
            "sun.elevation_deg" => Target::SunElevation,
            "sensor.dsnu_dn" => Target::PixelNoise(PixelNoise::Dsnu),
            "sensor.prnu" => Target::PixelNoise(PixelNoise::Prnu),
            "sensor.read_noise_dn" => Target::PixelNoise(PixelNoise::ReadNoise),
            _ => {
                let (e, p) = name.split_once('.')?;
                let effect = find(e).ok()?;
                let param = effect.params.iter().position(|q| q.name == p)?;
                Target::Effect { effect, param }
            }
        })
    }

    /// Whether the plain reconstruction can compensate it when it is known: the
    /// camera's geometry (assumed intrinsics), the analyzers and channel responses
    /// (the Stokes inversion), the lens diattenuation (seed eq. 13), the mount and
    /// IMU tilts (the level frame) and the sun.
    pub(super) fn compensable(&self) -> bool {
        match self {
            Target::Effect { effect, .. } => {
                matches!(effect.stage, Stage::Geometry | Stage::Analyzer)
                    || effect.name == "lens_diattenuation"
                    || effect.name == "channel_response"
            }
            Target::PixelNoise(_) => false,
            _ => true,
        }
    }
}

/// A per-trial (or, for pixel noise, per-pixel) distribution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Distribution {
    Normal { mean: f64, sigma: f64 },
    Uniform { min: f64, max: f64 },
    Fixed { value: f64 },
}

impl Distribution {
    /// The value for a standard normal `n` and a uniform `u` in [0, 1).
    pub fn value(&self, n: f64, u: f64) -> f64 {
        match *self {
            Distribution::Normal { mean, sigma } => mean + sigma * n,
            Distribution::Uniform { min, max } => min + (max - min) * u,
            Distribution::Fixed { value } => value,
        }
    }

    /// Its standard deviation.
    pub fn sigma(&self) -> f64 {
        match *self {
            Distribution::Normal { sigma, .. } => sigma,
            Distribution::Uniform { min, max } => (max - min) / 12f64.sqrt(),
            Distribution::Fixed { .. } => 0.0,
        }
    }

    /// As a short text: `N(0, 2)`, `U(-1, 1)`, `= 0.3`.
    pub fn describe(&self) -> String {
        match *self {
            Distribution::Normal { mean, sigma } => format!("N({mean}, {sigma})"),
            Distribution::Uniform { min, max } => format!("U({min}, {max})"),
            Distribution::Fixed { value } => format!("= {value}"),
        }
    }
}

/// How often an error is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Per {
    Trial,
    Pixel,
}

/// Whether the reconstruction knows the drawn value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Known {
    No,
    Yes,
    /// Both ways, from the same trial: the rows carry `known = true` and `false`.
    Both,
}

pub(crate) fn bad(p: &Path, key: &str, message: String) -> Error {
    Error::Sweep { path: p.to_path_buf(), key: key.to_string(), message }
}

/// FNV-1a, 64 bit.
pub(crate) fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// A small sweep the tests of this module and its siblings share.
#[cfg(test)]
pub(crate) const TINY_FOR_TESTS: &str = r#"
format = "bpins-sweep/1"
seed = 7
trials = 4
[sensor]
layout = "colocated"
width_px = 64
height_px = 48
pixel_pitch_um = 55.2
channels = [0, 45, 90]
[lens]
projection = "pinhole"
focal_length_mm = 8.0
[sky]
sun_elevations_deg = [5, 30]
sun_azimuths_deg = { from = 10, to = 40, step = 10 }
trials_per_azimuth = 1
[response]
peak_dn = 153
[[errors]]
source = "array_rotation"
param = "array_rotation.dtheta_deg"
distribution = "normal"
sigma = 0.1
[[errors]]
source = "grayscale"
param = "sensor.dsnu_dn"
distribution = "normal"
sigma = 1.0
per = "pixel"
"#;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Result;

    const TINY: &str = TINY_FOR_TESTS;

    fn parse(text: &str) -> Result<SweepSpec> {
        SweepSpec::parse(Path::new("my-sweep.toml"), text)
    }

    fn err_of(text: &str) -> String {
        parse(text).unwrap_err().to_string()
    }

    #[test]
    fn every_shipped_sweep_file_parses() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/sweeps");
        let mut n = 0;
        for f in std::fs::read_dir(&dir).unwrap() {
            let p = f.unwrap().path();
            if p.extension().and_then(|e| e.to_str()) == Some("toml") {
                SweepSpec::load(&p).unwrap_or_else(|e| panic!("{e}"));
                n += 1;
            }
        }
        assert!(n >= 6, "{n} sweep files in {}", dir.display());
    }

    #[test]
    fn a_small_sweep_parses_with_its_defaults() {
        let s = parse(TINY).unwrap();
        assert_eq!(s.sun_elevations_deg, vec![5.0, 30.0]);
        assert_eq!(s.sun_azimuths_deg, vec![10.0, 20.0, 30.0, 40.0]);
        assert_eq!(s.sources, vec!["array_rotation", "grayscale", "combined"]);
        assert_eq!(s.extractors, SweepExtractor::ALL[..2].to_vec());
        assert_eq!(s.errors[1].per, Per::Pixel);
        assert_eq!(s.sun_azimuth_deg(5), 20.0);
        assert_eq!(s.intrinsics().cx_px, 31.5);
    }

    #[test]
    fn bad_files_name_the_file_the_key_and_what_was_expected() {
        let cases: &[(&str, &str, &str)] = &[
            ("sigma = 0.1", "sigma = -0.1", "errors[0].sigma"),
            ("sigma = 0.1", "sigma = \"big\"", "errors[0].sigma"),
            ("param = \"array_rotation.dtheta_deg\"", "param = \"array_rotation.dtheta\"", "errors[0].param"),
            ("trials = 4", "trials = 0", "trials"),
            ("trials = 4", "", "trials"),
            ("sun_elevations_deg = [5, 30]", "sun_elevations_deg = [5, 95]", "sky.sun_elevations_deg[1]"),
            ("trials_per_azimuth = 1", "trials_per_azimut = 1", "sky.trials_per_azimut"),
            ("per = \"pixel\"", "per = \"trial\"", "errors[1].per"),
            (
                "distribution = \"normal\"\nsigma = 0.1",
                "distribution = \"gauss\"\nsigma = 0.1",
                "errors[0].distribution",
            ),
            ("format = \"bpins-sweep/1\"", "format = \"bpins-sweep/2\"", "format"),
            ("peak_dn = 153", "peak_dn = 1e9", "response.peak_dn"),
            ("trials_per_azimuth = 1", "trials_per_azimuth = 1\nscene = [\"fog\"]", "sky.scene[0]"),
            // What serde refuses is named by its key as well: a missing key, an
            // unknown one in an [[errors]] table, a wrong type in a list.
            ("param = \"array_rotation.dtheta_deg\"", "", "errors[0].param"),
            ("sigma = 0.1", "sigma = 0.1\nsgima = 0.2", "errors[0].sgima"),
            ("sun_elevations_deg = [5, 30]", "sun_elevations_deg = [5, \"high\"]", "sky.sun_elevations_deg[1]"),
            ("trials = 4", "trials = -4", "trials"),
        ];
        for (from, to, key) in cases {
            assert!(TINY.contains(from), "{from}");
            let e = err_of(&TINY.replacen(from, to, 1));
            assert!(e.starts_with("my-sweep.toml: "), "{e}");
            assert!(!e.contains("f64") && !e.contains("u64") && !e.contains("field"), "serde's words: {e}");
            assert!(e.contains(&format!(": {key}: ")), "{key}: {e}");
            assert!(
                e.contains("expected") || e.contains("must") || e.contains("outside") || e.contains("negative"),
                "{e}"
            );
        }
        // The sensor is a capture's, checked as CAPTURE.md says, naming the file.
        let e = err_of(&TINY.replacen("pixel_pitch_um = 55.2", "pixel_pitch_um = -1", 1));
        assert!(e.contains("my-sweep.toml") && e.contains("pixel_pitch_um"), "{e}");
        let e = err_of(&TINY.replacen("[lens]", "[lens]\nfocal = 3", 1));
        assert!(e.contains("my-sweep.toml") && e.contains("focal"), "{e}");
        // A colour sensor is swept band by band (colour.rs); its tiles are a DoFP
        // sensor's, as a capture's are.
        let colour = TINY.replacen("layout = \"colocated\"", "layout = \"dofp\"", 1).replacen(
            "channels = [0, 45, 90]",
            "colour_tiles = [[\"R\", \"G\"], [\"G\", \"B\"]]",
            1,
        );
        assert!(parse(&colour).unwrap().sensor.colour.is_some());
        let e = err_of(&TINY.replacen("channels = [0, 45, 90]", "colour_tiles = [[\"R\", \"G\"], [\"G\", \"B\"]]", 1));
        assert!(e.contains("my-sweep.toml") && e.contains("colour_tiles is for layout = \"dofp\""), "{e}");
    }

    #[test]
    fn known_is_refused_where_the_reconstruction_cannot_compensate() {
        let e = err_of(&TINY.replacen("per = \"pixel\"", "per = \"pixel\"\nknown = true", 1));
        assert!(e.contains("errors[1].known") && e.contains("cannot compensate"), "{e}");
        let tilt = TINY.replacen("array_rotation.dtheta_deg", "imu.tilt_x_deg", 1);
        assert!(parse(&tilt).is_ok());
        let e = err_of(&tilt.replacen("sigma = 0.1", "sigma = 0.1\nknown = true", 1));
        assert!(e.contains("errors[0].known") && e.contains("sun_vector"), "{e}");
    }

    #[test]
    fn ranges_and_the_registry_bound_the_distributions() {
        let e = err_of(&TINY.replacen(
            "distribution = \"normal\"\nsigma = 0.1",
            "distribution = \"fixed\"\nvalue = 1e6",
            1,
        ));
        assert!(e.contains("errors[0].distribution") && e.contains("must lie in"), "{e}");
        let s = parse(&TINY.replacen(
            "distribution = \"normal\"\nsigma = 0.1",
            "distribution = \"uniform\"\nmin = -0.2\nmax = 0.2",
            1,
        ))
        .unwrap();
        assert_eq!(s.errors[0].distribution, Distribution::Uniform { min: -0.2, max: 0.2 });
        assert!((s.errors[0].distribution.sigma() - 0.4 / 12f64.sqrt()).abs() < 1e-15);
    }
}
