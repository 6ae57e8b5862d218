//! Source files: their bytes (gzip already undone), line lookup for locations, and the file
//! system the parser reads archives through.

use crate::scene::FileLoc;
use std::io::{self, Read};
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

/// One loaded input: the top-level file, an archive or standard input.
#[derive(Debug)]
pub struct SourceFile {
    /// The name used in messages: the path as the user or the including file gave it.
    pub name: Arc<str>,
    /// The file's path on the (possibly virtual) file system, used to resolve relative archive
    /// names; `None` for standard input and in-memory sources.
    pub path: Option<PathBuf>,
    /// The RIB bytes, decompressed when the file was gzip (shared with the lexers reading them,
    /// without a copy).
    pub bytes: Arc<Vec<u8>>,
    /// True when the file was gzip-compressed (detected by its magic bytes, not its name).
    pub was_gzip: bool,
    line_starts: OnceLock<Vec<usize>>,
}

impl SourceFile {
    pub fn new(name: impl Into<Arc<str>>, path: Option<PathBuf>, bytes: Vec<u8>, was_gzip: bool) -> Self {
        SourceFile { name: name.into(), path, bytes: Arc::new(bytes), was_gzip, line_starts: OnceLock::new() }
    }

    /// Byte offsets where lines start; built on first use (most runs need no locations at all
    /// beyond a handful, so the 50 MB mesh never pays for it unless something is reported).
    fn line_starts(&self) -> &[usize] {
        self.line_starts.get_or_init(|| {
            let mut starts = vec![0];
            starts.extend(self.bytes.iter().enumerate().filter(|(_, b)| **b == b'\n').map(|(i, _)| i + 1));
            starts
        })
    }

    /// 1-based line and column (in bytes) of a byte offset.
    pub fn line_col(&self, offset: usize) -> (u32, u32) {
        let starts = self.line_starts();
        let offset = offset.min(self.bytes.len());
        let line = match starts.binary_search(&offset) {
            Ok(i) => i,
            Err(i) => i - 1,
        };
        let col = offset - starts[line];
        (saturate(line + 1), saturate(col + 1))
    }

    /// The location of a byte offset.
    pub fn loc(&self, offset: usize) -> FileLoc {
        let (line, column) = self.line_col(offset);
        FileLoc { file: self.name.clone(), line, column }
    }

    /// The text of a 1-based line, without its line ending.
    pub fn line_text(&self, line: u32) -> Option<&[u8]> {
        let starts = self.line_starts();
        let index = (line as usize).checked_sub(1)?;
        let start = *starts.get(index)?;
        let mut end = starts.get(index + 1).map_or(self.bytes.len(), |s| s - 1);
        if end > start && self.bytes[end - 1] == b'\r' {
            end -= 1;
        }
        Some(&self.bytes[start..end.max(start)])
    }
}

fn saturate(v: usize) -> u32 {
    u32::try_from(v).unwrap_or(u32::MAX)
}

/// How many characters of a long source line are shown on each side of the caret.
const SNIPPET_HALF_WIDTH: usize = 60;

/// Every source read in one run, so diagnostics can show their source line.
#[derive(Clone, Debug, Default)]
pub struct SourceMap {
    files: Vec<Arc<SourceFile>>,
}

impl SourceMap {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn add(&mut self, file: Arc<SourceFile>) {
        if !self.files.iter().any(|f| Arc::ptr_eq(f, &file)) {
            self.files.push(file);
        }
    }

    pub fn get(&self, name: &str) -> Option<&Arc<SourceFile>> {
        self.files.iter().find(|f| &*f.name == name)
    }

    pub fn files(&self) -> &[Arc<SourceFile>] {
        &self.files
    }

    /// Total bytes of every source read (after decompression).
    pub fn total_bytes(&self) -> usize {
        self.files.iter().map(|f| f.bytes.len()).sum()
    }

    /// The source line of `loc` and a caret line under its column. Tabs are kept in the caret
    /// line so the caret lines up in a terminal; bytes that are not printable text (binary RIB)
    /// show as `.`; very long lines are cut around the column.
    pub fn snippet(&self, loc: &FileLoc) -> Option<String> {
        let file = self.get(&loc.file)?;
        let text = file.line_text(loc.line)?;
        let col = (loc.column as usize).saturating_sub(1).min(text.len());
        let (from, prefix) =
            if col > SNIPPET_HALF_WIDTH { (col - SNIPPET_HALF_WIDTH, "...") } else { (0, "") };
        let to = (col + SNIPPET_HALF_WIDTH).min(text.len());
        let suffix = if to < text.len() { "..." } else { "" };
        let shown = |b: u8| if b == b'\t' || (0x20..0x7f).contains(&b) { b as char } else { '.' };
        let mut line = String::from("    ");
        line.push_str(prefix);
        line.extend(text[from..to].iter().map(|&b| shown(b)));
        line.push_str(suffix);
        let mut caret = String::from("    ");
        caret.extend(std::iter::repeat_n(' ', prefix.len()));
        caret.extend(text[from..col].iter().map(|&b| if b == b'\t' { '\t' } else { ' ' }));
        caret.push('^');
        Some(format!("{line}\n{caret}"))
    }
}

