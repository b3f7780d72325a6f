//! The README and every page under `docs/` link only to files that exist: a page moved
//! or a run renamed fails here, not in a reader's browser. Links inside code blocks and
//! links to other sites are not followed; anchors (`#...`) are not checked.

use std::path::{Path, PathBuf};

/// The relative link targets of markdown `text`, outside fenced code blocks.
fn relative_links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut in_code = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            in_code = !in_code;
            continue;
        }
        if in_code {
            continue;
        }
        let mut rest = line;
        while let Some(at) = rest.find("](") {
            rest = &rest[at + 2..];
            let end = rest.find(')').unwrap_or(rest.len());
            let url = &rest[..end];
            let is_site = url.split_once(':').is_some_and(|(scheme, _)| {
                !scheme.is_empty() && scheme.chars().all(|c| c.is_ascii_alphabetic())
            });
            if !url.is_empty() && !url.starts_with('#') && !is_site && !url.contains(' ') {
                out.push(url.split('#').next().unwrap().to_string());
            }
            rest = &rest[end..];
        }
    }
    out
}

#[test]
fn links_are_found_outside_code_and_other_sites() {
    let text = "[a](docs/a.md#x) [b](https://x.org) [c](#top)\n```\n[d](nope.md)\n```\n[e](../e/)";
    assert_eq!(relative_links(text), ["docs/a.md", "../e/"]);
}

#[test]
fn every_relative_link_of_the_readme_and_the_docs_resolves() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut pages: Vec<PathBuf> = crate::common::files_under(&root.join("docs"), "md", &[]);
    pages.push(root.join("README.md"));
    let mut broken = Vec::new();
    let mut seen = 0;
    for page in &pages {
        let text = std::fs::read_to_string(page).unwrap();
        for link in relative_links(&text) {
            seen += 1;
            if !page.parent().unwrap().join(&link).exists() {
                broken.push(format!(
                    "{}: {link}",
                    page.strip_prefix(root).unwrap().display()
                ));
            }
        }
    }
    assert!(seen > 100, "only {seen} links found: is the parser blind?");
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}
