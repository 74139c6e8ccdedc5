//! Outputs whole or absent. Every file bpins writes (captures, fit and diagnosis
//! results, calibration files, reports, maps, tables) goes first to a temporary file
//! beside its final name (`.bpins-XXXXXX.part`, same folder, so the same file
//! system), is flushed to the disk, and is then renamed into place: an interrupted
//! run (SIGKILL, a power cut, a full disk) leaves either the previous file or the
//! new one, never a half. A rename cannot be torn; a temporary left by a killed run
//! is never read as a result (its name says so) and the next run ignores it.
//!
//! Where the name must not exist yet (capture files: bpins never overwrites a
//! capture), the new file is linked into place only if nothing is there, in the same
//! atomic step ([`Replace::Never`]).
//!
//! Errors name the path: a read-only folder, a full disk or a missing parent is an
//! [`Error::Io`] on the file or folder concerned, never a panic.
//!
//! The result has the mode any new file gets (0666 less the umask: `rw-r--r--` under
//! the usual 022), not the temporary file's private 0600, so a result folder shared
//! with a colleague or a web server is readable as its umask says.

pub(crate) mod exr;

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Whether an existing file at the final name may be replaced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Replace {
    /// Replace it (results a rerun renews: fit.json, reports).
    Allowed,
    /// Refuse, naming it (capture files).
    Never,
}

/// Writes `path` whole or not at all: `write` fills a buffered temporary file beside
/// it, which is synced and renamed into place. On any error the temporary is removed
/// and `path` is left as it was.
pub fn write_with(
    path: &Path,
    replace: Replace,
    write: impl FnOnce(&mut BufWriter<&mut File>) -> Result<()>,
) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if replace == Replace::Never && path.exists() {
        return Err(exists(path));
    }
    let io = |p: &Path, e: std::io::Error| Error::Io { path: p.to_path_buf(), source: e };
    let mut builder = tempfile::Builder::new();
    builder.prefix(".bpins-").suffix(".part");
    // Created as `File::create` creates (0666 less the umask), still with a fresh
    // random name opened exclusively; the rename keeps the mode.
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    let mut tmp = builder.tempfile_in(dir).map_err(|e| io(dir, e))?;
    {
        let mut w = BufWriter::new(tmp.as_file_mut());
        write(&mut w)?;
        w.flush().map_err(|e| io(path, e))?;
    }
    tmp.as_file().sync_all().map_err(|e| io(path, e))?;
    match replace {
        Replace::Allowed => tmp.persist(path).map(|_| ()).map_err(|e| io(path, e.error)),
        Replace::Never => tmp.persist_noclobber(path).map(|_| ()).map_err(|e| match e.error.kind() {
            std::io::ErrorKind::AlreadyExists => exists(path),
            _ => io(path, e.error),
        }),
    }?;
    // The rename itself reaches the disk with the folder's entry (best effort: some
    // file systems cannot sync a folder).
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// [`write_with`] for bytes in memory.
pub fn write_bytes(path: &Path, replace: Replace, bytes: &[u8]) -> Result<()> {
    write_with(path, replace, |w| w.write_all(bytes).map_err(|e| Error::Io { path: path.to_path_buf(), source: e }))
}

fn exists(path: &Path) -> Error {
    Error::Io {
        path: path.to_path_buf(),
        source: std::io::Error::new(std::io::ErrorKind::AlreadyExists, "already exists; bpins never overwrites it"),
    }
}

