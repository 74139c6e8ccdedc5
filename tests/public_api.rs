//! The public API of bpins-core as text (`docs/api/bpins-core.txt`), so that a change to
//! the interface is deliberate (issue 44 item 4): this test builds the crate's
//! documentation with stable `cargo doc`, reads every item's signature from it (the
//! declaration rustdoc renders, the inherent methods' signatures, the traits each type
//! implements), and fails where the text differs from the file, naming the lines that
//! were added and removed. After an intended change:
//!
//! ```sh
//! BPINS_BLESS_API=1 cargo test --test public_api     # rewrites docs/api/bpins-core.txt
//! ```
//!
//! What it reads: every item page under `target/doc/bpins_core/` (not the module index
//! pages, whose doc summaries are prose, and not `internal`, hidden from the
//! documentation and promised to no one); on each page, rustdoc's declaration block,
//! the headers and method signatures of the inherent impls, and the headers of the
//! trait impls (not the auto traits or blanket impls rustdoc adds). Default features.

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

const REPO: &str = env!("CARGO_MANIFEST_DIR");
const API: &str = "docs/api/bpins-core.txt";

#[test]
fn the_public_api_is_the_one_in_docs_api() {
    let target =
        std::env::var_os("CARGO_TARGET_DIR").map(PathBuf::from).unwrap_or_else(|| Path::new(REPO).join("target"));
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .current_dir(REPO)
        .args(["doc", "-p", "bpins-core", "--no-deps", "--locked", "--quiet"])
        .env("CARGO_TARGET_DIR", &target)
        .env_remove("RUSTDOCFLAGS")
        .output()
        .expect("running cargo doc");
    assert!(out.status.success(), "cargo doc -p bpins-core failed:\n{}", String::from_utf8_lossy(&out.stderr));
    let now = api_text(&target.join("doc/bpins_core"));
    let file = Path::new(REPO).join(API);
    if std::env::var_os("BPINS_BLESS_API").is_some() {
        fs::create_dir_all(file.parent().unwrap()).unwrap();
        fs::write(&file, &now).unwrap();
        return;
    }
    let before = fs::read_to_string(&file).unwrap_or_default();
    if before == now {
        return;
    }
    let (old, new): (Vec<&str>, Vec<&str>) = (before.lines().collect(), now.lines().collect());
    let removed: Vec<&&str> = old.iter().filter(|l| !new.contains(l)).take(30).collect();
    let added: Vec<&&str> = new.iter().filter(|l| !old.contains(l)).take(30).collect();
    panic!(
        "the public API of bpins-core differs from {API} (first 30 lines each way):\nremoved:\n  {}\nadded:\n  {}\n\
         if the change is meant, rewrite the file: BPINS_BLESS_API=1 cargo test --test public_api",
        removed.iter().map(|l| l.to_string()).collect::<Vec<_>>().join("\n  "),
        added.iter().map(|l| l.to_string()).collect::<Vec<_>>().join("\n  ")
    );
}

/// The API text of the documentation at `root`: per item page (sorted by path), its
/// path and its signatures, one a line.
fn api_text(root: &Path) -> String {
    let mut pages = BTreeMap::new();
    collect(root, root, &mut pages);
    assert!(pages.len() > 20, "only {} item pages under {}", pages.len(), root.display());
    let mut s =
        String::from("# The public API of bpins-core, from `cargo doc` (tests/public_api.rs writes and checks it).\n");
    for (path, lines) in pages {
        s += &format!("\n[{path}]\n");
        for l in lines {
            s += &l;
            s.push('\n');
        }
    }
    s
}

fn collect(root: &Path, dir: &Path, pages: &mut BTreeMap<String, Vec<String>>) {
    let mut entries: Vec<PathBuf> = fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    entries.sort();
    for p in entries {
        let rel = p.strip_prefix(root).unwrap().to_string_lossy().replace('\\', "/");
        if p.is_dir() {
            if rel != "internal" {
                collect(root, &p, pages);
            }
            continue;
        }
        let name = p.file_name().unwrap().to_string_lossy();
        if !name.ends_with(".html") || name == "index.html" || name == "all.html" {
            continue;
        }
        let html = fs::read_to_string(&p).unwrap();
        // A re-export's old path is a redirect page: no item of its own.
        if html.contains("http-equiv=\"refresh\"") || html.len() < 600 {
            continue;
        }
        pages.insert(rel, signatures(&html));
    }
}

