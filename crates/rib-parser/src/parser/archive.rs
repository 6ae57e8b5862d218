//! Archives: `ReadArchive`, `Procedural "DelayedReadArchive"`, `ArchiveBegin`/`ArchiveEnd`, and
//! the search paths of `Option "searchpath"`.
//!
//! Resolution of `ReadArchive "name"`:
//! 1. an inline archive defined earlier with `ArchiveBegin "name"`;
//! 2. an absolute path as given;
//! 3. a relative path against the directory of the file that contains the request;
//! 4. each entry of `Option "searchpath" "archive"`, then of `"resource"`. In an entry, `&` stands
//!    for the previous value of the same search path and `@` for the default (the directory of
//!    the top-level file); relative entries are taken relative to the top-level file's directory
//!    (where a renderer is normally started). Entries are separated by `:` (or `;`).
//!
//! An archive that is being read cannot be read again from inside itself (a cycle is an
//! error), and archives nest at most [`crate::limits::Limits::max_archive_depth`] deep.

use super::{PResult, Reader, Stop};
use crate::diagnostics::DiagnosticKind;
use crate::lexer::{BinaryTables, Lexer, TokenKind};
use crate::scene::FileLoc;
use crate::source::SourceFile;
use std::path::{Component, Path, PathBuf};
use std::sync::Arc;

/// An `ArchiveBegin "name"` ... `ArchiveEnd` block: a byte range of a source, replayed by
/// `ReadArchive "name"`.
#[derive(Clone, Debug)]
pub struct InlineArchive {
    source: Arc<SourceFile>,
    start: usize,
    end: usize,
    tables: BinaryTables,
}

/// Lexically normalised path (`a/./b/../c` -> `a/c`), used to recognise the same file reached
/// by two spellings.
pub(crate) fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                if !out.pop() {
                    out.push("..");
                }
            }
            other => out.push(other.as_os_str()),
        }
    }
    out
}

impl Reader {
    /// `Option "searchpath" "kind" ["a:&:@"]`: expands `&` and `@` and stores the entries.
    pub(crate) fn set_search_path(&mut self, kind: &str, value: &str) {
        let previous = self.search_paths.get(kind).cloned().unwrap_or_default();
        let mut entries = Vec::new();
        for part in split_search_path(value) {
            match part {
                "&" => entries.extend(previous.iter().cloned()),
                "@" => entries.push(self.root_dir.to_string_lossy().into_owned()),
                "" => {}
                other => entries.push(other.to_string()),
            }
        }
        self.search_paths.insert(kind.to_string(), entries);
    }

    /// Candidate paths for an archive name, in the order they are tried.
    fn archive_candidates(&mut self, name: &str) -> Vec<PathBuf> {
        let given = Path::new(name);
        if given.is_absolute() {
            return vec![given.to_path_buf()];
        }
        let mut out = Vec::new();
        let including_dir = self
            .inputs
            .iter()
            .rev()
            .find_map(|i| i.source.path.as_ref())
            .and_then(|p| p.parent().map(Path::to_path_buf))
            .unwrap_or_else(|| self.root_dir.clone());
        out.push(including_dir.join(given));
        // Renderers resolve relative names against their working directory, normally the
        // top-level file's: exporters (Blender's ribber) write names relative to it.
        out.push(self.root_dir.join(given));
        for kind in ["archive", "resource"] {
            for entry in self.search_paths.get(kind).into_iter().flatten() {
                let dir = Path::new(entry);
                let dir = if dir.is_absolute() { dir.to_path_buf() } else { self.root_dir.join(dir) };
                out.push(dir.join(given));
            }
        }
        let mut seen = std::collections::HashSet::new();
        out.retain(|p| seen.insert(normalize(p)));
        out
    }

