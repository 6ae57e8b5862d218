//! The depth table (CONTRACTS.md §2): radial distances per pixel, rows top-first, `+inf` for a
//! miss; its ASCII form and its single-channel OpenEXR form.
//!
//! ```text
//! # lrt-depth v1 width=3 height=2 depth=radial units=scene
//! 1.5 1.25 inf
//! 2 2.0000002 3.75
//! ```
//!
//! Reading is strict about values (every error names the line and column: ragged rows, bad
//! tokens, `nan`, negatives, values beyond `f32`, a size that disagrees with the header) and
//! lenient about layout (`\r\n`, runs of spaces or tabs, blank lines and `#` comments anywhere).
//! Large inputs are parsed on several threads; writers format on several threads and write a
//! temporary file that is renamed into place, so a reader never sees half a table.

use crate::float_text::{self, TokenError};
use std::fmt;
use std::fs;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// The header line the writer emits first (followed by the size).
pub const HEADER_PREFIX: &str = "# lrt-depth";

/// A depth table in memory: `width * height` values, row-major, top row first. Every value is
/// a non-negative `f32` or `+inf` (a miss); the constructor enforces it.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthTable {
    width: u32,
    height: u32,
    values: Vec<f32>,
}

/// Limits that keep a reader from allocating without bound on hostile input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReadLimits {
    /// Largest `width * height` accepted.
    pub max_pixels: u64,
    /// Largest file accepted, in bytes.
    pub max_bytes: u64,
}

impl Default for ReadLimits {
    /// 2^28 pixels (16384 x 16384) and 8 GiB of text.
    fn default() -> Self {
        ReadLimits { max_pixels: 1 << 28, max_bytes: 8 << 30 }
    }
}

/// How a depth table failed to read, write or match.
#[derive(Debug)]
#[non_exhaustive]
pub enum DepthTableErrorKind {
    Io(io::Error),
    /// A token that is not a non-negative decimal or `inf`.
    BadToken {
        token: String,
    },
    /// `nan`.
    NotANumber {
        token: String,
    },
    /// A negative number.
    Negative {
        token: String,
    },
    /// A decimal beyond the largest `f32`.
    OutOfRange {
        token: String,
    },
    /// A row whose length differs from the table width.
    RowLength {
        row: u64,
        found: u64,
        expected: u64,
        width_from_header: bool,
    },
    /// Fewer rows than the header says.
    TooFewRows {
        found: u64,
        expected: u64,
    },
    /// More rows than the header says.
    TooManyRows {
        expected: u64,
    },
    /// A malformed `# lrt-depth` header.
    BadHeader {
        message: String,
    },
    /// No values at all.
    Empty,
    /// Larger than [`ReadLimits`] allow.
    TooLarge {
        what: &'static str,
        size: u64,
        limit: u64,
    },
    /// The table's size differs from the image it is paired with.
    SizeMismatch {
        table: (u32, u32),
        image: (u32, u32),
    },
    /// An in-memory table with a value that is not a depth (`nan` or negative) or a wrong count.
    InvalidValue {
        index: usize,
        value: f32,
    },
    WrongValueCount {
        width: u32,
        height: u32,
        count: usize,
    },
    /// The OpenEXR library failed.
    Exr {
        message: String,
    },
    /// An OpenEXR file without a `Z` channel.
    MissingZChannel {
        channels: Vec<String>,
    },
    /// An OpenEXR value that is not a depth, at pixel `(x, y)`.
    InvalidExrValue {
        x: u32,
        y: u32,
        value: f32,
    },
}

/// An error with where it happened: the file and, for text, the 1-based line and column.
#[derive(Debug)]
pub struct DepthTableError {
    pub kind: DepthTableErrorKind,
    pub path: Option<PathBuf>,
    /// 1-based line and column (in characters) of the offending text.
    pub location: Option<(u64, u64)>,
}

impl DepthTableError {
    pub(crate) fn new(kind: DepthTableErrorKind) -> Self {
        DepthTableError { kind, path: None, location: None }
    }