/// The declaration, the inherent impls' headers and methods, and the trait impls' headers.
fn signatures(html: &str) -> Vec<String> {
    let mut out = Vec::new();
    for decl in blocks(html, "<pre class=\"rust item-decl\">", "</pre>") {
        out.extend(text(decl).lines().map(str::trim_end).filter(|l| !l.trim().is_empty()).map(String::from));
    }
    let cut = |id: &str| html.find(&format!("id=\"{id}\"")).unwrap_or(html.len());
    let traits = cut("trait-implementations-list");
    let auto = cut("synthetic-implementations-list").min(cut("blanket-implementations-list"));
    let inherent = &html[..traits.min(auto)];
    for h in blocks(inherent, "<h3 class=\"code-header\">", "</h3>").into_iter().chain(blocks(
        inherent,
        "<h4 class=\"code-header\">",
        "</h4>",
    )) {
        out.push(one_line(&text(h)));
    }
    if traits < auto {
        let mut impls: Vec<String> = blocks(&html[traits..auto], "<h3 class=\"code-header\">", "</h3>")
            .into_iter()
            .map(|h| one_line(&text(h)))
            .collect();
        impls.sort();
        out.extend(impls);
    }
    out
}

/// The text between each `open` and the next `close`.
fn blocks<'a>(html: &'a str, open: &str, close: &str) -> Vec<&'a str> {
    let mut out = Vec::new();
    let mut rest = html;
    while let Some(i) = rest.find(open) {
        let from = &rest[i + open.len()..];
        let Some(j) = from.find(close) else { break };
        out.push(&from[..j]);
        rest = &from[j + close.len()..];
    }
    out
}

/// `html` without its tags, entities decoded.
fn text(html: &str) -> String {
    let mut s = String::with_capacity(html.len());
    let mut in_tag = false;
    for c in html.chars() {
        match c {
            '<' => in_tag = true,
            '>' if in_tag => in_tag = false,
            _ if !in_tag => s.push(c),
            _ => {}
        }
    }
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&#39;", "'")
        .replace("&nbsp;", " ")
        .replace("&amp;", "&")
}

fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The workspace's clients use the named doors (issue 44 item 3): the front door,
/// `twin` (the GPU twin) and `tool` (the CLI, Python's fit and diagnosis). The hidden
/// `internal` module is for bpins-core's own tests, benches and examples and the
/// end-to-end tests in tests/; no other crate's source, bench or example names it.
#[test]
fn no_client_crate_reaches_past_the_named_doors() {
    let mut offenders = Vec::new();
    for krate in fs::read_dir(Path::new(REPO).join("crates")).unwrap() {
        let krate = krate.unwrap().path();
        if krate.file_name().is_some_and(|n| n == "bpins-core") {
            continue;
        }
        let mut stack = vec![krate];
        while let Some(dir) = stack.pop() {
            for e in fs::read_dir(&dir).unwrap() {
                let p = e.unwrap().path();
                if p.is_dir() {
                    if !p.ends_with("target") && !p.ends_with("python") {
                        stack.push(p);
                    }
                } else if p.extension().is_some_and(|x| x == "rs") {
                    let text = fs::read_to_string(&p).unwrap();
                    for (i, line) in text.lines().enumerate() {
                        if line.contains("bpins_core::internal") {
                            offenders.push(format!("{}:{}: {}", p.display(), i + 1, line.trim()));
                        }
                    }
                }
            }
        }
    }
    assert!(
        offenders.is_empty(),
        "client crates name bpins_core::internal (use the front door, bpins_core::twin or bpins_core::tool):\n{}",
        offenders.join("\n")
    );
    // The check reads the crates it means to: the GPU twin names its door.
    let gpu = fs::read_to_string(Path::new(REPO).join("crates/bpins-gpu/src/sums.rs")).unwrap();
    assert!(gpu.contains("bpins_core::twin::"), "crates/bpins-gpu/src/sums.rs no longer names bpins_core::twin");
}
