//! The RIB tokenizer: ASCII and binary encodings (RISpec 3.2 Appendix C), freely intermixed.
//!
//! Bytes below 0200 (octal) are ASCII RIB: barewords (request names), numbers, quoted strings,
//! `[` `]`, whitespace and `#` comments. Bytes 0200 and above start a binary token: integers and
//! fixed-point numbers, strings, IEEE floats, float arrays, encoded requests and defined string
//! tokens. Every token carries the byte offset it starts at; the parser turns offsets into
//! `file:line:col` only when it needs a location.
//!
//! Numbers are scanned once into a decimal mantissa and exponent and converted on demand into the
//! type the request expects (`f32` for geometry, `f64` for transforms and camera values, `i32`
//! for counts and indices), each conversion correctly rounded.

mod binary;

pub(crate) use binary::BinaryTables;
use std::sync::Arc;

/// Bytes of a string or request name: a span of the source, or bytes the lexer made (escapes,
/// defined binary strings).
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Text {
    Span(usize, usize),
    Shared(Arc<[u8]>),
    Owned(Vec<u8>),
}

impl Text {
    pub(crate) fn bytes<'a>(&'a self, src: &'a [u8]) -> &'a [u8] {
        match self {
            Text::Span(a, b) => &src[*a..*b],
            Text::Shared(s) => s,
            Text::Owned(v) => v,
        }
    }
}

/// A number as written. ASCII numbers keep their decimal mantissa and exponent (and their text
/// for the rare conversions that need a full parse); binary numbers are already decoded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Num {
    Decimal {
        negative: bool,
        mantissa: u64,
        exp10: i32,
        /// Written without `.` or exponent.
        integer: bool,
        /// `mantissa * 10^exp10` is the exact value (no digits were dropped).
        exact: bool,
        start: usize,
        end: usize,
    },
    Int(i32),
    F32(f32),
    F64(f64),
}

const POW10_F32: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];
const POW10_F64: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18,
    1e19, 1e20, 1e21, 1e22,
];

impl Num {
    /// The value rounded once to `f32`.
    #[inline]
    pub(crate) fn to_f32(self, src: &[u8]) -> f32 {
        match self {
            Num::Decimal { negative, mantissa, exp10, exact, start, end, .. } => {
                // Clinger's fast path: the mantissa and the power of ten are exact in f32, so one
                // correctly rounded operation gives the correctly rounded result.
                if exact && mantissa <= 1 << 24 && (-10..=10).contains(&exp10) {
                    let m = mantissa as f32;
                    let v = if exp10 >= 0 {
                        m * POW10_F32[exp10 as usize]
                    } else {
                        m / POW10_F32[(-exp10) as usize]
                    };
                    if negative { -v } else { v }
                } else {
                    parse_slow(&src[start..end])
                }
            }
            Num::Int(i) => i as f32,
            Num::F32(f) => f,
            Num::F64(f) => f as f32,
        }
    }

    /// The value rounded once to `f64`.
    #[inline]
    pub(crate) fn to_f64(self, src: &[u8]) -> f64 {
        match self {
            Num::Decimal { negative, mantissa, exp10, exact, start, end, .. } => {
                if exact && mantissa <= 1 << 53 && (-22..=22).contains(&exp10) {
                    let m = mantissa as f64;
                    let v = if exp10 >= 0 {
                        m * POW10_F64[exp10 as usize]
                    } else {
                        m / POW10_F64[(-exp10) as usize]
                    };
                    if negative { -v } else { v }
                } else {
                    parse_slow(&src[start..end])
                }
            }
            Num::Int(i) => f64::from(i),
            Num::F32(f) => f64::from(f),
            Num::F64(f) => f,
        }
    }

