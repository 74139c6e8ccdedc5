//! User-defined Monte Carlo sweeps: the heading error of *any* sensor, at any sun
//! elevations, under any error sources, with a budget of which source dominates.
//! `bpins sweep SPEC.toml --out DIR [--trials N] [--shard I/N] [--backend cpu|gpu]`
//! and `bpins merge --out DIR SHARD_DIR...` are thin layers on this module.
//!
//! # The sweep file (`bpins-sweep/1`)
//!
//! ```toml
//! format = "bpins-sweep/1"
//! title = "My sensor at noon"      # optional, shown in the report
//! seed = 2023                      # every draw is keyed by (seed, source, trial)
//! trials = 160                     # per source and sun elevation (--trials overrides)
//! extractors = ["sun_vector", "meridian_line"]   # default these two; also "edge_point"
//!                                  # (the seed paper's own, colocated sensors: `edge_point`)
//! combined = true                  # also a row drawing every source at once (default)
//! sources = ["principal_point"]   # optional: the rows' order (keys the draws);
//!                                  # default: order of first appearance in [[errors]]
//!
//! [sensor]                         # exactly a capture's [sensor] (docs/spec/CAPTURE.md)
//! layout = "colocated"             # or "dofp" (2 × 2 superpixels); a dofp sensor with
//!                                  # colour_tiles is swept band by band (below)
//! width_px = 1224
//! height_px = 1024
//! pixel_pitch_um = 3.45
//! channels = [0, 45, 90]
//!
//! [lens]                           # exactly a capture's [lens]
//! projection = "pinhole"
//! focal_length_mm = 8.0
//!
//! [sky]                            # Rayleigh sky, level camera at heading 0°
//! sun_elevations_deg = [5, 30, 60]                    # a list, or { from, to, step }; in (0°, 90°)
//! sun_azimuths_deg = { from = 10, to = 80, step = 10 } # default [0]; in [−360°, 360°]
//!                                  # (a range of at most 100 000 values)
//! trials_per_azimuth = 20          # trial t: azimuth [(t / this) mod count]; default 1
//! dmax = 0.6                       # default 0.6
//! scene = ["clouds"]               # optional field conditions, as `bpins simulate --scene`
//!                                  # (element or element.param=value; drawn per trial; CPU only)
//!
//! [response]
//! peak_dn = 153.0                  # nominal sensor's peak response (sets the gain); default 1000
//! quantize = false                 # round and clip to bit_depth; default false
//!
//! [[errors]]                       # one per parameter; errors sharing `source` form one row
//! source = "principal_point"
//! param = "principal_point.dx_px"  # see below
//! distribution = "normal"          # normal (mean = 0, sigma) | uniform (min, max) | fixed (value)
//! sigma = 2.0
//! per = "trial"                    # "trial" (default) or "pixel" (per-pixel noise only)
//! known = false                    # false (default) | true | "both": the reconstruction knows the draw
//! ```
//!
//! `param` is any catalog effect parameter `effect.param` (`bpins effects` lists them;
//! the draw must stay in the parameter's range), or the following (any distribution
//! whose draws are finite: |mean| + 10σ, max − min and value finite):
//!
//! | param | what it is |
//! |---|---|
//! | `lens.rho_corner` | lens diattenuation ρ at the field's corner (sets `lens_diattenuation.rho2 = ρ / r²_corner`, the seed paper's reading) |
//! | `imu.tilt_x_deg`, `imu.tilt_y_deg` | the camera's true tilt; the reconstruction believes the IMU's level unless known |
//! | `sun.azimuth_deg`, `sun.elevation_deg` | error of the sun position the reconstruction assumes |
//! | `sensor.dsnu_dn`, `sensor.prnu`, `sensor.read_noise_dn` | per-pixel noise, `per = "pixel"`, N(0, σ) |
//!
//! `known` compensates what the plain reconstruction can: the camera geometry
//! (assumed intrinsics), analyzers and channel responses (Stokes inversion), the lens
//! ρ (seed eq. 13), tilts (level frame) and the sun; elsewhere it is refused.
//! `"both"` reads each trial twice, and its rows carry `known = true` and `false`.
//!
//! A bad file is an [`crate::Error::Sweep`] naming the file, the key and what was
//! expected, before any trial runs.
//!
//! # Outputs
//!
//! `DIR/summary.json` (`rows`: `source`, `extractor`, `sun_elevation_deg`, `known`,
//! `mean_deg`, `std_deg`, `rms_deg`, `p95_deg`, `max_abs_deg`, `trials`, `failed`;
//! `budget`: each source's share of the combined variance and whether they add in
//! quadrature), `summary.csv`, `budget.csv`, `report.html`, every trial's error in
//! `trials.csv`, and `shard.toml` written last (the slice is complete).
//!
//! # A colour-polarization sensor
//!
//! With `[sensor] colour_tiles` each trial is the colour mosaic, read band by band
//! (`colour.rs`): every row, budget and trial line carries `band` (`R`, `G`, `B`, or
//! `fused`: their inverse-variance mean), a `band` column after `known` in the CSV
//! files; a monochrome sensor's outputs have none. The CPU and the GPU engine sweep it
//! (the GPU renders each colour mosaic and reads it back; the host sums it).

mod colour;
mod edge_point;
mod parse;
mod report;
mod run;
mod spec;
mod stats;
mod store;

pub use colour::{
    band_columns, colour_heading_sums, colour_mosaic_heading_sums, fuse as fuse_bands, fused_estimate, BandColumn,
    ColourSumsJob,
};
pub use edge_point::heading as edge_point_heading;
pub use report::html as report_html;
pub use run::{
    columns, draws, nominal_rows, peak, record_columns, run_units, unit, unit_count, unit_index, variants, CpuSums,
    Reading, Shard, SumsEngine, SumsJob, TrialRecord, TrialSetup, Unit, MAX_CONTEXTS, NOMINAL,
};
pub use spec::{Distribution, ErrorSpec, Known, Per, PixelNoise, SweepExtractor, SweepSpec, Target, COMBINED, FORMAT};
pub use stats::{describe, percentile_sorted, summarise, Budget, Row, Share, Summary, SUMMARY_FORMAT};
pub use store::{merge, read_trials, run_to_dir, write_outputs, Outcome, ShardMeta, SHARD_FORMAT};

#[cfg(test)]
mod paper;
