//! A virtual file system over the flattened RIB corpus (shared with several test files).
//!
//! The corpus stores `<repo>/<dir>/<dir>/<file>` as `<repo>/<dir>__<dir>__<file>`. This file
//! system serves `/corpus/<repo>/<dir>/<dir>/<file>` from there, so relative `ReadArchive`
//! names resolve as they did in the original repositories. Absolute paths from another machine
//! (`/home/someone/.../presets/x.rib`) are matched by their longest suffix present in the corpus.
//!
//! Each test file includes this module and uses part of it.
#![allow(dead_code)]

use rib_parser::FileSystem;
use std::io;
use std::path::{Path, PathBuf};

pub fn corpus_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/rib-corpus"))
}

#[derive(Debug)]
pub struct CorpusFs {
    root: PathBuf,
}

impl CorpusFs {
    pub fn new() -> CorpusFs {
        CorpusFs { root: corpus_dir() }
    }

    /// The virtual path of a corpus file given by its flattened name `repo/flat__name.rib`.
    pub fn virtual_path(repo: &str, flat: &str) -> PathBuf {
        PathBuf::from("/corpus").join(repo).join(flat.replace("__", "/"))
    }

    fn real(&self, path: &Path) -> Option<PathBuf> {
        let parts: Vec<String> = path
            .components()
            .filter_map(|c| match c {
                std::path::Component::Normal(s) => Some(s.to_string_lossy().into_owned()),
                _ => None,
            })
            .collect();
        if parts.len() >= 3 && parts[0] == "corpus" {
            let p = self.root.join(&parts[1]).join(parts[2..].join("__"));
            return p.is_file().then_some(p);
        }
        // A foreign absolute path: the longest suffix that names a corpus file.
        let repos = std::fs::read_dir(&self.root).ok()?;
        let repos: Vec<PathBuf> =
            repos.filter_map(|e| e.ok()).map(|e| e.path()).filter(|p| p.is_dir()).collect();
        for k in 0..parts.len() {
            let flat = parts[k..].join("__");
            for repo in &repos {
                let p = repo.join(&flat);
                if p.is_file() {
                    return Some(p);
                }
            }
        }
        None
    }
}

impl FileSystem for CorpusFs {
    fn read(&self, path: &Path) -> io::Result<Vec<u8>> {
        match self.real(path) {
            Some(p) => std::fs::read(p),
            None => Err(io::Error::new(io::ErrorKind::NotFound, "not in the corpus")),
        }
    }

    fn is_file(&self, path: &Path) -> bool {
        self.real(path).is_some()
    }
}

/// Every corpus file as (repo, flattened name), sorted.
pub fn corpus_files() -> Vec<(String, String)> {
    let mut out = Vec::new();
    let repos = std::fs::read_dir(corpus_dir())
        .unwrap_or_else(|e| panic!("cannot read the RIB corpus at {}: {e}", corpus_dir().display()));
    for repo in repos.flatten() {
        if !repo.path().is_dir() {
            continue;
        }
        let repo_name = repo.file_name().to_string_lossy().into_owned();
        for f in std::fs::read_dir(repo.path()).into_iter().flatten().flatten() {
            let name = f.file_name().to_string_lossy().into_owned();
            if name.ends_with(".rib") || name.ends_with(".rib.gz") {
                out.push((repo_name.clone(), name));
            }
        }
    }
    // An absent corpus must fail the tests that read it, never let them pass over no files.
    assert!(
        !out.is_empty(),
        "no RIB files under {}: the tests need the shared corpus beside the repository",
        corpus_dir().display()
    );
    out.sort();
    out
}
