//! The repository stands alone: `samples/` and `docs/spec/` are byte-identical copies
//! of `../shared/samples` and `../shared/spec` (relative to the repository root), the
//! folder that sits beside the checkout on the project's machines and in CI. Where
//! `../shared` is there, every file of it must have an identical copy here and the
//! copy no file the source lacks; a fresh clone has no `../shared`, and there the test
//! is counted as ignored, saying so (with `CI` set it fails: CI has `../shared`). Both
//! sides are only read. The harness is `tests/needs/mod.rs` (`harness = false`).

#[path = "../../../tests/needs/mod.rs"]
mod needs;

use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};

const REPO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

/// (source under `../shared`, in-repo copy under the repository root).
const PAIRS: [(&str, &str); 2] = [("samples", "samples"), ("spec", "docs/spec")];

/// Every regular file under `root`, as paths relative to it (symbolic links followed).
fn files_under(root: &Path) -> BTreeSet<PathBuf> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeSet<PathBuf>) {
        let entries = fs::read_dir(dir).unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()));
        for entry in entries {
            let path = entry.unwrap_or_else(|e| panic!("reading {}: {e}", dir.display())).path();
            let meta = fs::metadata(&path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
            if meta.is_dir() {
                walk(root, &path, out);
            } else {
                out.insert(path.strip_prefix(root).unwrap().to_path_buf());
            }
        }
    }
    let mut out = BTreeSet::new();
    walk(root, root, &mut out);
    out
}

/// How `copy` differs from `source`, or `None` where they are byte-identical.
fn difference(source: &Path, copy: &Path) -> Option<String> {
    let a = fs::read(source).unwrap_or_else(|e| panic!("reading {}: {e}", source.display()));
    let b = fs::read(copy).unwrap_or_else(|e| panic!("reading {}: {e}", copy.display()));
    if a == b {
        return None;
    }
    let at = a.iter().zip(&b).position(|(x, y)| x != y).unwrap_or(a.len().min(b.len()));
    Some(format!("{} bytes there, {} here, first difference at byte {at}", a.len(), b.len()))
}

fn main() -> std::process::ExitCode {
    let beside = Path::new(REPO).join("../shared");
    let missing = beside.canonicalize().is_err().then(|| {
        format!(
            "{} is absent, as in any clone made outside the project's own machines. It is the project's shared \
             spec and samples, kept beside the checkout on those machines and in CI (`.ci/run`), and this test \
             only checks that samples/ and docs/spec/ here are byte-identical copies of it. Nothing else reads \
             it: every other test and command uses those in-repo copies, so you need nothing more; with \
             ../shared beside the checkout it runs as `cargo test -p bpins-core --test standalone`",
            beside.display()
        )
    });
    needs::run(vec![(
        needs::Need::new("../shared", missing),
        vec![("in_repo_copies_match_shared", in_repo_copies_match_shared)],
    )])
}

fn in_repo_copies_match_shared() {
    let repo = Path::new(REPO);
    let shared = repo.join("../shared").canonicalize().expect("main checked for ../shared");
    let mut problems = Vec::new();
    let mut compared = 0;
    for (from, to) in PAIRS {
        let source = shared.join(from);
        let copy = repo.join(to);
        if !source.is_dir() {
            println!("skipped {to}/: {} is absent", source.display());
            continue;
        }
        assert!(copy.is_dir(), "{to}/ is missing: it must be a copy of {}", source.display());
        let there = files_under(&source);
        let here = files_under(&copy);
        for rel in &there {
            if !here.contains(rel) {
                problems.push(format!("{to}/{}: missing (it is in {})", rel.display(), source.display()));
            } else if let Some(how) = difference(&source.join(rel), &copy.join(rel)) {
                problems.push(format!("{to}/{}: differs from {}: {how}", rel.display(), source.join(rel).display()));
            }
            compared += 1;
        }
        for rel in here.difference(&there) {
            problems.push(format!("{to}/{}: not in {}", rel.display(), source.display()));
        }
    }
    assert!(
        problems.is_empty(),
        "the in-repo copies differ from ../shared (copy it again with `cp -r`):\n  {}",
        problems.join("\n  ")
    );
    if needs::verbose() {
        println!("{compared} files of ../shared/samples and ../shared/spec identical to samples/ and docs/spec/");
    }
}