    fn at(kind: DepthTableErrorKind, line: u64, column: u64) -> Self {
        DepthTableError { kind, path: None, location: Some((line, column)) }
    }

    pub(crate) fn with_path(mut self, path: &Path) -> Self {
        self.path = Some(path.to_path_buf());
        self
    }
}

impl fmt::Display for DepthTableError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (&self.path, self.location) {
            (Some(path), Some((line, column))) => write!(f, "{}:{line}:{column}: ", path.display())?,
            (Some(path), None) => write!(f, "{}: ", path.display())?,
            (None, Some((line, column))) => write!(f, "line {line}, column {column}: ")?,
            (None, None) => {}
        }
        write!(f, "{}", self.kind)
    }
}

impl fmt::Display for DepthTableErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use DepthTableErrorKind as K;
        match self {
            K::Io(e) => write!(f, "{e}"),
            K::BadToken { token } => {
                write!(f, "expected a non-negative decimal number or `inf`, found `{token}`")
            }
            K::NotANumber { token } => write!(f, "`{token}` is not a depth (a miss is written `inf`)"),
            K::Negative { token } => write!(f, "negative depth `{token}`"),
            K::OutOfRange { token } => {
                write!(f, "`{token}` is beyond the largest 32-bit float (a miss is written `inf`)")
            }
            K::RowLength { row, found, expected, width_from_header } => {
                let source = if *width_from_header { "the header's width" } else { "the first row" };
                write!(f, "row {row} has {found} values, but {source} is {expected}")
            }
            K::TooFewRows { found, expected } => {
                write!(f, "the table ends after {found} rows, but the header says height={expected}")
            }
            K::TooManyRows { expected } => write!(f, "more rows than the header's height={expected}"),
            K::BadHeader { message } => write!(f, "bad `{HEADER_PREFIX}` header: {message}"),
            K::Empty => write!(f, "the depth table has no values"),
            K::TooLarge { what, size, limit } => write!(f, "{what} {size} exceeds the limit {limit}"),
            K::SizeMismatch { table, image } => write!(
                f,
                "the depth table is {}x{} but the image is {}x{}",
                table.0, table.1, image.0, image.1
            ),
            K::InvalidValue { index, value } => {
                write!(f, "value {value} at index {index} is not a depth (finite non-negative or +inf)")
            }
            K::WrongValueCount { width, height, count } => {
                write!(f, "{count} values do not make a {width}x{height} table")
            }
            K::Exr { message } => write!(f, "OpenEXR: {message}"),
            K::MissingZChannel { channels } => {
                write!(f, "no `Z` channel in the OpenEXR file (channels: {})", channels.join(", "))
            }
            K::InvalidExrValue { x, y, value } => {
                write!(f, "pixel ({x}, {y}) holds {value}, which is not a depth (a miss is +inf)")
            }
        }
    }
}

impl std::error::Error for DepthTableError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.kind {
            DepthTableErrorKind::Io(e) => Some(e),
            _ => None,
        }
    }
}

impl From<io::Error> for DepthTableError {
    fn from(e: io::Error) -> Self {
        DepthTableError::new(DepthTableErrorKind::Io(e))
    }
}

/// Options for reading text.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ParseOptions {
    pub limits: ReadLimits,
    /// Threads to parse with; 0 means all available. Inputs under 4 MiB use one.
    pub threads: usize,
}

impl DepthTable {
    /// A table from row-major values (top row first). Fails unless there are exactly
    /// `width * height` values, each non-negative or `+inf`.
    pub fn new(width: u32, height: u32, values: Vec<f32>) -> Result<Self, DepthTableError> {
        if width == 0 || height == 0 || values.len() as u64 != u64::from(width) * u64::from(height) {
            return Err(DepthTableError::new(DepthTableErrorKind::WrongValueCount {
                width,
                height,
                count: values.len(),
            }));
        }
        if let Some(index) = values.iter().position(|v| !is_depth(*v)) {
            return Err(DepthTableError::new(DepthTableErrorKind::InvalidValue {
                index,
                value: values[index],
            }));
        }
        Ok(DepthTable { width, height, values })
    }