    /// The value as an integer: integers as written, and floats with an integral value (binary
    /// writers sometimes encode counts as floats).
    #[inline]
    pub(crate) fn to_i32(self, src: &[u8]) -> Option<i32> {
        match self {
            Num::Decimal { negative, mantissa, integer: true, exact: true, .. } => {
                let v = i64::try_from(mantissa).ok()?;
                i32::try_from(if negative { -v } else { v }).ok()
            }
            Num::Int(i) => Some(i),
            other => {
                let f = other.to_f64(src);
                (f.fract() == 0.0 && f >= f64::from(i32::MIN) && f <= f64::from(i32::MAX)).then_some(f as i32)
            }
        }
    }
}

/// The full (correctly rounded) conversion for numbers the fast path cannot take: more than
/// 7 (f32) or 15 (f64) significant digits, or large exponents. The lexer only makes number
/// tokens of ASCII digits, signs, `.` and exponents, which `str::parse` accepts.
#[cold]
#[inline(never)]
fn parse_slow<T: std::str::FromStr + From<f32>>(text: &[u8]) -> T {
    std::str::from_utf8(text).ok().and_then(|t| t.parse().ok()).unwrap_or(T::from(f32::NAN))
}

#[derive(Clone, Debug, PartialEq)]
pub(crate) enum TokenKind {
    Request(Text),
    String(Text),
    Number(Num),
    ArrayBegin,
    ArrayEnd,
    Eof,
}

#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Token {
    pub kind: TokenKind,
    /// Byte offset of the first byte of the token.
    pub start: usize,
}

/// How [`Lexer::read_number_array`] stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ArrayRead {
    /// The array is complete (its `]` is consumed).
    Closed,
    /// Something else comes next; the general path takes over.
    Interrupted,
}

/// A byte sequence that is not a token. The lexer has already skipped past it.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct LexError {
    pub offset: usize,
    pub message: String,
}

pub(crate) struct Lexer {
    bytes: Arc<Vec<u8>>,
    pos: usize,
    end: usize,
    tables: BinaryTables,
    /// Elements left in a binary float array being delivered one token at a time.
    array_remaining: Option<usize>,
    peeked: std::collections::VecDeque<Result<Token, LexError>>,
}

fn is_delimiter(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | b'\r' | 0x0b | 0x0c | b'[' | b']' | b'"' | b'#') || b >= 0x80
}

impl Lexer {
    pub(crate) fn new(bytes: Arc<Vec<u8>>) -> Lexer {
        let end = bytes.len();
        Lexer::with_range(bytes, 0, end, BinaryTables::default())
    }

    /// A lexer over `bytes[start..end]` (an inline archive) with the binary definitions that were
    /// in effect where the range starts.
    pub(crate) fn with_range(bytes: Arc<Vec<u8>>, start: usize, end: usize, tables: BinaryTables) -> Lexer {
        let end = end.min(bytes.len());
        Lexer { bytes, pos: start.min(end), end, tables, array_remaining: None, peeked: Default::default() }
    }

    pub(crate) fn bytes(&self) -> &Arc<Vec<u8>> {
        &self.bytes
    }

    pub(crate) fn tables(&self) -> &BinaryTables {
        &self.tables
    }

    pub(crate) fn next(&mut self) -> Result<Token, LexError> {
        match self.peeked.pop_front() {
            Some(t) => t,
            None => self.scan(),
        }
    }

    /// Puts a token back: the next `next` returns it.
    pub(crate) fn unread(&mut self, token: Token) {
        self.peeked.push_front(Ok(token));
    }

    /// The token `n` places ahead (0 is the next one), without consuming it.
    pub(crate) fn peek(&mut self, n: usize) -> &Result<Token, LexError> {
        while self.peeked.len() <= n {
            let t = self.scan();
            self.peeked.push_back(t);
        }
        &self.peeked[n]
    }

