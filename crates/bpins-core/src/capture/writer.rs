//! Writing a capture frame by frame, so that memory is bounded by one frame and an
//! interrupted write never reads as a capture.
//!
//! ```text
//! writer(out)      checks: valid capture, out not a capture, not inside self.dir,
//!                  no frame file in the way; marks out as being written
//!                  (out/.bpins-partial)
//! write_frame(d)   frame i, checked to read back, written whole (output.rs)
//! finish()         capture.toml last (whole, never over an existing one), then
//!                  the mark removed
//! ```
//!
//! A folder without `capture.toml` is not a capture (the reader says so), so a run
//! killed at any point leaves frames that are each whole and no capture. Rerun into
//! the same folder, the mark says its frame files are an interrupted run's and may be
//! replaced; without the mark an existing file is refused, as bpins never overwrites
//! what it did not leave half-done.

use super::{images, resolve_path as resolve, validate, Capture, FrameData, Layout};
use crate::output::{self, Replace};
use crate::{Error, Result};
use std::fs;
use std::path::{Path, PathBuf};

/// The mark of a capture folder being written (removed once `capture.toml` is in).
pub const PARTIAL_MARK: &str = ".bpins-partial";

/// A capture being written frame by frame (see the module).
pub struct CaptureWriter<'a> {
    capture: &'a Capture,
    out_dir: PathBuf,
    next: usize,
    replace: Replace,
}

impl Capture {
    /// Starts writing this capture into `out_dir`. Refuses (before writing anything)
    /// an invalid capture, an `out_dir` holding `capture.toml`, one inside the capture
    /// folder `self.dir`, and an existing frame file (unless `out_dir` holds the mark
    /// of an interrupted write).
    pub fn writer(&self, out_dir: &Path) -> Result<CaptureWriter<'_>> {
        let toml_path = out_dir.join("capture.toml");
        validate::validate(self, &toml_path)?;
        if toml_path.exists() {
            bail!(&toml_path, "already exists: bpins never writes into a capture; choose a new folder");
        }
        if self.toml_path().is_file() {
            let src = fs::canonicalize(&self.dir).map_err(|e| Error::Io { path: self.dir.clone(), source: e })?;
            let targets =
                std::iter::once(out_dir.to_path_buf()).chain(self.frames.iter().map(|f| out_dir.join(&f.file)));
            for t in targets {
                if resolve(&t)?.starts_with(&src) {
                    bail!(&t, "is inside the capture {}; bpins never writes into a capture", self.dir.display());
                }
            }
        }
        let mark = out_dir.join(PARTIAL_MARK);
        let resumed = mark.is_file();
        if !resumed {
            for f in &self.frames {
                let p = out_dir.join(&f.file);
                if p.exists() {
                    bail!(&p, "already exists; bpins never overwrites capture files");
                }
            }
        }
        fs::create_dir_all(out_dir).map_err(|e| Error::Io { path: out_dir.to_path_buf(), source: e })?;
        output::write_bytes(&mark, Replace::Allowed, b"a bpins capture being written: not a capture yet\n")?;
        let replace = if resumed { Replace::Allowed } else { Replace::Never };
        Ok(CaptureWriter { capture: self, out_dir: out_dir.to_path_buf(), next: 0, replace })
    }
}

impl CaptureWriter<'_> {
    /// Frames written so far.
    pub fn written(&self) -> usize {
        self.next
    }

    /// Writes the next frame (checked first to read back: size, layout, channels,
    /// finite DN within full scale).
    pub fn write_frame(&mut self, data: &FrameData) -> Result<()> {
        let c = self.capture;
        let i = self.next;
        let toml_path = self.out_dir.join("capture.toml");
        let Some(spec) = c.frames.get(i) else {
            bail!(&toml_path, "frame {i} written, but the capture has {} [[frames]]", c.frames.len());
        };
        let p = self.out_dir.join(&spec.file);
        images::check_frame_data(c, i, data, &p)?;
        if let Some(parent) = p.parent() {
            fs::create_dir_all(parent).map_err(|e| Error::Io { path: parent.to_path_buf(), source: e })?;
        }
        match (data, &c.sensor.layout) {
            (FrameData::Mosaic { width_px, height_px, dn }, Layout::Dofp { .. }) => {
                images::write_dofp(&p, *width_px, *height_px, dn, self.replace)?
            }
            (FrameData::Colocated { width_px, height_px, channels }, Layout::Colocated { .. }) => {
                images::write_colocated(&p, *width_px, *height_px, channels, self.replace)?
            }
            _ => bail!(&p, "frame {i}: data of the other layout"),
        }
        self.next += 1;
        Ok(())
    }

    /// Writes `capture.toml` once every frame is written, and removes the mark.
    pub fn finish(self) -> Result<()> {
        let toml_path = self.out_dir.join("capture.toml");
        if self.next != self.capture.frames.len() {
            bail!(
                &toml_path,
                "{} of {} frames written; the capture is not complete",
                self.next,
                self.capture.frames.len()
            );
        }
        output::write_bytes(&toml_path, Replace::Never, self.capture.to_toml_string().as_bytes())?;
        let mark = self.out_dir.join(PARTIAL_MARK);
        fs::remove_file(&mark).map_err(|e| Error::Io { path: mark, source: e })
    }
}
