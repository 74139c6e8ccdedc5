//! `bpins`: the command-line interface. One file per subcommand; errors are
//! `anyhow` with context here, typed in the library; `main` returns an exit code.
//!
//! Output goes through [`out!`] (stdout) and [`say!`] (stderr), never `println!`:
//! a reader that closes the pipe early (`bpins effects | head`) ends the command
//! quietly with status 0, as Unix tools do, instead of a panic.

/// `println!` to stdout, returning early from the enclosing `anyhow::Result` function
/// when the write fails: a closed pipe as [`StdoutClosed`] (a quiet exit in `main`),
/// any other failure as an error naming standard output.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*).map_err($crate::stdout_error)?
    }};
}

/// `eprintln!` that never panics: a message to stderr, dropped if stderr is closed.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr().lock(), $($arg)*);
    }};
}

mod backend;
mod bag;
mod capture_bag;
mod cmd_agree;
mod cmd_bench;
mod cmd_calibrate;
mod cmd_diagnose;
mod cmd_effects;
mod cmd_fit;
mod cmd_heading;
mod cmd_heading_bag;
mod cmd_locate;
mod cmd_maps;
mod cmd_node;
mod cmd_run;
mod cmd_simulate;
mod cmd_sweep;
mod effect_sizes;
mod frames;
mod names;
mod node_graph;
mod profiles;
mod progress;
mod report;
mod residuals;

use clap::{CommandFactory, Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "bpins",
    version,
    about = "Bionic polarization imaging navigation sensor: model, Monte Carlo, heading from captures"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Precision of the GPU kernels (with --backend gpu, and for `bpins agree`): f64
    /// agrees with the CPU pixel for pixel and needs an adapter with f64 shaders; f32
    /// runs on every adapter, within the statistical tolerances of TOLERANCES.md.
    /// Default: f64 where the adapter has it, else f32.
    #[arg(long, global = true, value_name = "f32|f64", value_parser = parse_precision)]
    gpu_precision: Option<bpins_gpu::Precision>,
}

fn parse_precision(s: &str) -> Result<bpins_gpu::Precision, String> {
    s.parse()
}

#[derive(Subcommand)]
enum Command {
    /// The seed paper's Monte Carlo (Table 3): every error source, every extractor.
    Run(cmd_run::Args),
    /// Simulate a capture (bpins-capture/1) or one EXR frame, with any effect.
    Simulate(Box<cmd_simulate::Args>),
    /// Heading of every frame of a capture, against its reference heading; or of a
    /// ROS 2 bag's images (--bag), optionally into a new bag (--bag-out).
    Heading(cmd_heading::Args),
    /// AoP, DoLP, intensity and AoE maps of every frame of a DoFP capture (EXR).
    Maps(cmd_maps::Args),
    /// North, latitude and longitude from frames over time, without GNSS (writes a site file).
    Locate(cmd_locate::Args),
    /// A ROS 2 bag's DoFP frames, with their sun and tilt, as a new capture
    /// (bpins-capture/1), for fit, diagnose and calibrate.
    BagToCapture(capture_bag::Args),
    /// The compass as a live ROS 2 node over Zenoh (rmw_zenoh): images, CameraInfo,
    /// Imu and NavSatFix in; a heading Imu (REP 103/145) or a diagnostic per frame out.
    Node(Box<cmd_node::Args>),
    /// List the effects bpins models, with their parameters.
    Effects(cmd_effects::Args),
    /// Run seeded trials over every effect on the CPU and the GPU and compare them.
    Agree(cmd_agree::Args),
    /// Time a 2448 × 2048 frame, batched frames and the paper sweep on the GPU or CPU.
    Bench(cmd_bench::Args),
    /// Fit the enabled effects and each frame's nuisances to a capture's raw DN.
    Fit(cmd_fit::Args),
    /// Find the catalog effect a capture's model lacks, add it, watch the error fall.
    Diagnose(cmd_diagnose::Args),
    /// Calibrate a DoFP sensor from a lab capture: per-pixel analyzers, gains,
    /// offsets, photon transfer; writes maps, a report and calibration.toml.
    Calibrate(cmd_calibrate::Args),
    /// A Monte Carlo sweep from a bpins-sweep/1 file: heading error per source, sun
    /// elevation and extractor, and the error budget; one slice with --shard I/N.
    Sweep(cmd_sweep::Args),
    /// Merge the slices of a sharded sweep (bit for bit the unsharded result).
    Merge(cmd_sweep::MergeArgs),
}