    /// The fast path for the elements of a number array whose `[` was read: converts numbers
    /// straight into `out` up to and including the closing `]` (or the end of a binary float
    /// array). Stops before anything else (another token, a number `convert` refuses, `max`
    /// elements), leaving it to the caller's general path.
    pub(crate) fn read_number_array<T>(
        &mut self,
        out: &mut Vec<T>,
        max: usize,
        convert: impl Fn(Num, &[u8]) -> Option<T>,
    ) -> Result<ArrayRead, LexError> {
        if !self.peeked.is_empty() {
            return Ok(ArrayRead::Interrupted);
        }
        loop {
            if out.len() >= max {
                return Ok(ArrayRead::Interrupted);
            }
            if let Some(remaining) = self.array_remaining {
                let take = remaining.min(max - out.len());
                out.reserve(take);
                for k in 0..take {
                    let at = self.pos;
                    let word = [self.bytes[at], self.bytes[at + 1], self.bytes[at + 2], self.bytes[at + 3]];
                    match convert(Num::F32(f32::from_be_bytes(word)), &self.bytes) {
                        Some(v) => out.push(v),
                        None => {
                            self.array_remaining = Some(remaining - k);
                            return Ok(ArrayRead::Interrupted);
                        }
                    }
                    self.pos += 4;
                }
                if take < remaining {
                    self.array_remaining = Some(remaining - take);
                    return Ok(ArrayRead::Interrupted);
                }
                self.array_remaining = None;
                return Ok(ArrayRead::Closed);
            }
            let (i, b) = {
                let bytes = &*self.bytes;
                let mut i = self.pos;
                loop {
                    while i < self.end && matches!(bytes[i], b' ' | b'\t' | b'\n' | b'\r' | 0x0b | 0x0c) {
                        i += 1;
                    }
                    if i < self.end && bytes[i] == b'#' {
                        while i < self.end && bytes[i] != b'\n' && bytes[i] != b'\r' {
                            i += 1;
                        }
                        continue;
                    }
                    break;
                }
                self.pos = i;
                if i >= self.end {
                    return Ok(ArrayRead::Interrupted);
                }
                (i, bytes[i])
            };
            let token = match b {
                b']' => {
                    self.pos = i + 1;
                    return Ok(ArrayRead::Closed);
                }
                b'0'..=b'9' | b'-' | b'+' | b'.' => {
                    let n = self.lex_number(i)?;
                    match convert(n, &self.bytes) {
                        Some(v) => {
                            out.push(v);
                            continue;
                        }
                        None => Token { kind: TokenKind::Number(n), start: i },
                    }
                }
                // Binary integers and floats, decoded in place (meshes written in binary RIB
                // hold millions of them).
                0x80..=0x83 | 0xa4 if i + 5 <= self.end => {
                    let n = if b == 0xa4 {
                        let w = [self.bytes[i + 1], self.bytes[i + 2], self.bytes[i + 3], self.bytes[i + 4]];
                        self.pos = i + 5;
                        Num::F32(f32::from_be_bytes(w))
                    } else {
                        let len = usize::from(b - 0x80) + 1;
                        let mut v: u32 = 0;
                        for k in 0..len {
                            v = (v << 8) | u32::from(self.bytes[i + 1 + k]);
                        }
                        let shift = 32 - 8 * len as u32;
                        self.pos = i + 1 + len;
                        Num::Int(((v << shift) as i32) >> shift)
                    };
                    match convert(n, &self.bytes) {
                        Some(v) => {
                            out.push(v);
                            continue;
                        }
                        None => Token { kind: TokenKind::Number(n), start: i },
                    }
                }
                0x80.. => match self.scan_binary(i)? {
                    Some(t) => t,
                    None => continue,
                },
                _ => return Ok(ArrayRead::Interrupted),
            };
            match token.kind {
                TokenKind::Number(n) => match convert(n, &self.bytes) {
                    Some(v) => out.push(v),
                    None => {
                        self.unread(token);
                        return Ok(ArrayRead::Interrupted);
                    }
                },
                _ => {
                    self.unread(token);
                    return Ok(ArrayRead::Interrupted);
                }
            }
        }
    }

