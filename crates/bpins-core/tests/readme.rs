//! The README's catalog tables are generated from the registries: this fails when
//! they are stale (an effect or element added, a summary or range changed) and says
//! how to regenerate them.

use bpins_core::catalog::{markdown, readme_copy, README_BEGIN, README_END};

const README: &str = include_str!("../../../README.md");

#[test]
fn readme_catalog_is_the_registry() {
    let copy = readme_copy(README)
        .unwrap_or_else(|| panic!("README.md lacks the catalog markers:\n{README_BEGIN}\n…\n{README_END}"));
    let generated = markdown();
    assert!(
        copy == generated.trim_matches('\n'),
        "README.md's catalog tables are stale: replace the text between its catalog markers with the \
         output of `bpins effects --markdown`"
    );
}

#[test]
fn readme_is_read_in_one_sitting() {
    let lines = README.lines().count();
    assert!(lines <= 400, "README.md has {lines} lines; keep it ≤ 400 and move detail into docs/");
    assert!(README.contains("## Contents"), "README.md has no table of contents");
}

/// The relative links of one Markdown file that name no file or folder.
fn missing_links(file: &std::path::Path) -> Vec<String> {
    let text = std::fs::read_to_string(file).unwrap();
    let dir = file.parent().unwrap();
    let mut missing = Vec::new();
    for (i, _) in text.match_indices("](") {
        let rest = &text[i + 2..];
        let Some(end) = rest.find(')') else { continue };
        let target = rest[..end].split('#').next().unwrap_or("");
        if target.is_empty() || target.contains("://") || target.contains(' ') || target.contains("::") {
            continue;
        }
        if !dir.join(target).exists() {
            missing.push(format!("{}: {target}", file.display()));
        }
    }
    missing
}

#[test]
fn readme_and_docs_links_resolve() {
    // Every relative link of the README and of docs/*.md names a file or folder of
    // the repository (docs/spec is the shared spec's copy, checked by standalone.rs).
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut missing = missing_links(&root.join("README.md"));
    for entry in std::fs::read_dir(root.join("docs")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "md") {
            missing.extend(missing_links(&path));
        }
    }
    assert!(missing.is_empty(), "links to missing paths: {missing:?}");
}
