//! Writing a sidecar EXR file atomically and byte for byte reproducibly.
//!
//! The `exr` crate keeps custom header attributes in a `HashMap` with a random hasher, so the
//! same data was written with its attributes in a different order on each run. OpenEXR itself
//! writes them in name order; so do we: the header is put in name order once the file is
//! written. Attribute order has no meaning in the format, and sorting within each header keeps
//! its length, so the offset tables that follow stay valid.

use std::io::{self, Seek, SeekFrom, Write};
use std::path::Path;

/// How many leading bytes of the file are kept to reorder the header. Sidecar headers (a few
/// dozen attributes and a channel list) are far smaller; a header that does not fit is left in
/// the order `exr` wrote it.
const HEAD_LIMIT: usize = 1 << 16;

/// The bit of the version field that marks a multi-part file.
const MULTIPART_FLAG: u32 = 0x1000;

/// Writes the EXR file that `write` produces to `path` atomically (see
/// [`depth_remap::table::write_atomically`]), with each header's attributes in name order.
pub(crate) fn write_exr_atomically<F>(path: &Path, write: F) -> io::Result<()>
where
    F: FnOnce(&mut HeadRecorder<&mut io::BufWriter<std::fs::File>>) -> exr::error::UnitResult,
{
    depth_remap::table::write_atomically(path, |writer| {
        let mut recorder = HeadRecorder::new(writer);
        write(&mut recorder).map_err(|e| match e {
            exr::error::Error::Io(io) => io,
            other => io::Error::other(other.to_string()),
        })?;
        recorder.sort_header_attributes()
    })
}

/// Puts each header's attributes of the EXR file held in `file` in name order, in place; the
/// ray tracer's stamped images use it so that they, too, are reproducible byte for byte. A
/// buffer that does not start with a complete EXR header is left as it is.
pub fn sort_exr_header_attributes(file: &mut [u8]) {
    if let Some(sorted) = sorted_header(&file[..file.len().min(HEAD_LIMIT)]) {
        file[HEADERS_START..HEADERS_START + sorted.len()].copy_from_slice(&sorted);
    }
}

/// A writer that passes everything through and keeps a copy of the file's first
/// [`HEAD_LIMIT`] bytes, so the header can be rewritten in place once the file is complete.
pub(crate) struct HeadRecorder<W> {
    inner: W,
    position: u64,
    head: Vec<u8>,
}

impl<W: Write + Seek> HeadRecorder<W> {
    fn new(inner: W) -> Self {
        HeadRecorder { inner, position: 0, head: Vec::new() }
    }

    /// Rewrites the header with its attributes in name order, then returns to the file's end.
    fn sort_header_attributes(&mut self) -> io::Result<()> {
        if let Some(sorted) = sorted_header(&self.head) {
            self.inner.seek(SeekFrom::Start(HEADERS_START as u64))?;
            self.inner.write_all(&sorted)?;
            self.position = self.inner.seek(SeekFrom::End(0))?;
        }
        Ok(())
    }
}

impl<W: Write> Write for HeadRecorder<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let written = self.inner.write(buf)?;
        let start = self.position;
        if start < HEAD_LIMIT as u64 {
            let start = start as usize;
            let end = (start + written).min(HEAD_LIMIT);
            if self.head.len() < end {
                self.head.resize(end, 0);
            }
            self.head[start..end].copy_from_slice(&buf[..end - start]);
        }
        self.position += written as u64;
        Ok(written)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

impl<W: Seek> Seek for HeadRecorder<W> {
    fn seek(&mut self, to: SeekFrom) -> io::Result<u64> {
        self.position = self.inner.seek(to)?;
        Ok(self.position)
    }
}

/// Where the first header starts: after the magic number and the version field.
const HEADERS_START: usize = 8;