/// Where the parser reads files from. The standard implementation is [`StdFileSystem`]; tests
/// use virtual ones (e.g. to map the flattened names of the RIB corpus back to directories).
pub trait FileSystem: Send + Sync {
    /// Reads a whole file, or fails with an `io::Error`.
    fn read(&self, path: &Path) -> io::Result<Vec<u8>>;
    /// True when `path` names a readable regular file.
    fn is_file(&self, path: &Path) -> bool;
}

/// The real file system.
#[derive(Clone, Copy, Debug, Default)]
pub struct StdFileSystem;

impl FileSystem for StdFileSystem {
    fn read(&self, path: &Path) -> io::Result<Vec<u8>> {
        std::fs::read(path)
    }

    fn is_file(&self, path: &Path) -> bool {
        path.is_file()
    }
}

/// True when the bytes start with the gzip magic number `1f 8b`.
pub fn is_gzip(bytes: &[u8]) -> bool {
    bytes.len() >= 2 && bytes[0] == 0x1f && bytes[1] == 0x8b
}

/// Why raw bytes could not be turned into RIB bytes.
#[derive(Debug, thiserror::Error)]
pub enum DecodeError {
    #[error("cannot decompress gzip data: {0}")]
    Gzip(io::Error),
    #[error("decompressed size exceeds the limit of {limit} bytes")]
    TooLarge { limit: u64 },
}

/// Undoes gzip compression when the magic bytes say so (whatever the file is called); returns
/// the RIB bytes and whether they were compressed. Decompression stops with an error once
/// `max_bytes` would be exceeded, so a small file cannot expand without bound.
pub fn decode(raw: Vec<u8>, max_bytes: u64) -> Result<(Vec<u8>, bool), DecodeError> {
    if !is_gzip(&raw) {
        if raw.len() as u64 > max_bytes {
            return Err(DecodeError::TooLarge { limit: max_bytes });
        }
        return Ok((raw, false));
    }
    let mut out = Vec::new();
    let decoder = flate2::read::MultiGzDecoder::new(&raw[..]);
    decoder.take(max_bytes.saturating_add(1)).read_to_end(&mut out).map_err(DecodeError::Gzip)?;
    if out.len() as u64 > max_bytes {
        return Err(DecodeError::TooLarge { limit: max_bytes });
    }
    Ok((out, true))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_and_column_are_one_based() {
        let f = SourceFile::new("a.rib", None, b"ab\ncd\r\nef".to_vec(), false);
        assert_eq!(f.line_col(0), (1, 1));
        assert_eq!(f.line_col(1), (1, 2));
        assert_eq!(f.line_col(3), (2, 1));
        assert_eq!(f.line_col(7), (3, 1));
        assert_eq!(f.line_text(2), Some(&b"cd"[..]));
        assert_eq!(f.line_text(3), Some(&b"ef"[..]));
        assert_eq!(f.line_text(4), None);
    }

    #[test]
    fn snippet_puts_the_caret_under_the_column_with_tabs_kept() {
        let mut map = SourceMap::new();
        map.add(Arc::new(SourceFile::new("a.rib", None, b"\tSphere x\n".to_vec(), false)));
        let s = map.snippet(&FileLoc::new("a.rib", 1, 9)).unwrap();
        assert_eq!(s, "    \tSphere x\n    \t       ^");
    }

    #[test]
    fn gzip_is_sniffed_and_bounded() {
        use flate2::{Compression, write::GzEncoder};
        use std::io::Write;
        let mut enc = GzEncoder::new(Vec::new(), Compression::fast());
        enc.write_all(&[b' '; 10_000]).unwrap();
        let gz = enc.finish().unwrap();
        let (bytes, was_gzip) = decode(gz.clone(), 1 << 20).unwrap();
        assert!(was_gzip);
        assert_eq!(bytes.len(), 10_000);
        assert!(matches!(decode(gz, 100), Err(DecodeError::TooLarge { limit: 100 })));
        assert!(matches!(decode(vec![0x1f, 0x8b, 0, 0], 100), Err(DecodeError::Gzip(_))));
    }
}
