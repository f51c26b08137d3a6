//! The user documentation — `README.md` and the pages in `docs/` — against
//! the code and itself: every TOML example loads as a scene, and every
//! relative link reaches an existing file and, for a `#anchor` into a
//! Markdown page, one of its headings. No GPU; runs in milliseconds. (The
//! Rust examples are compiled by `cargo test --doc`: see `DocExamples` in
//! `src/lib.rs`.)

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use wgcloth::Scene;

/// The most lines the README may have: the issue that split it asked for a
/// page a user reads through (what it is, quick start, an example, the
/// CLI in short, which integrator, headline figures, links) in about 300
/// lines; the reference belongs in `docs/`.
const README_MAX_LINES: usize = 300;

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// `README.md` and every `docs/*.md` (not `docs/pending/`, a drop box for
/// drafts), as (path relative to the repository, text), in a fixed order.
fn pages() -> Vec<(PathBuf, String)> {
    let mut paths = vec![PathBuf::from("README.md")];
    let docs = std::fs::read_dir(repo().join("docs")).expect("docs/ is readable");
    let mut found: Vec<PathBuf> = docs
        .map(|entry| entry.expect("docs/ entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .map(|p| Path::new("docs").join(p.file_name().expect("a file name")))
        .collect();
    found.sort();
    paths.extend(found);
    paths
        .into_iter()
        .map(|p| {
            let text = std::fs::read_to_string(repo().join(&p))
                .unwrap_or_else(|e| panic!("reading {}: {e}", p.display()));
            (p, text)
        })
        .collect()
}

/// One line of a page with what it is: inside a fenced code block (and the
/// block's info string, e.g. `toml`), or prose.
enum Line<'a> {
    Code { info: &'a str, text: &'a str },
    Fence,
    Prose(&'a str),
}

fn lines(page: &str) -> Vec<Line<'_>> {
    let mut open: Option<&str> = None;
    page.lines()
        .map(|text| match (text.trim_start().strip_prefix("```"), open) {
            (Some(info), None) => {
                open = Some(info.trim());
                Line::Fence
            }
            (Some(_), Some(_)) => {
                open = None;
                Line::Fence
            }
            (None, Some(info)) => Line::Code { info, text },
            (None, None) => Line::Prose(text),
        })
        .collect()
}

/// The fenced blocks of `page` whose info string is `info`, with the line
/// (1-based) each starts on.
fn blocks(page: &str, info: &str) -> Vec<(usize, String)> {
    let mut out: Vec<(usize, String)> = Vec::new();
    let mut inside = false;
    for (n, line) in lines(page).iter().enumerate() {
        match line {
            Line::Code { info: i, text } if *i == info => {
                if !inside {
                    out.push((n + 1, String::new()));
                    inside = true;
                }
                let block = &mut out.last_mut().expect("a block was pushed").1;
                block.push_str(text);
                block.push('\n');
            }
            Line::Fence if inside => inside = false,
            _ => {}
        }
    }
    out
}

/// GitHub's anchor for a heading: lower case, spaces to hyphens, and every
/// character other than letters, digits, `-` and `_` dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of `page`'s headings (a repeated heading gets `-1`, `-2`, …).
fn anchors(page: &str) -> HashSet<String> {
    let mut seen = HashSet::new();
    for line in lines(page) {
        let Line::Prose(text) = line else { continue };
        let Some(heading) = text.strip_prefix('#') else {
            continue;
        };
        let base = slug(heading.trim_start_matches('#'));
        let mut anchor = base.clone();
        let mut k = 0;
        while !seen.insert(anchor.clone()) {
            k += 1;
            anchor = format!("{base}-{k}");
        }
    }
    seen
}

/// The targets of `page`'s links and images outside code blocks: inline
/// `[text](target)` and reference definitions `[text]: target`.
fn links(page: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (n, line) in lines(page).iter().enumerate() {
        let Line::Prose(text) = line else { continue };
        for (start, _) in text.match_indices("](") {
            let rest = &text[start + 2..];
            let end = rest.find(')').unwrap_or(rest.len());
            out.push((n + 1, rest[..end].trim().to_string()));
        }
        let trimmed = text.trim_start();
        if let Some(close) = trimmed.find("]: ").filter(|_| trimmed.starts_with('[')) {
            out.push((n + 1, trimmed[close + 3..].trim().to_string()));
        }
    }
    out
}

#[test]
fn every_toml_block_in_the_docs_loads() {
    let mut total = 0;
    for (path, text) in pages() {
        for (line, block) in blocks(&text, "toml") {
            if let Err(e) = Scene::from_toml(&block, Path::new("doc.toml")) {
                panic!(
                    "the TOML block at {}:{line} does not load: {e}\n--- block ---\n{block}",
                    path.display()
                );
            }
            total += 1;
        }
    }
    assert!(total > 0, "no ```toml block in README.md or docs/*.md");
}

#[test]
fn every_relative_link_reaches_a_file_and_heading() {
    let pages = pages();
    let mut checked = 0;
    for (path, text) in &pages {
        let dir = path.parent().expect("a page has a folder");
        for (line, target) in links(text) {
            let at = format!("{}:{line}: link `{target}`", path.display());
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (file, anchor) = target.split_once('#').unwrap_or((&target, ""));
            let linked = if file.is_empty() {
                path.clone()
            } else {
                dir.join(file)
            };
            let on_disk = repo().join(&linked);
            assert!(
                on_disk.exists(),
                "{at}: {} does not exist",
                linked.display()
            );
            if !anchor.is_empty() {
                assert!(
                    on_disk.extension().is_some_and(|e| e == "md"),
                    "{at}: an anchor into a file that is not Markdown"
                );
                let target_text = std::fs::read_to_string(&on_disk)
                    .unwrap_or_else(|e| panic!("{at}: reading it: {e}"));
                assert!(
                    anchors(&target_text).contains(anchor),
                    "{at}: {} has no heading with anchor `#{anchor}`",
                    linked.display()
                );
            }
            checked += 1;
        }
    }
    assert!(
        checked > 0,
        "no relative link found: is the link parser broken?"
    );
}

#[test]
fn the_readme_stays_short() {
    let readme = std::fs::read_to_string(repo().join("README.md")).expect("README.md exists");
    let count = readme.lines().count();
    assert!(
        count <= README_MAX_LINES,
        "README.md has {count} lines, over {README_MAX_LINES}: move reference material to docs/"
    );
}

#[test]
fn the_anchor_rule_matches_githubs() {
    assert_eq!(slug(" `wgcloth run`"), "wgcloth-run");
    assert_eq!(
        slug("`[springs.stretch]`, `[springs.shear]`, `[springs.bend]`"),
        "springsstretch-springsshear-springsbend"
    );
    assert_eq!(
        slug("Bit for bit with the CPU mirror"),
        "bit-for-bit-with-the-cpu-mirror"
    );
    assert_eq!(anchors("# A\n## A\n```\n# not a heading\n```\n"), {
        HashSet::from(["a".to_string(), "a-1".to_string()])
    });
}