    fn err(&self, offset: usize, message: impl Into<String>) -> LexError {
        LexError { offset, message: message.into() }
    }

    fn scan(&mut self) -> Result<Token, LexError> {
        if let Some(remaining) = self.array_remaining {
            let start = self.pos;
            if remaining == 0 {
                self.array_remaining = None;
                return Ok(Token { kind: TokenKind::ArrayEnd, start });
            }
            self.array_remaining = Some(remaining - 1);
            let v = self.read_u32_be(4, start)?;
            return Ok(Token { kind: TokenKind::Number(Num::F32(f32::from_bits(v))), start });
        }
        loop {
            // Skip whitespace; `i` is the first byte of a token or comment.
            let (i, b) = {
                let bytes = &*self.bytes;
                let mut i = self.pos;
                while i < self.end && matches!(bytes[i], b' ' | b'\t' | b'\n' | b'\r' | 0x0b | 0x0c) {
                    i += 1;
                }
                if i >= self.end {
                    self.pos = self.end;
                    return Ok(Token { kind: TokenKind::Eof, start: self.end });
                }
                (i, bytes[i])
            };
            self.pos = i;
            match b {
                b'#' => {
                    let bytes = &*self.bytes;
                    let mut j = i;
                    while j < self.end && bytes[j] != b'\n' && bytes[j] != b'\r' {
                        j += 1;
                    }
                    self.pos = j;
                }
                b'[' => {
                    self.pos = i + 1;
                    return Ok(Token { kind: TokenKind::ArrayBegin, start: i });
                }
                b']' => {
                    self.pos = i + 1;
                    return Ok(Token { kind: TokenKind::ArrayEnd, start: i });
                }
                b'"' => return self.scan_string(i),
                b'0'..=b'9' | b'-' | b'+' | b'.' => return self.scan_number(i),
                0x80.. => {
                    if let Some(t) = self.scan_binary(i)? {
                        return Ok(t);
                    }
                    // A definition (request or string token): no token produced, go on.
                }
                0x21..=0x7e => {
                    let bytes = &*self.bytes;
                    let mut j = i + 1;
                    while j < self.end && (0x21..0x7f).contains(&bytes[j]) && !is_delimiter(bytes[j]) {
                        j += 1;
                    }
                    self.pos = j;
                    return Ok(Token { kind: TokenKind::Request(Text::Span(i, j)), start: i });
                }
                _ => {
                    self.pos = i + 1;
                    return Err(
                        self.err(i, format!("unexpected byte 0x{b:02x} (not RIB text or a binary token)"))
                    );
                }
            }
        }
    }

    fn skip_to_delimiter(&mut self, mut i: usize) {
        while i < self.end && !is_delimiter(self.bytes[i]) {
            i += 1;
        }
        self.pos = i;
    }

    fn scan_number(&mut self, start: usize) -> Result<Token, LexError> {
        let n = self.lex_number(start)?;
        Ok(Token { kind: TokenKind::Number(n), start })
    }

