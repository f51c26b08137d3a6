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

/// The examples cargo builds: `examples/NAME.rs` and `examples/NAME/main.rs`
/// (`examples/common/` is a module the examples share, not one of them).
fn example_names() -> Vec<String> {
    example_names_in("examples")
}

/// The examples under `dir` (relative to the repository), sorted.
fn example_names_in(dir: &str) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(repo().join(dir))
        .expect("the examples folder is readable")
        .map(|entry| entry.expect("an examples entry").path())
        .filter_map(|p| {
            let is_example = if p.is_dir() {
                p.join("main.rs").is_file()
            } else {
                p.extension().is_some_and(|e| e == "rs")
            };
            let stem = p.file_stem()?.to_str()?.to_string();
            is_example.then_some(stem)
        })
        .collect();
    names.sort();
    names
}

/// The names `text` runs as `--example NAME`, in order of appearance.
fn examples_named(text: &str) -> Vec<String> {
    text.split("--example ")
        .skip(1)
        .filter_map(|rest| {
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            (!name.is_empty()).then_some(name)
        })
        .collect()
}

/// The names in the first column of `page`'s table rows that start with a
/// code span (`` | `name` | … ``), in order.
fn table_names(page: &str) -> Vec<String> {
    page.lines()
        .filter_map(|line| {
            let cell = line.trim().strip_prefix("| `")?;
            let end = cell.find("` |")?;
            Some(cell[..end].to_string())
        })
        .collect()
}

#[test]
fn every_built_in_scene_is_listed_where_the_docs_list_them() {
    let builtin: Vec<String> = Scene::builtin_names()
        .iter()
        .map(|s| s.to_string())
        .collect();
    for (page, first) in [
        ("README.md", "hanging"),
        ("docs/scene-format.md", "hanging"),
    ] {
        let text = std::fs::read_to_string(repo().join(page)).expect("readable");
        // The scenes table is the one whose first row names the first scene.
        let names = table_names(&text);
        let start = names
            .iter()
            .position(|n| n == first)
            .unwrap_or_else(|| panic!("{page}: no table row for `{first}`"));
        let listed: Vec<String> = names[start..]
            .iter()
            .take_while(|n| builtin.contains(n))
            .cloned()
            .collect();
        assert_eq!(
            listed, builtin,
            "{page}'s scene table must list every built-in scene, in `wgcloth scenes` order"
        );
    }
    // docs/cli.md names them in prose where it says which names are built in.
    let cli = std::fs::read_to_string(repo().join("docs/cli.md")).expect("readable");
    for name in &builtin {
        assert!(
            cli.contains(&format!("`{name}`")),
            "docs/cli.md does not name the built-in scene `{name}`"
        );
    }
}

#[test]
fn every_example_is_listed_in_the_readme_and_no_page_names_a_missing_one() {
    let examples = example_names();
    assert!(
        examples.len() >= 5,
        "found only {examples:?} under examples/"
    );
    let readme = std::fs::read_to_string(repo().join("README.md")).expect("readable");
    let in_readme = examples_named(&readme);
    for name in &examples {
        assert!(
            in_readme.contains(name),
            "README.md does not show `cargo run --release --example {name}`"
        );
    }
    // A page may also run the Bevy plugin's examples (`-p wgcloth-bevy`).
    let bevy = example_names_in("bevy/examples");
    for (path, text) in pages() {
        for name in examples_named(&text) {
            assert!(
                examples.contains(&name) || bevy.contains(&name),
                "{} runs `--example {name}`, which is not under examples/ or bevy/examples/ \
                 (have {examples:?} and {bevy:?})",
                path.display()
            );
        }
    }
}

/// A line of Rust without its trailing `//` comment and surrounding space
/// (a comment in the README may say more, or less, than the example's).
fn code_of(line: &str) -> &str {
    let code = match line.find("//") {
        Some(at) => &line[..at],
        None => line,
    };
    code.trim()
}

#[test]
fn the_readme_embedding_snippet_is_lines_of_the_embed_example() {
    let readme = std::fs::read_to_string(repo().join("README.md")).expect("readable");
    let example = std::fs::read_to_string(repo().join("examples/embed.rs")).expect("readable");
    let blocks = blocks(&readme, "rust");
    assert_eq!(blocks.len(), 1, "README.md should have one ```rust block");
    let (start, snippet) = &blocks[0];
    // Every line of code in the snippet is a line of the example, in the
    // same order: the README abridges the example (drops lines, shortens
    // comments) but never shows code the example does not run. A line the
    // example wraps differently counts when its tokens match the joined
    // lines, so rustfmt's wrapping does not matter.
    let example_lines: Vec<String> = example
        .lines()
        .map(code_of)
        .filter(|l| !l.is_empty())
        .map(str::to_string)
        .collect();
    let squash = |s: &str| s.split_whitespace().collect::<String>();
    let mut from = 0;
    for (n, line) in snippet.lines().enumerate() {
        let code = code_of(line);
        if code.is_empty() {
            continue;
        }
        let want = squash(code);
        // The example's lines from `from` on, joined until they cover `want`.
        let found = (from..example_lines.len()).find_map(|i| {
            let mut joined = String::new();
            for (j, l) in example_lines[i..].iter().enumerate() {
                joined.push_str(&squash(l));
                if joined == want {
                    return Some(i + j + 1);
                }
                if !want.starts_with(&joined) {
                    return None;
                }
            }
            None
        });
        match found {
            Some(next) => from = next,
            None => panic!(
                "README.md:{}: `{code}` is not a line of examples/embed.rs after the \
                 previous snippet line (the snippet must be the example, abridged)",
                start + n
            ),
        }
    }
}

#[test]
fn every_picture_in_the_docs_is_made_by_docs_images_make_sh() {
    let script = std::fs::read_to_string(repo().join("docs/images/make.sh")).expect("readable");
    let mut pictures = 0;
    for entry in std::fs::read_dir(repo().join("docs/images")).expect("docs/images is readable") {
        let path = entry.expect("docs/images entry").path();
        let name = path.file_name().and_then(|n| n.to_str()).expect("a name");
        if name == "make.sh" {
            continue;
        }
        pictures += 1;
        // Written by name, or as a scene's last frame (`last_frame SCENE`).
        let by_name = script.contains(&format!("$images/{name}"));
        let by_scene = name
            .strip_suffix(".png")
            .is_some_and(|scene| script.contains(&format!("\nlast_frame {scene} ")));
        assert!(
            by_name || by_scene,
            "docs/images/{name} is not made by docs/images/make.sh: a picture nobody \
             can regenerate goes stale"
        );
    }
    assert!(pictures > 0, "no pictures in docs/images");
}