    /// A table where every ray misses.
    pub fn all_misses(width: u32, height: u32) -> Self {
        let count = width as usize * height as usize;
        DepthTable { width, height, values: vec![f32::INFINITY; count] }
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    /// All values, row-major, top row first.
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    pub fn into_values(self) -> Vec<f32> {
        self.values
    }

    /// One row (`j` from the top).
    pub fn row(&self, j: u32) -> &[f32] {
        let w = self.width as usize;
        &self.values[j as usize * w..(j as usize + 1) * w]
    }

    /// The depth of pixel `(i, j)` (column from the left, row from the top).
    pub fn get(&self, i: u32, j: u32) -> Option<f32> {
        (i < self.width && j < self.height)
            .then(|| self.values[j as usize * self.width as usize + i as usize])
    }

    /// Sets the depth of pixel `(i, j)`; values that are not depths (`nan`, negative) are
    /// refused and return `false`, as do positions outside the table.
    pub fn set(&mut self, i: u32, j: u32, depth: f32) -> bool {
        if i >= self.width || j >= self.height || !is_depth(depth) {
            return false;
        }
        self.values[j as usize * self.width as usize + i as usize] = depth;
        true
    }

    /// Checks that the table is as large as the image it goes with; the error names both.
    pub fn check_size(&self, image_width: u32, image_height: u32) -> Result<(), DepthTableError> {
        if (self.width, self.height) == (image_width, image_height) {
            Ok(())
        } else {
            Err(DepthTableError::new(DepthTableErrorKind::SizeMismatch {
                table: (self.width, self.height),
                image: (image_width, image_height),
            }))
        }
    }

    /// The header line, without the newline.
    pub fn header(&self) -> String {
        format!("{HEADER_PREFIX} v1 width={} height={} depth=radial units=scene", self.width, self.height)
    }

    /// The ASCII form (header, then rows), formatted on `threads` threads (0: all available).
    pub fn to_text(&self, threads: usize) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.values.len() * 10 + 64);
        out.extend_from_slice(self.header().as_bytes());
        out.push(b'\n');
        let threads = thread_count(threads, self.values.len() / (1 << 18));
        let w = self.width as usize;
        if threads <= 1 {
            format_rows(&self.values, w, &mut out);
            return out;
        }
        let rows_per_chunk = (self.height as usize).div_ceil(threads);
        let chunks: Vec<Vec<u8>> = std::thread::scope(|scope| {
            let handles: Vec<_> = self
                .values
                .chunks(rows_per_chunk * w)
                .map(|chunk| {
                    scope.spawn(move || {
                        let mut text = Vec::with_capacity(chunk.len() * 10);
                        format_rows(chunk, w, &mut text);
                        text
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap_or_default()).collect()
        });
        for chunk in chunks {
            out.extend_from_slice(&chunk);
        }
        out
    }

    /// Parses the ASCII form (see the module doc) with default options.
    pub fn parse(text: &[u8]) -> Result<Self, DepthTableError> {
        Self::parse_with(text, ParseOptions::default())
    }

    /// Parses the ASCII form.
    pub fn parse_with(text: &[u8], options: ParseOptions) -> Result<Self, DepthTableError> {
        parse_text(text, options)
    }

    /// Reads a `.depth` text file, or an OpenEXR file when the name ends in `.exr`.
    pub fn read(path: impl AsRef<Path>) -> Result<Self, DepthTableError> {
        Self::read_with(path, ParseOptions::default())
    }

    /// [`DepthTable::read`] with explicit options.
    pub fn read_with(path: impl AsRef<Path>, options: ParseOptions) -> Result<Self, DepthTableError> {
        let path = path.as_ref();
        if is_exr_path(path) {
            return crate::exr_io::read_exr(path, options.limits);
        }
        let run = || -> Result<Self, DepthTableError> {
            let size = fs::metadata(path)?.len();
            if size > options.limits.max_bytes {
                return Err(DepthTableError::new(DepthTableErrorKind::TooLarge {
                    what: "file size",
                    size,
                    limit: options.limits.max_bytes,
                }));
            }
            let text = fs::read(path)?;
            parse_text(&text, options)
        };
        run().map_err(|e| e.with_path(path))
    }

    /// Writes the table atomically: text, or OpenEXR when the name ends in `.exr`.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<(), DepthTableError> {
        let path = path.as_ref();
        if is_exr_path(path) {
            return crate::exr_io::write_exr(self, path);
        }
        let text = self.to_text(0);
        write_atomically(path, |file| file.write_all(&text))
            .map_err(|e| DepthTableError::from(e).with_path(path))
    }
}

/// Whether `v` may be stored in a depth table.
#[inline]
pub fn is_depth(v: f32) -> bool {
    v >= 0.0 // false for NaN and negatives; true for +inf
}

fn is_exr_path(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// Writes `path` through a temporary file in the same directory that is synced and renamed over
/// it, so that readers see either the old file or the complete new one.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut io::BufWriter<fs::File>) -> io::Result<()>,
) -> io::Result<()> {
    let directory = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path.file_name().ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "no file name"))?;
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let unique = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let mut temp_name = std::ffi::OsString::from(".");
    temp_name.push(name);
    temp_name.push(format!(".{}.{unique}.tmp", std::process::id()));
    let temp = directory.join(temp_name);
    let result = (|| {
        let file = fs::File::create(&temp)?;
        let mut writer = io::BufWriter::with_capacity(1 << 20, file);
        write(&mut writer)?;
        let file = writer.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        fs::rename(&temp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&temp);
    }
    result
}