    /// Scans an ASCII number starting at `start` into its decimal mantissa and exponent.
    #[inline]
    fn lex_number(&mut self, start: usize) -> Result<Num, LexError> {
        let bytes = &*self.bytes;
        let end = self.end;
        let mut i = start;
        let negative = bytes[i] == b'-';
        if bytes[i] == b'-' || bytes[i] == b'+' {
            i += 1;
        }
        let mut mantissa: u64 = 0;
        let mut exp10: i32 = 0;
        let mut exact = true;
        let mut any_digit = false;
        let mut integer = true;
        while i < end && bytes[i].is_ascii_digit() {
            any_digit = true;
            let d = u64::from(bytes[i] - b'0');
            if mantissa < (u64::MAX - 9) / 10 {
                mantissa = mantissa * 10 + d;
            } else {
                exact = false;
                exp10 = exp10.saturating_add(1);
            }
            i += 1;
        }
        if i < end && bytes[i] == b'.' {
            integer = false;
            i += 1;
            while i < end && bytes[i].is_ascii_digit() {
                any_digit = true;
                let d = u64::from(bytes[i] - b'0');
                if mantissa < (u64::MAX - 9) / 10 {
                    mantissa = mantissa * 10 + d;
                    exp10 -= 1;
                } else if d != 0 {
                    exact = false;
                }
                i += 1;
            }
        }
        if !any_digit {
            self.skip_to_delimiter(i);
            let text = String::from_utf8_lossy(&self.bytes[start..self.pos]).into_owned();
            return Err(self.err(start, format!("'{text}' is not a number")));
        }
        if i < end && (bytes[i] == b'e' || bytes[i] == b'E') {
            integer = false;
            i += 1;
            let mut exp_negative = false;
            if i < end && (bytes[i] == b'-' || bytes[i] == b'+') {
                exp_negative = bytes[i] == b'-';
                i += 1;
            }
            let exp_start = i;
            let mut e: i32 = 0;
            while i < end && bytes[i].is_ascii_digit() {
                e = e.saturating_mul(10).saturating_add(i32::from(bytes[i] - b'0'));
                i += 1;
            }
            if i == exp_start {
                self.skip_to_delimiter(i);
                let text = String::from_utf8_lossy(&self.bytes[start..self.pos]).into_owned();
                return Err(self.err(start, format!("'{text}' is not a number (exponent without digits)")));
            }
            exp10 = exp10.saturating_add(if exp_negative { -e } else { e });
        }
        if i < end && !is_delimiter(bytes[i]) {
            self.skip_to_delimiter(i);
            let text = String::from_utf8_lossy(&self.bytes[start..self.pos]).into_owned();
            return Err(self.err(start, format!("'{text}' is not a number")));
        }
        self.pos = i;
        Ok(Num::Decimal { negative, mantissa, exp10, integer, exact, start, end: i })
    }

