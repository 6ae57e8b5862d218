//! Reading the ASCII depth table: the header, rows split into chunks parsed on several threads,
//! and every error located by line and column.

use super::{DepthTable, DepthTableError, DepthTableErrorKind, ParseOptions, thread_count};
use crate::float_text::{self, TokenError};

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

pub(super) fn parse_text(text: &[u8], options: ParseOptions) -> Result<DepthTable, DepthTableError> {
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