/// The headers of the EXR file starting with `head`, each with its attributes sorted by name,
/// as the bytes from [`HEADERS_START`] on; `None` when `head` is not a complete EXR header
/// (then the file keeps the order it was written in).
fn sorted_header(head: &[u8]) -> Option<Vec<u8>> {
    if head.get(..4)? != [0x76, 0x2f, 0x31, 0x01] {
        return None;
    }
    let version = u32::from_le_bytes(head.get(4..8)?.try_into().ok()?);
    let multipart = version & MULTIPART_FLAG != 0;
    let mut out = Vec::new();
    let mut at = HEADERS_START;
    loop {
        let mut attributes: Vec<&[u8]> = Vec::new();
        while *head.get(at)? != 0 {
            let start = at;
            let name_end = at + head.get(at..)?.iter().position(|&b| b == 0)?;
            let type_end = name_end + 1 + head.get(name_end + 1..)?.iter().position(|&b| b == 0)?;
            let size_at = type_end + 1;
            let size = i32::from_le_bytes(head.get(size_at..size_at + 4)?.try_into().ok()?);
            let size = usize::try_from(size).ok()?;
            at = size_at + 4 + size;
            attributes.push(head.get(start..at)?);
        }
        // Attribute names are unique within a header, so sorting whole attributes sorts by name.
        attributes.sort_by_key(|attribute| &attribute[..attribute.iter().position(|&b| b == 0).unwrap_or(0)]);
        for attribute in attributes {
            out.extend_from_slice(attribute);
        }
        out.push(0);
        at += 1;
        // A multi-part file ends its list of headers with an empty one.
        if !multipart || *head.get(at)? == 0 {
            return Some(out);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn attribute(name: &str, kind: &str, value: &[u8]) -> Vec<u8> {
        let mut bytes = Vec::new();
        bytes.extend_from_slice(name.as_bytes());
        bytes.push(0);
        bytes.extend_from_slice(kind.as_bytes());
        bytes.push(0);
        bytes.extend_from_slice(&(value.len() as i32).to_le_bytes());
        bytes.extend_from_slice(value);
        bytes
    }

    fn file(version: u32, headers: &[Vec<Vec<u8>>]) -> Vec<u8> {
        let mut bytes = vec![0x76, 0x2f, 0x31, 0x01];
        bytes.extend_from_slice(&version.to_le_bytes());
        for header in headers {
            for a in header {
                bytes.extend_from_slice(a);
            }
            bytes.push(0);
        }
        if version & MULTIPART_FLAG != 0 {
            bytes.push(0);
        }
        bytes
    }

    #[test]
    fn attributes_of_each_part_come_out_in_name_order_and_the_length_is_kept() {
        let b = attribute("b", "int", &[1, 0, 0, 0]);
        let a = attribute("a", "string", b"zz");
        let c = attribute("c", "float", &[0, 0, 128, 63]);
        let single = file(2, &[vec![b.clone(), c.clone(), a.clone()]]);
        let sorted = sorted_header(&single).unwrap();
        assert_eq!(sorted, file(2, &[vec![a.clone(), b.clone(), c.clone()]])[HEADERS_START..]);

        let multi = file(2 | MULTIPART_FLAG, &[vec![c.clone(), a.clone()], vec![b.clone(), a.clone()]]);
        let sorted = sorted_header(&multi).unwrap();
        let expected = file(2 | MULTIPART_FLAG, &[vec![a.clone(), c], vec![a, b]]);
        // The final empty header stays where it was; only the parts' attributes move.
        assert_eq!(sorted, expected[HEADERS_START..expected.len() - 1]);
    }

    #[test]
    fn a_truncated_or_foreign_head_is_left_alone() {
        let header = file(2, &[vec![attribute("name", "string", b"value")]]);
        for cut in 0..header.len() {
            assert_eq!(sorted_header(&header[..cut]), None, "cut at {cut}");
        }
        assert_eq!(sorted_header(b"not an exr file at all"), None);
        let mut negative = file(2, &[vec![attribute("x", "int", &[0; 4])]]);
        negative[HEADERS_START + 6..HEADERS_START + 10].copy_from_slice(&(-5i32).to_le_bytes());
        assert_eq!(sorted_header(&negative), None);
    }
}
