//! RISpec Appendix C's binary encoding: encoded numbers, strings and arrays, and the request
//! and string definitions a stream makes (bytes 0200 and above), interleaved freely with ASCII.

use super::{LexError, Lexer, Num, Text, Token, TokenKind};
use std::sync::Arc;

/// The binary-encoding state of a stream: requests and strings defined so far (RISpec C.2).
#[derive(Clone, Debug, Default)]
pub(crate) struct BinaryTables {
    requests: Vec<Option<Arc<[u8]>>>,
    strings: std::collections::HashMap<u32, Arc<[u8]>>,
}

/// Most string tokens a stream may define, so a hostile stream cannot grow the table without
/// bound (each definition also needs input bytes, so this is generous).
const MAX_DEFINED_STRINGS: usize = 1 << 20;

impl Lexer {
    pub(super) fn read_u32_be(&mut self, n: usize, token_start: usize) -> Result<u32, LexError> {
        if self.pos + n > self.end {
            self.pos = self.end;
            return Err(self.err(token_start, "binary token cut short by the end of the file"));
        }
        let mut v: u32 = 0;
        for k in 0..n {
            v = (v << 8) | u32::from(self.bytes[self.pos + k]);
        }
        self.pos += n;
        Ok(v)
    }

    pub(super) fn read_slice(&mut self, n: usize, token_start: usize) -> Result<(usize, usize), LexError> {
        if n > self.end - self.pos {
            self.pos = self.end;
            return Err(self.err(token_start, "binary string cut short by the end of the file"));
        }
        let span = (self.pos, self.pos + n);
        self.pos += n;
        Ok(span)
    }

    /// Decodes one binary token starting at `start` (a byte >= 0200). Returns `None` for
    /// definitions, which produce no token.
    pub(super) fn scan_binary(&mut self, start: usize) -> Result<Option<Token>, LexError> {
        let code = self.bytes[start];
        self.pos = start + 1;
        let token = |kind| Ok(Some(Token { kind, start }));
        match code {
            // Integers and fixed-point numbers: 0200 + 4d + w, then w+1 bytes of a signed
            // integer, most significant first, whose bottom d bytes follow the radix point.
            0x80..=0x8f => {
                let w = usize::from(code & 0x03);
                let d = i32::from((code >> 2) & 0x03);
                let n = w + 1;
                let raw = self.read_u32_be(n, start)?;
                let shift = 32 - 8 * n as u32;
                let signed = ((raw << shift) as i32) >> shift;
                if d == 0 {
                    token(TokenKind::Number(Num::Int(signed)))
                } else {
                    token(TokenKind::Number(Num::F64(f64::from(signed) / 256f64.powi(d))))
                }
            }
            // Short strings: 0220 + w, then w bytes.
            0x90..=0x9f => {
                let (a, b) = self.read_slice(usize::from(code - 0x90), start)?;
                token(TokenKind::String(Text::Span(a, b)))
            }
            // Long strings: 0240 + l, an (l+1)-byte unsigned length, then the bytes.
            0xa0..=0xa3 => {
                let len = self.read_u32_be(usize::from(code - 0xa0) + 1, start)? as usize;
                let (a, b) = self.read_slice(len, start)?;
                token(TokenKind::String(Text::Span(a, b)))
            }
            0xa4 => {
                let v = self.read_u32_be(4, start)?;
                token(TokenKind::Number(Num::F32(f32::from_bits(v))))
            }
            0xa5 => {
                let hi = self.read_u32_be(4, start)?;
                let lo = self.read_u32_be(4, start)?;
                token(TokenKind::Number(Num::F64(f64::from_bits((u64::from(hi) << 32) | u64::from(lo)))))
            }
            // An encoded request: 0246 then the request's one-byte code.
            0xa6 => {
                let c = self.read_u32_be(1, start)? as usize;
                match self.tables.requests.get(c).and_then(Option::as_ref) {
                    Some(name) => token(TokenKind::Request(Text::Shared(name.clone()))),
                    None => Err(self.err(start, format!("encoded request {c} was never defined"))),
                }
            }
            // Float arrays: 0310 + l, an (l+1)-byte length, then that many IEEE floats. The
            // elements are delivered as separate number tokens between array brackets.
            0xc8..=0xcb => {
                let len = self.read_u32_be(usize::from(code - 0xc8) + 1, start)? as usize;
                if len.saturating_mul(4) > self.end - self.pos {
                    self.pos = self.end;
                    return Err(self.err(start, format!("binary float array of {len} values cut short")));
                }
                self.array_remaining = Some(len);
                token(TokenKind::ArrayBegin)
            }
            // Request definition: 0314, a one-byte code, then a string.
            0xcc => {
                let c = self.read_u32_be(1, start)? as usize;
                let name = self.definition_string(start)?;
                if name.is_empty() {
                    return Err(self.err(start, "empty request name in an encoded request definition"));
                }
                if self.tables.requests.len() <= c {
                    self.tables.requests.resize(c + 1, None);
                }
                self.tables.requests[c] = Some(name);
                Ok(None)
            }
            // String definition: 0315 + w, a (w+1)-byte token, then a string.
            0xcd | 0xce => {
                let t = self.read_u32_be(usize::from(code - 0xcd) + 1, start)?;
                let value = self.definition_string(start)?;
                if self.tables.strings.len() >= MAX_DEFINED_STRINGS && !self.tables.strings.contains_key(&t) {
                    return Err(self.err(start, "too many defined binary string tokens"));
                }
                self.tables.strings.insert(t, value);
                Ok(None)
            }
            // String reference: 0317 + w, a (w+1)-byte token.
            0xcf | 0xd0 => {
                let t = self.read_u32_be(usize::from(code - 0xcf) + 1, start)?;
                match self.tables.strings.get(&t) {
                    Some(s) => token(TokenKind::String(Text::Shared(s.clone()))),
                    None => Err(self.err(start, format!("binary string token {t} was never defined"))),
                }
            }
            _ => Err(self.err(start, format!("reserved binary code 0{code:o}"))),
        }
    }

    /// The string operand of a binary definition (encoded or quoted ASCII).
    /// Only a string may follow (ASCII, encoded, or a defined string token): another
    /// definition there is an error, so nested definitions cannot recurse without bound.
    pub(super) fn definition_string(&mut self, start: usize) -> Result<Arc<[u8]>, LexError> {
        let mut i = self.pos;
        while i < self.end && matches!(self.bytes[i], b' ' | b'\t' | b'\n' | b'\r' | 0x0b | 0x0c) {
            i += 1;
        }
        self.pos = i;
        let token = match self.bytes.get(i).filter(|_| i < self.end) {
            Some(b'"') => self.scan_string(i)?,
            Some(0x90..=0xa3 | 0xcf | 0xd0) => match self.scan_binary(i)? {
                Some(t) => t,
                None => return Err(self.err(start, "a binary definition is not followed by a string")),
            },
            _ => return Err(self.err(start, "a binary definition is not followed by a string")),
        };
        match token.kind {
            TokenKind::String(text) => Ok(Arc::from(text.bytes(&self.bytes))),
            _ => Err(self.err(start, "a binary definition is not followed by a string")),
        }
    }
}