/// How many threads to use: `requested`, or when it is 0 all available but no more than
/// `work_units` (each unit is enough work to be worth a thread).
pub(crate) fn thread_count(requested: usize, work_units: usize) -> usize {
    if requested == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get()).min(work_units.max(1))
    } else {
        requested
    }
}

fn format_rows(values: &[f32], width: usize, out: &mut Vec<u8>) {
    for row in values.chunks(width) {
        for (k, v) in row.iter().enumerate() {
            if k > 0 {
                out.push(b' ');
            }
            float_text::push_f32(out, *v);
        }
        out.push(b'\n');
    }
}

// ---------------------------------------------------------------------------------------------
// Parsing

/// The 1-based column (in characters) of byte offset `at` in `line`.
fn column_of(line: &[u8], at: usize) -> u64 {
    let prefix = &line[..at.min(line.len())];
    // Count UTF-8 characters: every byte that is not a continuation byte.
    prefix.iter().filter(|&&b| (b & 0xC0) != 0x80).count() as u64 + 1
}

/// The text of the token starting at byte `at`, for error messages (lossy, at most 64 chars).
fn token_text(line: &[u8], at: usize) -> String {
    let rest = &line[at.min(line.len())..];
    let length = float_text::token_length(rest);
    let text = String::from_utf8_lossy(&rest[..length]);
    if text.chars().count() > 64 {
        let mut short: String = text.chars().take(61).collect();
        short.push_str("...");
        short
    } else {
        text.into_owned()
    }
}

/// Splits off one line (without its `\n` and a `\r` before it); returns it and the rest.
#[inline]
fn split_line(text: &[u8]) -> (&[u8], &[u8]) {
    match text.iter().position(|&b| b == b'\n') {
        Some(end) => {
            let line = &text[..end];
            (line.strip_suffix(b"\r").unwrap_or(line), &text[end + 1..])
        }
        None => (text.strip_suffix(b"\r").unwrap_or(text), &[]),
    }
}

fn is_blank(line: &[u8]) -> bool {
    line.iter().all(|&b| b == b' ' || b == b'\t')
}