    /// Reads an archive file (or inline archive) named `name` at `loc`: pushes it as the
    /// current input, so the main loop continues inside it.
    pub(crate) fn read_archive(&mut self, name: &str, loc: &FileLoc) -> PResult<()> {
        let depth = self.inputs.len();
        if depth > self.options.limits.max_archive_depth {
            let limit = self.options.limits.max_archive_depth;
            self.diagnostics.error(
                DiagnosticKind::Limit,
                loc,
                format!("archive '{name}' is nested deeper than the limit of {limit} archives"),
            );
            return Err(Stop);
        }
        if let Some(inline) = self.inline_archives.get(name).cloned() {
            if self.inputs.iter().any(|i| i.inline_name.as_deref() == Some(name)) {
                self.diagnostics.error(
                    DiagnosticKind::Archive,
                    loc,
                    format!("archive '{name}' includes itself"),
                );
                return Err(Stop);
            }
            let lexer =
                Lexer::with_range(inline.source.bytes.clone(), inline.start, inline.end, inline.tables);
            let source = inline.source;
            self.inputs.push(super::Input {
                lexer,
                cursor: super::LocCursor { offset: 0, line: 1, line_start: 0 },
                source,
                key: None,
                inline_name: Some(name.to_string()),
                conditional_depth: self.conditionals.len(),
            });
            return Ok(());
        }
        let candidates = self.archive_candidates(name);
        let fs = self.options.file_system.clone();
        let Some(path) = candidates.iter().find(|p| fs.is_file(p)).cloned() else {
            let tried: Vec<String> = candidates.iter().map(|p| p.display().to_string()).collect();
            self.diagnostics.error(
                DiagnosticKind::Archive,
                loc,
                format!("cannot find archive '{name}' (looked for {})", tried.join(", ")),
            );
            return Err(Stop);
        };
        let key = normalize(&path);
        if self.inputs.iter().any(|i| i.key.as_ref() == Some(&key)) {
            let chain: Vec<String> = self.inputs.iter().map(|i| i.source.name.to_string()).collect();
            self.diagnostics.error(
                DiagnosticKind::Archive,
                loc,
                format!(
                    "archive '{name}' includes itself (cycle: {} -> {})",
                    chain.join(" -> "),
                    path.display()
                ),
            );
            return Err(Stop);
        }
        let raw = match fs.read(&path) {
            Ok(raw) => raw,
            Err(e) => {
                self.diagnostics.error(
                    DiagnosticKind::Archive,
                    loc,
                    format!("cannot read archive '{}': {e}", path.display()),
                );
                return Err(Stop);
            }
        };
        let display_name: Arc<str> = Arc::from(path.to_string_lossy().as_ref());
        let Some(source) = self.load(display_name, Some(path), raw, Some(loc)) else { return Err(Stop) };
        self.push_input(source, Some(key), None);
        Ok(())
    }

    /// `ArchiveBegin "name" params`: records the block up to the matching `ArchiveEnd` without
    /// reading it.
    pub(crate) fn define_inline_archive(&mut self, name: String, loc: &FileLoc) -> PResult<()> {
        let start = self.peek_start();
        let tables = self.input().lexer.tables().clone();
        let source = self.input().source.clone();
        let mut depth = 0usize;
        loop {
            let tok = match self.input().lexer.next() {
                Ok(t) => t,
                Err(e) => {
                    self.report_lex_error(e);
                    continue;
                }
            };
            match &tok.kind {
                TokenKind::Eof => {
                    self.diagnostics.error(
                        DiagnosticKind::Nesting,
                        loc,
                        format!("ArchiveBegin \"{name}\" has no ArchiveEnd"),
                    );
                    return Err(Stop);
                }
                TokenKind::Request(t) => {
                    let bytes = self.bytes();
                    match t.bytes(&bytes) {
                        b"ArchiveBegin" => depth += 1,
                        b"ArchiveEnd" if depth == 0 => {
                            self.inline_archives
                                .insert(name, InlineArchive { source, start, end: tok.start, tables });
                            return Ok(());
                        }
                        b"ArchiveEnd" => depth -= 1,
                        _ => {}
                    }
                }
                _ => {}
            }
        }
    }
}

/// Splits a search path on `:` and `;`, keeping Windows drive letters (`C:/x`) whole.
fn split_search_path(value: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut start = 0;
    let bytes = value.as_bytes();
    for (i, &b) in bytes.iter().enumerate() {
        if b == b':' || b == b';' {
            let part = &value[start..i];
            let is_drive = b == b':'
                && part.len() == 1
                && part.as_bytes()[0].is_ascii_alphabetic()
                && matches!(bytes.get(i + 1), Some(b'/' | b'\\'));
            if is_drive {
                continue;
            }
            out.push(part);
            start = i + 1;
        }
    }
    out.push(&value[start..]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn search_paths_split_on_colons_but_keep_drive_letters() {
        assert_eq!(split_search_path("@:.:Archives:&"), vec!["@", ".", "Archives", "&"]);
        assert_eq!(split_search_path("C:/rib;D:\\x:y"), vec!["C:/rib", "D:\\x", "y"]);
    }

    #[test]
    fn normalisation() {
        assert_eq!(normalize(Path::new("a/./b/../c.rib")), PathBuf::from("a/c.rib"));
        assert_eq!(normalize(Path::new("../x")), PathBuf::from("../x"));
    }
}
