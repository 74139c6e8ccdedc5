//! The interface bpins' own front ends are built on, beyond the crate's front door: the
//! command line (`bpins`, crates/bpins-cli) and the Python binding's `fit` and
//! `diagnose` (crates/bpins-py). Named as such so that neither reaches into the whole
//! crate: what is here is what a tool needs to read a user's request, run it with a
//! progress callback, and write the files the CLI documents (`fit.json`,
//! `diagnosis.json`, the sweep's shards and summary, the lab calibration's maps and
//! report, the capture format's EXR layers).
//!
//! A library user starts at the front door (the crate page's table); these are the
//! pieces that door is assembled from, public and documented but shaped by the tools'
//! needs, and free to change with them (every change shows in
//! `docs/api/bpins-core.txt`). The GPU twin's interface is [`crate::twin`].

/// A capture's EXR layers written (the fast writer for large maps), a sensor file
/// read, and the path resolution the CLI's "never write into the input" check uses.
pub mod capture {
    pub use crate::capture::{load_sensor_file, resolve_path, write_exr_layers, write_exr_layers_fast};
}

/// The diagnosis run on frames already loaded (so a tool loads once, reports
/// progress, and writes the fit beside it), and `diagnosis.json`'s schema.
pub mod diagnose {
    pub use crate::diagnose::{diagnose_frames, DiagnosisJson};
}

/// A fit request as the CLI and Python take it (capture folder, effects, calibration,
/// sample budget), loaded once ([`fit::Loaded`]) and fitted ([`fit::fit_from`]); its
/// JSON file; the residual maps written beside it; the budgets and the 1σ a fit is
/// told it must reach.
pub mod fit {
    pub use crate::fit::input::frames::MIN_BUDGET_PX;
    pub use crate::fit::input::resolution::TOLD_SIGMA;
    pub use crate::fit::input::sky::{frame_skies, FrameSky};
    pub use crate::fit::{
        fit_from, residual_maps_of, AddedEffect, FitFrames, FitJson, FitRequest, FrameMaps, Loaded, ResidualMaps,
        COLOUR_BANDS_ADDED, DEFAULT_BUDGET_PX,
    };
}

/// A lab calibration's maps written to EXR, its HTML report, and the lab simulator
/// (`bpins simulate --lab`): a sensor's flaws, the plan of lab frames, the truth maps.
pub mod lab {
    pub use crate::lab::bands;
    pub use crate::lab::output::{maps_of, write_maps, MapFile};
    pub use crate::lab::report::report_html;
    pub use crate::lab::simulate::{colour_truth_maps, lab_frames, truth_maps, LabPlan, LabSensor, PixelFlaws};
}

/// A series of frames simulated over time at a place (`bpins simulate --series`), its
/// truth, and reference tilts written into frames.
pub mod locate {
    pub use crate::locate::{with_reference_tilts, Series, SeriesTruth};
}

/// The seed paper's Table 3 figures and rows, for `bpins run`'s comparison.
pub mod montecarlo {
    pub use crate::montecarlo::{paper_figures_deg, Row, Source};
}

/// Files written whole or not at all (a temporary file renamed), and the HTML reports'
/// template renderer.
pub mod output {
    pub use crate::output::{render_html, write_bytes, Replace};
}

/// The per-frame steps the CLI's `simulate` and `heading` chain together: a simulated
/// sensor's chain frame and response, a whole capture simulated (field scenes too), a frame's reconstruction, per-pixel calibration
/// maps applied to a frame, and a frame's headings.
pub mod pipeline {
    pub use crate::pipeline::{
        apply_pixel_maps, colour_frame_headings_of, frame_headings_of, reconstruct_frame, sim_band_frames,
        sim_chain_frame, sim_response, simulate_capture, ColourPlainHeadings, ReconMode, SimSensor,
    };
    /// AoP and DoLP of reconstructed Stokes maps, per pixel.
    pub use crate::recon::angle_maps;
}

/// The sky in physical units (cd/m² under the sun or the moon, a night sky's
/// mag/arcsec²) and a camera, lens and exposure in physical units
/// (`bpins simulate --exposure-s`): docs/night.md.
pub mod radiometry {
    pub use crate::sensor_exposure::{exposed_response, Exposed, Exposure, PHOTONS_PER_LUX_S_M2};
    pub use crate::sky::radiometry::*;
}

/// The sun's place from a time and place (SPA), as a frame's stamp and a site give it;
/// and the sky's source at a time and place (the sun, or at night a moon that is up, or
/// why neither lights the sky).
#[cfg(feature = "spa")]
pub mod sun {
    pub use crate::sky::sun::{sun_from_time_place, sun_from_unix_time};
    pub use crate::sky::{dark_night, source_from_time_place, source_from_unix_time, NIGHT_SUN_ELEVATION_DEG};
}

/// A sweep run unit by unit (`bpins bench`, `bpins run`), its trial records, the
/// summary of records, shards merged, the paired nominal rows and a sample's summary
/// statistics.
pub mod sweep {
    pub use crate::sweep::{describe, merge, nominal_rows, run_units, summarise, unit_count, TrialRecord, NOMINAL};
}