pub use backend::Backend;

fn main() -> ExitCode {
    let cli = Cli::parse();
    backend::set_gpu_precision(cli.gpu_precision);
    let result = match cli.command {
        Command::Run(a) => cmd_run::run(a),
        Command::Simulate(a) => {
            if let Some((x, y)) = a.refused() {
                refuse("simulate", &x, &y);
            }
            if let Some((x, y)) = a.lacking() {
                refuse_lacking("simulate", &x, &y);
            }
            cmd_simulate::run(*a)
        }
        Command::Heading(a) => {
            if let Some((x, y)) = a.refused() {
                refuse("heading", &x, &y);
            }
            cmd_heading::run(a)
        }
        Command::Maps(a) => cmd_maps::run(a),
        Command::Locate(a) => cmd_locate::run(a),
        Command::BagToCapture(a) => capture_bag::bag_to_capture(a),
        Command::Node(a) => cmd_node::run(*a),
        Command::Effects(a) => cmd_effects::run(a),
        Command::Agree(a) => cmd_agree::run(a),
        Command::Bench(a) => cmd_bench::run(a),
        Command::Fit(a) => cmd_fit::run(a),
        Command::Diagnose(a) => cmd_diagnose::run(a),
        Command::Calibrate(a) => cmd_calibrate::run(a),
        Command::Sweep(a) => cmd_sweep::run(a),
        Command::Merge(a) => cmd_sweep::run_merge(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // The reader has gone (`| head`): nothing more to say, and nothing failed.
        Err(e) if e.chain().any(|c| c.is::<StdoutClosed>()) => ExitCode::SUCCESS,
        Err(e) => {
            say!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

/// Refuses a combination of `subcommand`'s flags that clap's own rules cannot state
/// (it turns on a flag's value, e.g. `--estimator plain`) as clap refuses a conflict:
/// its message naming both, the usage, exit status 2.
fn refuse(subcommand: &str, a: &str, b: &str) -> ! {
    let mut cli = Cli::command();
    cli.build();
    let sub = cli.find_subcommand_mut(subcommand).expect("a subcommand of bpins");
    sub.error(clap::error::ErrorKind::ArgumentConflict, format!("the argument '{a}' cannot be used with '{b}'")).exit()
}

/// Refuses flag `a` given without what it acts with (`needs`), as clap refuses a
/// missing required argument: its message, the usage, exit status 2.
fn refuse_lacking(subcommand: &str, a: &str, needs: &str) -> ! {
    let mut cli = Cli::command();
    cli.build();
    let sub = cli.find_subcommand_mut(subcommand).expect("a subcommand of bpins");
    sub.error(
        clap::error::ErrorKind::MissingRequiredArgument,
        format!("the argument '{a}' acts only with {needs}, and none was given"),
    )
    .exit()
}

/// Standard output was closed by its reader (a broken pipe): the command stops there.
#[derive(Debug)]
pub struct StdoutClosed;

impl std::fmt::Display for StdoutClosed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("standard output was closed")
    }
}

impl std::error::Error for StdoutClosed {}

/// A failed write to stdout as [`out!`] returns it.
pub fn stdout_error(e: std::io::Error) -> anyhow::Error {
    if e.kind() == std::io::ErrorKind::BrokenPipe {
        anyhow::Error::new(StdoutClosed)
    } else {
        anyhow::Error::new(e).context("writing to standard output")
    }
}

/// Writes `value` as pretty JSON to `path`, with context on failure.
pub fn write_json(path: &std::path::Path, value: &impl serde::Serialize) -> anyhow::Result<()> {
    use anyhow::Context;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let text = serde_json::to_string_pretty(value).context("serialising JSON")?;
    write_output(path, (text + "\n").as_bytes())
}

/// Writes an output file whole or not at all (a temporary beside it, renamed into
/// place: `bpins_core::output`), replacing an earlier run's.
pub fn write_output(path: &std::path::Path, bytes: &[u8]) -> anyhow::Result<()> {
    use anyhow::Context;
    bpins_core::tool::output::write_bytes(path, bpins_core::tool::output::Replace::Allowed, bytes)
        .with_context(|| format!("writing {}", path.display()))
}

/// Refuses an output path that lies in a capture (a folder holding capture.toml):
/// bpins never writes into a capture. [`ensure_not_in_input`] with no bag.
pub fn ensure_not_in_capture(out: &std::path::Path) -> anyhow::Result<()> {
    ensure_not_in_input(out, &[])
}

/// The one check that bpins never writes into its input: refuses an output path
/// `out` that is or lies in a capture (any folder holding capture.toml) or in one of
/// `bags` (a bag's folder). Both sides are compared resolved ([`resolve`]: `..` taken
/// and symbolic links followed, through the existing part of a path not yet made), so
/// that an output reached through `..` or a link into an input is caught.
pub fn ensure_not_in_input(out: &std::path::Path, bags: &[&std::path::Path]) -> anyhow::Result<()> {
    let o = resolve(out)?;
    if let Some(c) = o.ancestors().find(|a| a.join("capture.toml").is_file()) {
        anyhow::bail!("{}: is inside the capture {}; bpins never writes into a capture", out.display(), c.display());
    }
    for bag in bags {
        let b = resolve(bag)?;
        if o.starts_with(&b) {
            anyhow::bail!("{}: is inside the bag {}; bpins never writes into a bag", out.display(), b.display());
        }
    }
    Ok(())
}

/// Refuses two outputs of one run of which one is or lies in the other (a bag written
/// into the capture written beside it), compared resolved as [`ensure_not_in_input`].
pub fn ensure_apart(a: &std::path::Path, b: &std::path::Path) -> anyhow::Result<()> {
    let (ra, rb) = (resolve(a)?, resolve(b)?);
    if ra.starts_with(&rb) || rb.starts_with(&ra) {
        anyhow::bail!(
            "{} and {} are one inside the other; each output needs a folder of its own",
            a.display(),
            b.display()
        );
    }
    Ok(())
}

/// `p` resolved as every input check resolves it (`capture::resolve_path`).
fn resolve(p: &std::path::Path) -> anyhow::Result<std::path::PathBuf> {
    Ok(bpins_core::tool::capture::resolve_path(p)?)
}

/// What `fit` and `diagnose` read: a capture, the model's effects, where to write.
#[derive(clap::Args)]
pub struct FitInput {
    /// The capture folder (bpins-capture/1).
    pub capture: std::path::PathBuf,
    /// Effects of the model, whose parameters are fitted, comma-separated (`bpins
    /// effects` lists them; default: none).
    #[arg(long, value_delimiter = ',')]
    pub effects: Vec<String>,
    /// Hold each frame's heading at its reference instead of fitting it.
    #[arg(long)]
    pub trust_reference: bool,
    /// The sky's peak degree of linear polarization, when known: hold every frame's
    /// d_max at this value (in [0, 1]) instead of fitting it per frame.
    #[arg(long, value_name = "DMAX")]
    pub fixed_dmax: Option<f64>,
    /// Hold every frame's sky radiance at Rayleigh's ½(1 + cos²γ) times its scale,
    /// instead of fitting a smooth shape × (1 + a1 cos γ + a2 cos²γ) per frame.
    #[arg(long)]
    pub rayleigh_radiance: bool,
    /// A calibration (bpins-calibration/1, as `bpins fit` or `bpins calibrate` writes
    /// it): its effects are known and held at their values (an effect also named in
    /// --effects is fitted); its per-pixel maps, if any, are applied to every frame.
    #[arg(long, value_name = "FILE")]
    pub calibration: Option<std::path::PathBuf>,
    /// Fit every pixel, including those each frame's sky mask leaves out as not sky
    /// (clouds, trees, buildings, the ground, the sun's aureole: the field estimator's
    /// depolarized clusters and the rays below the horizon).
    #[arg(long)]
    pub all_pixels: bool,
    /// Most pixels of each frame the fit reads (default 524288): a larger frame is read
    /// through a stratified, seeded sample of 8 × 8-pixel blocks (whole 2 × 2 tiles),
    /// which bounds the time and the memory per frame; each 1σ then grows about as
    /// √(frame pixels / sampled pixels), which the result states (`sample`).
    #[arg(long, value_name = "PIXELS", conflicts_with = "full")]
    pub sample_budget: Option<usize>,
    /// Read every pixel of every frame, however large (no sample budget).
    #[arg(long)]
    pub full: bool,
    /// Output folder (never inside the capture).
    #[arg(long)]
    pub out: std::path::PathBuf,
}

/// Why a fit read more pixels than its first sample, in words (`FitResult::raised`):
/// `what` was done on them.
pub fn raised_line(x: &bpins_core::Raised, what: &str) -> String {
    format!(
        "{} not told from neutral at {} px per frame (< {}σ), but every pixel would tell them: {what} on {}",
        x.params.join(", "),
        x.from_budget_px,
        bpins_core::tool::fit::TOLD_SIGMA,
        x.to_budget_px.map_or("every pixel".to_string(), |b| format!("a budget of {b} px per frame"))
    )
}

/// What of each frame a fit read, in words (`FitResult::sample`).
pub fn sample_line(s: &bpins_core::Sample) -> String {
    let budget = s.budget_px.map_or("none (--full)".to_string(), |b| format!("{b} px per frame"));
    if s.pixels_per_frame >= s.frame_px {
        format!("every pixel of each frame ({} px; sample budget {budget})", s.frame_px)
    } else {
        format!(
            "a sample of {} of each frame's {} px (budget {budget}): one {b} × {b} block per {t} × {t} stratum; \
             every pixel would give each 1σ × {:.2} (--sample-budget N raises it, --full reads every pixel)",
            s.pixels_per_frame,
            s.frame_px,
            s.full_sigma_factor,
            b = s.block_px,
            t = s.stratum_px
        )
    }
}

impl FitInput {
    /// The request as the library takes it (the effects checked against the registry
    /// there), then the capture with its frames as the fit reads them (whole, or
    /// sampled within the budget; a progress bar while reading). `out` must lie
    /// outside the capture.
    pub fn load(&self) -> anyhow::Result<bpins_core::tool::fit::Loaded> {
        self.load_request(false).map(|(_, loaded)| loaded)
    }

    /// [`FitInput::load`], with the request it read (to read the capture again).
    /// `model_colour_bands`: a colour capture whose effects name no band effect is
    /// fitted with `sky_spectrum` too (`bpins fit`; `FitRequest::model_colour_bands`),
    /// never for `bpins diagnose`, whose search starts from the model it is given.
    pub fn load_request(
        &self,
        model_colour_bands: bool,
    ) -> anyhow::Result<(bpins_core::tool::fit::FitRequest, bpins_core::tool::fit::Loaded)> {
        use anyhow::Context;
        if let Some(d) = self.fixed_dmax.filter(|d| !(0.0..=1.0).contains(d)) {
            anyhow::bail!("--fixed-dmax {d} must lie in [0, 1]");
        }
        let min = bpins_core::tool::fit::MIN_BUDGET_PX;
        if let Some(b) = self.sample_budget.filter(|&b| b < min) {
            anyhow::bail!("--sample-budget {b} is below the smallest budget, {min} pixels (16 blocks of 8 × 8)");
        }
        let budget =
            if self.full { None } else { Some(self.sample_budget.unwrap_or(bpins_core::tool::fit::DEFAULT_BUDGET_PX)) };
        ensure_not_in_capture(&self.out)?;
        let request = bpins_core::tool::fit::FitRequest {
            capture: self.capture.clone(),
            effects: self.effects.clone(),
            trust_reference: self.trust_reference,
            fixed_dmax: self.fixed_dmax,
            rayleigh_radiance: self.rayleigh_radiance,
            calibration: self.calibration.clone(),
            all_pixels: self.all_pixels,
            sample_budget_px: budget,
            model_colour_bands,
        };
        let pb = progress::bar(0, "frames read");
        let loaded = request
            .load(&|done, n| {
                pb.set_length(n as u64);
                pb.set_position(done as u64);
            })
            .with_context(|| match &self.calibration {
                Some(p) => format!("reading {} with --calibration {}", self.capture.display(), p.display()),
                None => format!("reading {}", self.capture.display()),
            })?;
        pb.finish_and_clear();
        Ok((request, loaded))
    }
}