/// What a chunk of data lines parsed into.
struct ChunkResult {
    values: Vec<f32>,
    rows: u64,
    lines: u64,
}

/// An error inside a chunk, at a chunk-relative line.
struct ChunkError {
    kind: DepthTableErrorKind,
    relative_line: u64,
    column: u64,
}

/// Parses one data line into `values`; returns how many values it held, or an error column.
#[inline]
fn parse_row(line: &[u8], values: &mut Vec<f32>) -> Result<u64, (DepthTableErrorKind, u64)> {
    let mut at = 0;
    let mut count = 0u64;
    let len = line.len();
    loop {
        while at < len && (line[at] == b' ' || line[at] == b'\t') {
            at += 1;
        }
        if at >= len {
            return Ok(count);
        }
        let (result, length) = float_text::parse_f32_token(&line[at..]);
        match result {
            Ok(v) => values.push(v),
            Err(error) => {
                let token = token_text(line, at);
                let kind = match error {
                    TokenError::Malformed => DepthTableErrorKind::BadToken { token },
                    TokenError::NotANumber => DepthTableErrorKind::NotANumber { token },
                    TokenError::Negative => DepthTableErrorKind::Negative { token },
                    TokenError::OutOfRange => DepthTableErrorKind::OutOfRange { token },
                };
                return Err((kind, column_of(line, at)));
            }
        }
        at += length;
        count += 1;
    }
}

/// Parses data lines (comments and blank lines allowed) with rows of exactly `width` values.
/// Row numbers in errors count from 1 at the start of the chunk.
fn parse_chunk(mut text: &[u8], width: u64, width_from_header: bool) -> Result<ChunkResult, ChunkError> {
    let mut values = Vec::with_capacity(text.len() / 8);
    let mut rows = 0u64;
    let mut lines = 0u64;
    while !text.is_empty() {
        let (line, rest) = split_line(text);
        text = rest;
        lines += 1;
        if line.first() == Some(&b'#') || is_blank(line) {
            continue;
        }
        let before = values.len();
        let found = parse_row(line, &mut values).map_err(|(kind, column)| ChunkError {
            kind,
            relative_line: lines,
            column,
        })?;
        rows += 1;
        if found != width {
            // Point at the first surplus value, or at the end of a short row.
            let column = if found > width {
                let mut at = 0;
                let mut seen = 0;
                loop {
                    while at < line.len() && (line[at] == b' ' || line[at] == b'\t') {
                        at += 1;
                    }
                    if seen == width {
                        break;
                    }
                    at += float_text::token_length(&line[at..]);
                    seen += 1;
                }
                column_of(line, at)
            } else {
                column_of(line, line.len())
            };
            values.truncate(before);
            return Err(ChunkError {
                kind: DepthTableErrorKind::RowLength { row: rows, found, expected: width, width_from_header },
                relative_line: lines,
                column,
            });
        }
    }
    Ok(ChunkResult { values, rows, lines })
}

/// The `# lrt-depth v1 width=W height=H depth=radial units=scene` header.
struct Header {
    width: u32,
    height: u32,
}