    fn scan_string(&mut self, start: usize) -> Result<Token, LexError> {
        let bytes = &*self.bytes;
        let mut i = start + 1;
        // Fast path: no escapes and no carriage returns.
        while i < self.end {
            match bytes[i] {
                b'"' => {
                    self.pos = i + 1;
                    return Ok(Token { kind: TokenKind::String(Text::Span(start + 1, i)), start });
                }
                b'\\' | b'\r' => break,
                _ => i += 1,
            }
        }
        let mut out = bytes[start + 1..i].to_vec();
        while i < self.end {
            let b = bytes[i];
            i += 1;
            match b {
                b'"' => {
                    self.pos = i;
                    return Ok(Token { kind: TokenKind::String(Text::Owned(out)), start });
                }
                b'\r' => {
                    if i < self.end && bytes[i] == b'\n' {
                        i += 1;
                    }
                    out.push(b'\n');
                }
                b'\\' => {
                    let Some(&e) = bytes.get(i).filter(|_| i < self.end) else { break };
                    i += 1;
                    match e {
                        b'n' => out.push(b'\n'),
                        b'r' => out.push(b'\r'),
                        b't' => out.push(b'\t'),
                        b'b' => out.push(0x08),
                        b'f' => out.push(0x0c),
                        b'0'..=b'7' => {
                            let mut v = u32::from(e - b'0');
                            for _ in 0..2 {
                                match bytes.get(i) {
                                    Some(&d @ b'0'..=b'7') if i < self.end => {
                                        v = v * 8 + u32::from(d - b'0');
                                        i += 1;
                                    }
                                    _ => break,
                                }
                            }
                            out.push((v & 0xff) as u8);
                        }
                        // A backslash before a line ending continues the string on the next line.
                        b'\n' => {}
                        b'\r' => {
                            if i < self.end && bytes[i] == b'\n' {
                                i += 1;
                            }
                        }
                        other => out.push(other),
                    }
                }
                other => out.push(other),
            }
        }
        self.pos = self.end;
        Err(self.err(start, "unterminated string (no closing '\"' before the end of the file)"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lex(src: &[u8]) -> (Vec<Result<TokenKind, String>>, Arc<Vec<u8>>) {
        let bytes = Arc::new(src.to_vec());
        let mut l = Lexer::new(bytes.clone());
        let mut out = Vec::new();
        loop {
            match l.next() {
                Ok(Token { kind: TokenKind::Eof, .. }) => break,
                Ok(t) => out.push(Ok(t.kind)),
                Err(e) => out.push(Err(e.message)),
            }
            assert!(out.len() < 1000);
        }
        (out, bytes)
    }

    fn floats(src: &str) -> Vec<f32> {
        let (toks, bytes) = lex(src.as_bytes());
        toks.into_iter()
            .map(|t| match t {
                Ok(TokenKind::Number(n)) => n.to_f32(&bytes),
                other => panic!("not a number: {other:?}"),
            })
            .collect()
    }

    #[test]
    fn numbers_in_every_written_form() {
        assert_eq!(
            floats(".5 1. 1e30 -0 -.75 +2 0.80000000000000004 1E-3"),
            vec![0.5, 1.0, 1e30, -0.0, -0.75, 2.0, 0.8, 1e-3]
        );
        assert!(floats("-0")[0].is_sign_negative());
    }

    #[test]
    fn float_conversion_is_correctly_rounded() {
        for text in ["0.1", "3.14159265358979", "123456789", "1.17549435e-38", "3.4028235e38", "0.000001"] {
            let (toks, bytes) = lex(text.as_bytes());
            let Ok(TokenKind::Number(n)) = &toks[0] else { panic!() };
            assert_eq!(n.to_f32(&bytes), text.parse::<f32>().unwrap(), "{text}");
            assert_eq!(n.to_f64(&bytes), text.parse::<f64>().unwrap(), "{text}");
        }
    }

    #[test]
    fn integers_and_integral_floats() {
        let (toks, bytes) = lex(b"42 -7 3.0 2147483648 1.5");
        let ints: Vec<Option<i32>> = toks
            .iter()
            .map(|t| match t {
                Ok(TokenKind::Number(n)) => n.to_i32(&bytes),
                _ => panic!(),
            })
            .collect();
        assert_eq!(ints, vec![Some(42), Some(-7), Some(3), None, None]);
    }

    #[test]
    fn strings_escapes_and_line_spanning() {
        let (toks, bytes) = lex(b"\"a\\\"b\\n\\101\\\nc\" \"two\r\nlines\"");
        let strs: Vec<Vec<u8>> = toks
            .iter()
            .map(|t| match t {
                Ok(TokenKind::String(s)) => s.bytes(&bytes).to_vec(),
                _ => panic!(),
            })
            .collect();
        assert_eq!(strs, vec![b"a\"b\nAc".to_vec(), b"two\nlines".to_vec()]);
    }

    #[test]
    fn tokens_without_whitespace_and_comments_in_arrays() {
        let (toks, bytes) = lex(b"Surface\"plastic\"\"Ks\"[0.8]\"Ka\"[.5 # comment ]\n 1]#end");
        let kinds: Vec<String> = toks
            .iter()
            .map(|t| match t {
                Ok(TokenKind::Request(s)) => format!("R:{}", String::from_utf8_lossy(s.bytes(&bytes))),
                Ok(TokenKind::String(s)) => format!("S:{}", String::from_utf8_lossy(s.bytes(&bytes))),
                Ok(TokenKind::Number(n)) => format!("N:{}", n.to_f32(&bytes)),
                Ok(TokenKind::ArrayBegin) => "[".into(),
                Ok(TokenKind::ArrayEnd) => "]".into(),
                other => format!("{other:?}"),
            })
            .collect();
        assert_eq!(
            kinds,
            ["R:Surface", "S:plastic", "S:Ks", "[", "N:0.8", "]", "S:Ka", "[", "N:0.5", "N:1", "]"]
        );
    }

    #[test]
    fn bad_tokens_are_errors_and_lexing_goes_on() {
        let (toks, _) = lex(b"set -x\nSphere 1.2.3 \"open");
        assert!(matches!(toks[0], Ok(TokenKind::Request(_))));
        assert_eq!(toks[1], Err("'-x' is not a number".into()));
        assert!(matches!(toks[2], Ok(TokenKind::Request(_))));
        assert_eq!(toks[3], Err("'1.2.3' is not a number".into()));
        assert!(toks[4].as_ref().unwrap_err().starts_with("unterminated string"));
    }

    #[test]
    fn binary_tokens() {
        // version 3.03 as fixed point (0212: 3 bytes, 2 after the point), a 2-byte integer 512,
        // a negative 1-byte integer, an IEEE float, a float array, a defined request and string.
        let mut src = b"version".to_vec();
        src.extend([0x8a, 0x03, 0x07, 0xae, 0x81, 0x02, 0x00, 0x80, 0xff, 0xa4, 0x3f, 0x80, 0, 0]);
        src.extend([0xc8, 0x02, 0x3f, 0x80, 0, 0, 0x40, 0, 0, 0]);
        src.extend([0xcc, 0x07, 0x96]);
        src.extend(b"Sphere");
        src.extend([0xa6, 0x07, 0xcd, 0x00, 0x92]);
        src.extend(b"lh");
        src.extend([0xcf, 0x00]);
        let (toks, bytes) = lex(&src);
        let n = |i: usize| match &toks[i] {
            Ok(TokenKind::Number(n)) => n.to_f64(&bytes),
            other => panic!("{other:?}"),
        };
        assert!((n(1) - 3.03).abs() < 1e-4);
        assert_eq!(n(2), 512.0);
        assert_eq!(n(3), -1.0);
        assert_eq!(n(4), 1.0);
        assert_eq!(toks[5], Ok(TokenKind::ArrayBegin));
        assert_eq!((n(6), n(7)), (1.0, 2.0));
        assert_eq!(toks[8], Ok(TokenKind::ArrayEnd));
        match &toks[9] {
            Ok(TokenKind::Request(t)) => assert_eq!(t.bytes(&bytes), b"Sphere"),
            other => panic!("{other:?}"),
        }
        match &toks[10] {
            Ok(TokenKind::String(t)) => assert_eq!(t.bytes(&bytes), b"lh"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn nested_binary_definitions_do_not_recurse() {
        // A million request definitions, each "defining" with another definition: an error at
        // once, not a stack overflow.
        let src: Vec<u8> = std::iter::repeat_n([0xcc, 0x01], 1_000_000).flatten().collect();
        let mut l = Lexer::new(Arc::new(src));
        let first = l.next();
        assert!(first.as_ref().unwrap_err().message.contains("not followed by a string"), "{first:?}");
        let mut errors = 1;
        while !matches!(l.next(), Ok(Token { kind: TokenKind::Eof, .. })) {
            errors += 1;
        }
        assert!(errors <= 1_000_000);
    }

    #[test]
    fn truncated_and_undefined_binary_is_an_error() {
        let (toks, _) = lex(&[0xa6, 0x05]);
        assert_eq!(toks, vec![Err("encoded request 5 was never defined".into())]);
        let (toks, _) = lex(&[0xc8, 0xff, 0, 0]);
        assert!(toks[0].as_ref().unwrap_err().contains("cut short"));
        let (toks, _) = lex(&[0x83, 0, 0]);
        assert!(toks[0].as_ref().unwrap_err().contains("cut short"));
        let (toks, _) = lex(&[0xd5]);
        assert!(toks[0].as_ref().unwrap_err().contains("reserved"));
    }
}