/// `s` as HTML text or attribute value: `& < > " '` escaped, nothing else (a `/` in a
/// file name stays as it is). Every report bpins writes escapes through this.
pub fn escape_html(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// Renders one of bpins' HTML report templates (minijinja; `name` for its errors) with
/// `page`'s values, every one escaped for HTML through [`escape_html`] unless marked
/// safe. Templates may use the `code` filter: text whose backticked spans (`--flag`,
/// a name) become `<code>`. The diagnosis, the lab calibration and the sweep reports
/// all render through this. A page ends with one newline.
pub fn render_html(name: &str, template: &str, page: &impl serde::Serialize) -> Result<String> {
    use minijinja::{AutoEscape, Environment};
    let fail = |e: minijinja::Error| Error::Template { name: name.to_string(), message: format!("{e:#}") };
    let mut env = Environment::new();
    env.set_auto_escape_callback(|_| AutoEscape::Html);
    env.set_formatter(html_formatter);
    env.add_filter("code", code_spans);
    env.add_template(name, template).map_err(fail)?;
    let mut html = env.get_template(name).map_err(fail)?.render(minijinja::value::Serde(page)).map_err(fail)?;
    // The template's last newline (minijinja drops it).
    html.push('\n');
    Ok(html)
}

/// The formatter of [`render_html`]: values through [`escape_html`], safe ones as they are.
fn html_formatter(
    out: &mut minijinja::Output,
    state: &mut minijinja::State,
    value: &minijinja::Value,
) -> std::result::Result<(), minijinja::Error> {
    if value.is_safe() || !matches!(state.auto_escape(), minijinja::AutoEscape::Html) {
        return minijinja::escape_formatter(out, state, value);
    }
    out.write_str(&escape_html(&value.to_string()))
        .map_err(|_| minijinja::Error::new(minijinja::ErrorKind::WriteFailure, "writing the report"))
}

/// The `code` filter: text from the library, whose `--flag`s and names stand in
/// backticks as in the terminal, as HTML with those spans in `<code>` (everything
/// escaped first; an unpaired backtick stays as it is).
fn code_spans(text: String) -> minijinja::Value {
    let escaped = escape_html(&text);
    let parts: Vec<&str> = escaped.split('`').collect();
    let mut html = String::with_capacity(escaped.len() + 16);
    for (i, part) in parts.iter().enumerate() {
        let closed = i % 2 == 1 && i + 1 < parts.len();
        match (i % 2 == 1, closed) {
            (true, true) => html.push_str(&format!("<code>{part}</code>")),
            (true, false) => html.push_str(&format!("`{part}")),
            _ => html.push_str(part),
        }
    }
    minijinja::Value::from_safe_string(html)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn html_escaping_covers_the_five_characters_and_nothing_else() {
        assert_eq!(
            escape_html(r#"it's "<b>odd</b>" & more/x.png"#),
            "it&#39;s &quot;&lt;b&gt;odd&lt;/b&gt;&quot; &amp; more/x.png"
        );
        assert_eq!(escape_html("plain °σ"), "plain °σ");
    }

    #[test]
    fn a_file_is_replaced_whole_or_left_as_it_was() {
        let t = tempfile::tempdir().unwrap();
        let p = t.path().join("fit.json");
        write_bytes(&p, Replace::Allowed, b"first").unwrap();
        write_bytes(&p, Replace::Allowed, b"second").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"second");
        // A writer that fails half-way: the old file stays, no temporary is left.
        let e = write_with(&p, Replace::Allowed, |w| {
            w.write_all(b"half of a").unwrap();
            Err(Error::Encode { what: "test".into(), message: "disk full".into() })
        });
        assert!(e.is_err());
        assert_eq!(std::fs::read(&p).unwrap(), b"second");
        assert_eq!(std::fs::read_dir(t.path()).unwrap().count(), 1);
    }

    /// The result's mode is that of a file made with `File::create` in the same folder
    /// (0666 less the umask), whatever the umask, both for a new name and a replaced one.
    #[cfg(unix)]
    #[test]
    fn outputs_get_the_mode_the_umask_gives_not_0600() {
        use std::os::unix::fs::PermissionsExt;
        let t = tempfile::tempdir().unwrap();
        let probe = t.path().join("probe");
        std::fs::File::create(&probe).unwrap();
        let want = std::fs::metadata(&probe).unwrap().permissions().mode() & 0o777;
        for (name, replace) in [("a.json", Replace::Allowed), ("a.json", Replace::Allowed), ("f.png", Replace::Never)] {
            let p = t.path().join(name);
            write_bytes(&p, replace, b"x").unwrap();
            let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode, want, "{name}: mode {mode:o}, a new file here gets {want:o}");
        }
        // The test runs under whatever umask its caller has; the CLI's test sets 022
        // and 077 and checks 0644 and 0600.
        assert_ne!(want, 0, "the probe file has no permission bits at all");
    }

    #[test]
    fn never_replace_refuses_an_existing_file_naming_it() {
        let t = tempfile::tempdir().unwrap();
        let p = t.path().join("f000.png");
        write_bytes(&p, Replace::Never, b"a").unwrap();
        let e = write_bytes(&p, Replace::Never, b"b").unwrap_err().to_string();
        assert!(e.contains("f000.png"), "{e}");
        assert!(format!("{:?}", std::error::Error::source(&write_bytes(&p, Replace::Never, b"b").unwrap_err()))
            .contains("already exists"));
        assert_eq!(std::fs::read(&p).unwrap(), b"a");
        assert_eq!(std::fs::read_dir(t.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_folder_that_cannot_be_written_is_an_error_naming_it() {
        let t = tempfile::tempdir().unwrap();
        let missing = t.path().join("no/such/folder/x.json");
        let e = write_bytes(&missing, Replace::Allowed, b"x").unwrap_err().to_string();
        assert!(e.contains("no/such/folder"), "{e}");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let ro = t.path().join("ro");
            std::fs::create_dir(&ro).unwrap();
            std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
            // Root may write anyway; then the write succeeds, which is also not a panic.
            match write_bytes(&ro.join("x.json"), Replace::Allowed, b"x") {
                Err(e) => assert!(e.to_string().contains("ro"), "{e}"),
                Ok(()) => assert_eq!(std::fs::read(ro.join("x.json")).unwrap(), b"x"),
            }
            std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o755)).unwrap();
        }
    }
}