fn parse_header(line: &[u8], line_number: u64) -> Result<Header, DepthTableError> {
    let bad = |message: String, at: usize| {
        DepthTableError::at(DepthTableErrorKind::BadHeader { message }, line_number, column_of(line, at))
    };
    let text = String::from_utf8_lossy(line);
    let mut words = Vec::new();
    let mut offset = 0;
    for word in text.split([' ', '\t']) {
        if !word.is_empty() {
            words.push((word, offset));
        }
        offset += word.len() + 1;
    }
    // words[0] = "#", words[1] = "lrt-depth" (or "#lrt-depth" handled by the caller's check).
    let mut rest = words.iter().skip_while(|(w, _)| *w == "#" || w.ends_with("lrt-depth"));
    let Some(&(version, version_at)) = rest.next() else {
        return Err(bad("missing version (expected `v1`)".into(), line.len()));
    };
    if version != "v1" {
        return Err(bad(format!("unsupported version `{version}` (this reader knows `v1`)"), version_at));
    }
    let (mut width, mut height) = (None, None);
    for &(word, at) in rest {
        let Some((key, value)) = word.split_once('=') else {
            return Err(bad(format!("expected `key=value`, found `{word}`"), at));
        };
        let size = |value: &str| -> Result<u32, DepthTableError> {
            match value.parse::<u32>() {
                Ok(n) if n > 0 => Ok(n),
                _ => Err(bad(format!("`{key}` must be a positive integer, found `{value}`"), at)),
            }
        };
        match key {
            "width" => width = Some(size(value)?),
            "height" => height = Some(size(value)?),
            "depth" if value != "radial" => {
                return Err(bad(
                    format!("depth={value} is not supported: tables hold radial distances (depth=radial)"),
                    at,
                ));
            }
            // units=scene and keys of later minor revisions are informational.
            _ => {}
        }
    }
    match (width, height) {
        (Some(width), Some(height)) => Ok(Header { width, height }),
        _ => Err(bad("needs both width= and height=".into(), line.len())),
    }
}

fn is_header_line(line: &[u8]) -> bool {
    let Some(rest) = line.strip_prefix(b"#") else { return false };
    let rest = rest.trim_ascii_start();
    rest.starts_with(b"lrt-depth") && rest.get(9).is_none_or(|b| *b == b' ' || *b == b'\t')
}

