//! `diagnosis.json`, as `bpins diagnose` writes it.

use super::Diagnosis;

/// `diagnosis.json`: the capture, the diagnosis's own fields ([`Diagnosis`]: each step
/// carries the same fields as `fit.json`) and, for readers that want only the verdict,
/// whether a residual remains unexplained and what remains in words.
#[derive(serde::Serialize)]
pub struct DiagnosisJson<'a> {
    pub capture: String,
    #[serde(flatten)]
    pub diagnosis: &'a Diagnosis,
    pub unexplained: bool,
    pub unexplained_summary: String,
}

impl<'a> DiagnosisJson<'a> {
    pub fn new(capture: &std::path::Path, diagnosis: &'a Diagnosis) -> Self {
        DiagnosisJson {
            capture: capture.display().to_string(),
            diagnosis,
            unexplained: diagnosis.unexplained(),
            unexplained_summary: diagnosis.summary(),
        }
    }
}
