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

mod parse;

use crate::float_text;
use parse::parse_text;
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