fn parse_text(text: &[u8], options: ParseOptions) -> Result<DepthTable, DepthTableError> {
    let limits = options.limits;
    if text.len() as u64 > limits.max_bytes {
        return Err(DepthTableError::new(DepthTableErrorKind::TooLarge {
            what: "text size",
            size: text.len() as u64,
            limit: limits.max_bytes,
        }));
    }
    // Leading comments, blank lines and the header, one line at a time.
    let mut rest = text;
    let mut line_number = 0u64;
    let mut header = None;
    let first_data = loop {
        if rest.is_empty() {
            break None;
        }
        let (line, after) = split_line(rest);
        line_number += 1;
        if is_header_line(line) {
            if header.is_some() {
                return Err(DepthTableError::at(
                    DepthTableErrorKind::BadHeader { message: "a second header".into() },
                    line_number,
                    1,
                ));
            }
            header = Some(parse_header(line, line_number)?);
        } else if !(line.first() == Some(&b'#') || is_blank(line)) {
            break Some(line);
        }
        rest = after;
    };
    let Some(first_line) = first_data else {
        return match header {
            Some(h) => Err(DepthTableError::at(
                DepthTableErrorKind::TooFewRows { found: 0, expected: u64::from(h.height) },
                line_number.max(1),
                1,
            )),
            None => Err(DepthTableError::new(DepthTableErrorKind::Empty)),
        };
    };
    let first_data_line = line_number;
    // The width: from the header, or from the first row.
    let (width, width_from_header) = match &header {
        Some(h) => (u64::from(h.width), true),
        None => {
            let mut scratch = Vec::new();
            let n = parse_row(first_line, &mut scratch)
                .map_err(|(kind, column)| DepthTableError::at(kind, first_data_line, column))?;
            (n, false)
        }
    };
    if let Some(h) = &header {
        let pixels = u64::from(h.width) * u64::from(h.height);
        if pixels > limits.max_pixels {
            return Err(DepthTableError::at(
                DepthTableErrorKind::TooLarge {
                    what: "width x height",
                    size: pixels,
                    limit: limits.max_pixels,
                },
                first_data_line - 1,
                1,
            ));
        }
    } else if width > limits.max_pixels {
        return Err(DepthTableError::at(
            DepthTableErrorKind::TooLarge { what: "row length", size: width, limit: limits.max_pixels },
            first_data_line,
            1,
        ));
    }
    // The data, from the first data line on, split at line ends into chunks parsed in parallel.
    let data = rest;
    let threads = thread_count(options.threads, data.len() >> 22);
    let mut bounds = vec![0usize];
    for k in 1..threads {
        let guess = (data.len() * k / threads).max(*bounds.last().unwrap_or(&0));
        match data[guess..].iter().position(|&b| b == b'\n') {
            Some(p) => bounds.push(guess + p + 1),
            None => break,
        }
    }
    bounds.push(data.len());
    bounds.dedup();
    let chunks: Vec<&[u8]> = bounds.windows(2).map(|w| &data[w[0]..w[1]]).collect();
    let results: Vec<Result<ChunkResult, ChunkError>> = if chunks.len() <= 1 {
        chunks.iter().map(|c| parse_chunk(c, width, width_from_header)).collect()
    } else {
        std::thread::scope(|scope| {
            let handles: Vec<_> = chunks
                .iter()
                .map(|c| scope.spawn(move || parse_chunk(c, width, width_from_header)))
                .collect();
            handles
                .into_iter()
                .map(|h| {
                    h.join().unwrap_or_else(|_| {
                        Err(ChunkError {
                            kind: DepthTableErrorKind::BadToken { token: String::new() },
                            relative_line: 0,
                            column: 0,
                        })
                    })
                })
                .collect()
        })
    };
    // Stitch: absolute line and row numbers come from the chunks before.
    let mut line_base = first_data_line - 1;
    let mut rows = 0u64;
    let mut values: Vec<f32> = Vec::new();
    for result in results {
        match result {
            Ok(chunk) => {
                line_base += chunk.lines;
                rows += chunk.rows;
                if rows * width > limits.max_pixels {
                    return Err(DepthTableError::new(DepthTableErrorKind::TooLarge {
                        what: "width x height",
                        size: rows * width,
                        limit: limits.max_pixels,
                    }));
                }
                if values.is_empty() {
                    values = chunk.values;
                } else {
                    values.extend_from_slice(&chunk.values);
                }
            }
            Err(error) => {
                let kind = match error.kind {
                    // Chunks count rows from 1; make the row number absolute.
                    DepthTableErrorKind::RowLength { row, found, expected, width_from_header } => {
                        DepthTableErrorKind::RowLength { row: rows + row, found, expected, width_from_header }
                    }
                    other => other,
                };
                return Err(DepthTableError::at(kind, line_base + error.relative_line, error.column));
            }
        }
    }
    if let Some(h) = &header {
        let expected = u64::from(h.height);
        if rows < expected {
            return Err(DepthTableError::at(
                DepthTableErrorKind::TooFewRows { found: rows, expected },
                line_base.max(1),
                1,
            ));
        }
        if rows > expected {
            let line = line_of_data_row(data, expected + 1) + first_data_line - 1;
            return Err(DepthTableError::at(DepthTableErrorKind::TooManyRows { expected }, line, 1));
        }
    }
    let height = u32::try_from(rows).map_err(|_| {
        DepthTableError::new(DepthTableErrorKind::TooLarge {
            what: "height",
            size: rows,
            limit: u64::from(u32::MAX),
        })
    })?;
    let width = u32::try_from(width).map_err(|_| {
        DepthTableError::new(DepthTableErrorKind::TooLarge {
            what: "width",
            size: width,
            limit: u64::from(u32::MAX),
        })
    })?;
    if width == 0 {
        return Err(DepthTableError::at(DepthTableErrorKind::Empty, first_data_line, 1));
    }
    Ok(DepthTable { width, height, values })
}

/// The 1-based line (within `data`) of the `n`-th data row (1-based).
fn line_of_data_row(mut data: &[u8], n: u64) -> u64 {
    let mut line = 0;
    let mut seen = 0;
    while !data.is_empty() {
        let (text, rest) = split_line(data);
        data = rest;
        line += 1;
        if !(text.first() == Some(&b'#') || is_blank(text)) {
            seen += 1;
            if seen == n {
                return line;
            }
        }
    }
    line
}
