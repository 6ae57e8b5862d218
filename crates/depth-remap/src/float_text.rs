//! Fast, exact text for `f32` depth values.
//!
//! **Writing.** [`push_f32`] writes the shortest decimal that reads back as the same `f32`
//! (Steele & White / Ryu's definition: fewest significant digits, and of those the one nearest
//! the value; an exact tie between two nearest rounds up, as std does). The notation is Rust's `{}` (plain decimal, as std prints it) when the decimal
//! exponent of the first digit is in `-4..16`, and Rust's `{:e}` (`1.5e-7`) outside that range,
//! like Python's `repr`; so a 1000-unit depth is `1000`, never `1e3`, and a `1e-30` is not
//! thirty zeros long. std's formatting is already shortest-round-trip but costs about 75 ns
//! per value here (about 125 MB/s); the common range (`4e-22 <= v < 3.3e7`) takes an exact
//! integer path instead: the value and the midpoints to its neighbours are scaled by a power
//! of ten in `u128` arithmetic (no approximation, so no table of precomputed powers), then
//! digits are removed while the interval still contains a shorter decimal, exactly as Ryu's
//! general case does. Values outside that range go through std. A test compares both paths
//! bit for bit against std over a sample of all `f32`s; `cargo xtask depth-exhaustive` does
//! every one.
//!
//! **Reading.** [`parse_f32_token`] reads one token of the depth-table grammar: `inf`
//! (case-insensitive, also `infinity`), or a non-negative decimal with optional fraction and
//! exponent. The fast path collects up to 19 significant digits into a `u64` and, when the
//! digits fit in 53 bits and the power of ten is at most 22, computes the correctly rounded
//! `f64` (Clinger's fast path); rounding that to `f32` is correct unless the `f64` lies exactly
//! on an `f32` rounding midpoint, which is checked, and then, like every other case, std's
//! correctly rounded parser decides.

use std::fmt::Write as _;

/// Powers of ten that fit in `u128` and are needed by the shortest-digits path (p <= 30).
const POW10_U128: [u128; 31] = {
    let mut table = [1u128; 31];
    let mut i = 1;
    while i < 31 {
        table[i] = table[i - 1] * 10;
        i += 1;
    }
    table
};

/// Exact powers of ten in `f64` (10^22 is the largest exactly representable).
const POW10_F64: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18,
    1e19, 1e20, 1e21, 1e22,
];

/// The shortest round-trip decimal of a positive finite `f32` as `(digits, exponent)`, value
/// `digits * 10^exponent`, for the range the exact integer path covers; `None` outside it.
fn shortest_digits(v: f32) -> Option<(u64, i32)> {
    let bits = v.to_bits();
    let ieee_exponent = (bits >> 23) & 0xff;
    let ieee_mantissa = bits & 0x7f_ffff;
    let (m2, e2) = if ieee_exponent == 0 {
        (ieee_mantissa, -149i32)
    } else {
        (ieee_mantissa | (1 << 23), ieee_exponent as i32 - 150)
    };
    // The value and the two midpoints to its neighbours, as multiples of 2^(e2 - 2). At a power
    // of two the lower neighbour is twice as close.
    let accept_bounds = m2 % 2 == 0;
    let lower_is_closer = ieee_mantissa == 0 && ieee_exponent > 1;
    let mv = 4 * u64::from(m2);
    let mp = mv + 2;
    let mm = mv - if lower_is_closer { 1 } else { 2 };
    let shift = 2 - e2;
    // Values >= 2^25 (shift <= 0) and tiny ones (10^p overflowing u128 below) go through std.
    if !(1..=96).contains(&shift) {
        return None;
    }
    let shift = shift as u32;
    // 10^p >= 10 * 2^shift, so the interval is at least 30 units wide at this scale and the
    // loop below removes at least one digit; mv * 10^p < 2^26 * 10^30 < 2^128.
    let p = ((shift * 78913) >> 18) + 2;
    let pow = POW10_U128[p as usize];
    let mask = (1u128 << shift) - 1;
    let scaled = |x: u64| {
        let product = u128::from(x) * pow;
        ((product >> shift) as u64, product & mask == 0)
    };
    let (mut vr, vr_exact) = scaled(mv);
    let (mut vp, vp_exact) = scaled(mp);
    let (mut vm, vm_exact) = scaled(mm);
    if vp_exact && !accept_bounds {
        vp -= 1;
    }
    let mut vm_is_trailing_zeros = accept_bounds && vm_exact;
    let vr_is_trailing_zeros = vr_exact;
    let mut removed = 0i32;
    let mut last_removed_digit = 0u64;
    let output = if vm_is_trailing_zeros || vr_is_trailing_zeros {
        while vp / 10 > vm / 10 {
            vm_is_trailing_zeros &= vm % 10 == 0;
            last_removed_digit = vr % 10;
            vr /= 10;
            vp /= 10;
            vm /= 10;
            removed += 1;
        }
        if vm_is_trailing_zeros {
            while vm % 10 == 0 {
                last_removed_digit = vr % 10;
                vr /= 10;
                vm /= 10;
                removed += 1;
            }
        }
        // Exactly half-way between two shortest candidates (the value ends in ...5 exactly):
        // round up, as std does (Ryu would round to even here; `23.2578125` is `23.257813` in
        // std and `23.257812` in Ryu, both shortest and both exact to read back).
        vr + u64::from((vr == vm && (!accept_bounds || !vm_is_trailing_zeros)) || last_removed_digit >= 5)
    } else {
        while vp / 10 > vm / 10 {
            last_removed_digit = vr % 10;
            vr /= 10;
            vp /= 10;
            vm /= 10;
            removed += 1;
        }
        vr + u64::from(vr == vm || last_removed_digit >= 5)
    };
    let mut digits = output;
    let mut exponent = removed - p as i32;
    while digits % 10 == 0 {
        digits /= 10;
        exponent += 1;
    }
    Some((digits, exponent))
}

const DIGIT_PAIRS: &[u8; 200] = b"0001020304050607080910111213141516171819\
2021222324252627282930313233343536373839\
4041424344454647484950515253545556575859\
6061626364656667686970717273747576777879\
8081828384858687888990919293949596979899";

/// Writes the `count` low decimal digits of `value` (zero-padded) to `text[end - count..end]`.
#[inline]
fn write_digits_at(mut value: u64, count: usize, text: &mut [u8; 32], end: usize) {
    let stop = end - count;
    let mut at = end;
    while at >= stop + 2 {
        let pair = (value % 100) as usize * 2;
        value /= 100;
        at -= 2;
        text[at] = DIGIT_PAIRS[pair];
        text[at + 1] = DIGIT_PAIRS[pair + 1];
    }
    if at > stop {
        text[at - 1] = b'0' + (value % 10) as u8;
    }
}

/// Whether a decimal whose first significant digit has exponent `x` is written plainly.
fn plain_notation(x: i32) -> bool {
    (-4..16).contains(&x)
}

/// Appends the shortest round-trip text of `v` (see the module doc): `inf` for +infinity,
/// `0` for zero. Negative values get a `-` and `NaN` is written as `nan`; a depth table never
/// holds either.
pub fn push_f32(out: &mut Vec<u8>, v: f32) {
    if v.is_nan() {
        out.extend_from_slice(b"nan");
        return;
    }
    if v.is_sign_negative() && v != 0.0 {
        out.push(b'-');
    }
    let v = v.abs();
    if v == 0.0 {
        out.push(b'0');
        return;
    }
    if v.is_infinite() {
        out.extend_from_slice(b"inf");
        return;
    }
    let Some((digits, exponent)) = shortest_digits(v) else {
        push_f32_std(out, v);
        return;
    };
    // Assemble the text in a local buffer and append a fixed 32 bytes, then cut back: a
    // fixed-size copy is inlined, a variable-length one is a call to memcpy per value.
    let mut text = [0u8; 32];
    let length = format_decimal(digits, exponent, &mut text);
    let start = out.len();
    out.extend_from_slice(&text);
    out.truncate(start + length);
}

/// Copies 16 bytes `source[from..from + 16]` to `text[at..at + 16]`. A fixed-size copy is two
/// register moves; copies of a variable number of bytes become calls to memcpy or memmove,
/// which cost more than the rest of the formatting.
#[inline]
fn copy16(text: &mut [u8; 32], at: usize, source: &[u8; 32], from: usize) {
    if let (Some(destination), Some(chunk)) = (text.get_mut(at..at + 16), source.get(from..from + 16)) {
        let chunk: &[u8; 16] = chunk.try_into().unwrap_or(&[b'0'; 16]);
        destination.copy_from_slice(chunk);
    }
}

/// Writes `digits * 10^exponent` in the notation of [`push_f32`] to the start of `text`;
/// returns the length. `digits` has at most 10 digits and the exponent is within f32's range,
/// so the longest text is 16 bytes (`1234567800000000`, the widest plain integer).
fn format_decimal(digits: u64, exponent: i32, text: &mut [u8; 32]) -> usize {
    let n = digits.ilog10() as usize + 1;
    let x = exponent + n as i32 - 1;
    // The digits left-aligned, followed by zeros (which serve as trailing zeros too).
    let mut all = [b'0'; 32];
    write_digits_at(digits, n, &mut all, n);
    if plain_notation(x) {
        if exponent >= 0 {
            copy16(text, 0, &all, 0);
            n + exponent as usize
        } else if x >= 0 {
            let integer = (x + 1) as usize;
            copy16(text, 0, &all, 0);
            text[integer] = b'.';
            copy16(text, integer + 1, &all, integer);
            n + 1
        } else {
            let zeros = (-x - 1) as usize;
            text[0] = b'0';
            text[1] = b'.';
            copy16(text, 2, &[b'0'; 32], 0);
            copy16(text, 2 + zeros, &all, 0);
            2 + zeros + n
        }
    } else {
        text[0] = all[0];
        let mut at = 1;
        if n > 1 {
            text[1] = b'.';
            copy16(text, 2, &all, 1);
            at = n + 1;
        }
        text[at] = b'e';
        at += 1;
        if x < 0 {
            text[at] = b'-';
            at += 1;
        }
        let e = x.unsigned_abs() as usize;
        let e_digits = if e >= 10 { 2 } else { 1 };
        write_digits_at(e as u64, e_digits, text, at + e_digits);
        at + e_digits
    }
}

/// The same text through std's formatter (shortest round-trip digits, Grisu with a Dragon
/// fallback): the reference for [`push_f32`] and its path for values outside the fast range.
pub fn push_f32_std(out: &mut Vec<u8>, v: f32) {
    let mut text = String::with_capacity(24);
    // Writing to a String cannot fail.
    let _ = write!(text, "{v:e}");
    let x: i32 = text.rsplit_once('e').and_then(|(_, e)| e.parse().ok()).unwrap_or(0);
    if plain_notation(x) && v.is_finite() {
        text.clear();
        let _ = write!(text, "{v}");
    }
    out.extend_from_slice(text.as_bytes());
}

/// `f32` text of `v` as a `String` (see [`push_f32`]).
pub fn f32_to_text(v: f32) -> String {
    let mut out = Vec::with_capacity(16);
    push_f32(&mut out, v);
    // push_f32 writes ASCII only.
    String::from_utf8(out).unwrap_or_default()
}

/// Why a token is not a depth value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TokenError {
    /// Not a decimal number or `inf`.
    Malformed,
    /// `nan` in any case.
    NotANumber,
    /// A negative number (including `-inf`). `-0` is zero and accepted.
    Negative,
    /// A finite decimal beyond the largest `f32` (it would read as a miss).
    OutOfRange,
}

/// Whether `b` ends a token: a separator or the end of a line.
#[inline]
pub fn is_token_end(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | b'\r')
}

/// Reads the depth value at the start of `bytes` (a token ends at a space, tab, CR, LF or the
/// end of `bytes`). Returns the value and the token length; on error the token length is still
/// returned so that the caller can quote it.
#[inline]
pub fn parse_f32_token(bytes: &[u8]) -> (Result<f32, TokenError>, usize) {
    let mut i = 0;
    let len = bytes.len();
    let mut negative = false;
    if i < len && (bytes[i] == b'+' || bytes[i] == b'-') {
        negative = bytes[i] == b'-';
        i += 1;
    }
    let mut mantissa: u64 = 0;
    let mut significant = 0u32;
    let mut exponent: i64 = 0;
    let mut any_digit = false;
    let mut truncated = false;
    while i < len && bytes[i].is_ascii_digit() {
        let d = u64::from(bytes[i] - b'0');
        any_digit = true;
        if significant < 19 {
            if mantissa != 0 || d != 0 {
                mantissa = mantissa * 10 + d;
                significant += u32::from(mantissa != 0);
            }
        } else {
            exponent += 1;
            truncated |= d != 0;
        }
        i += 1;
    }
    if i < len && bytes[i] == b'.' {
        i += 1;
        while i < len && bytes[i].is_ascii_digit() {
            let d = u64::from(bytes[i] - b'0');
            any_digit = true;
            if significant < 19 {
                if mantissa != 0 || d != 0 {
                    mantissa = mantissa * 10 + d;
                    significant += 1;
                }
                exponent -= 1;
            } else {
                truncated |= d != 0;
            }
            i += 1;
        }
    }
    if !any_digit {
        return parse_word(bytes, negative);
    }
    if i < len && (bytes[i] == b'e' || bytes[i] == b'E') {
        i += 1;
        let mut exponent_negative = false;
        if i < len && (bytes[i] == b'+' || bytes[i] == b'-') {
            exponent_negative = bytes[i] == b'-';
            i += 1;
        }
        let start = i;
        let mut e: i64 = 0;
        while i < len && bytes[i].is_ascii_digit() {
            // Saturate: any exponent beyond this is zero or overflow either way.
            e = (e * 10 + i64::from(bytes[i] - b'0')).min(1 << 20);
            i += 1;
        }
        if i == start {
            return (Err(TokenError::Malformed), token_length(bytes));
        }
        exponent += if exponent_negative { -e } else { e };
    }
    if i < len && !is_token_end(bytes[i]) {
        return (Err(TokenError::Malformed), token_length(bytes));
    }
    if mantissa == 0 {
        // Zero, whatever the sign or exponent (also when only zeros were dropped).
        if !truncated {
            return (Ok(0.0), i);
        }
    } else if negative {
        return (Err(TokenError::Negative), i);
    }
    if !truncated && mantissa < (1 << 53) && (-22..=22).contains(&exponent) {
        let m = mantissa as f64;
        let r = if exponent >= 0 {
            m * POW10_F64[exponent as usize]
        } else {
            m / POW10_F64[(-exponent) as usize]
        };
        // r is the correctly rounded f64. Rounding it to f32 is correct unless it lies exactly on
        // an f32 midpoint (the low 29 of its 52 mantissa bits are 1000...0), within f32's normal
        // range.
        if (f64::from(f32::MIN_POSITIVE)..=f64::from(f32::MAX)).contains(&r)
            && r.to_bits() & ((1 << 29) - 1) != 1 << 28
        {
            return (Ok(r as f32), i);
        }
    }
    parse_std(&bytes[..i], negative)
}

/// The slow path: std's correctly rounded parser on the whole token.
#[cold]
fn parse_std(token: &[u8], negative: bool) -> (Result<f32, TokenError>, usize) {
    let length = token.len();
    let parsed = std::str::from_utf8(token).ok().and_then(|t| t.parse::<f32>().ok());
    let result = match parsed {
        None => Err(TokenError::Malformed),
        Some(0.0) => Ok(0.0),
        Some(_) if negative => Err(TokenError::Negative),
        Some(v) if v.is_infinite() => Err(TokenError::OutOfRange),
        Some(v) => Ok(v),
    };
    (result, length)
}

/// `inf`, `infinity` (any case, optionally signed) and `nan`.
#[cold]
fn parse_word(bytes: &[u8], negative: bool) -> (Result<f32, TokenError>, usize) {
    let length = token_length(bytes);
    let sign = usize::from(bytes.first().is_some_and(|b| *b == b'+' || *b == b'-'));
    let word = &bytes[sign..length];
    let result = if word.eq_ignore_ascii_case(b"inf") || word.eq_ignore_ascii_case(b"infinity") {
        if negative { Err(TokenError::Negative) } else { Ok(f32::INFINITY) }
    } else if word.eq_ignore_ascii_case(b"nan") {
        Err(TokenError::NotANumber)
    } else {
        Err(TokenError::Malformed)
    };
    (result, length)
}

/// Length of the token at the start of `bytes`.
#[inline]
pub fn token_length(bytes: &[u8]) -> usize {
    bytes.iter().position(|&b| is_token_end(b)).unwrap_or(bytes.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn std_text(v: f32) -> String {
        let mut out = Vec::new();
        push_f32_std(&mut out, v);
        String::from_utf8(out).unwrap()
    }

    /// Every `stride`-th positive finite f32 (plus its neighbours at the interesting edges).
    fn sample(stride: u32) -> impl Iterator<Item = f32> {
        (1..0x7f80_0000u32).step_by(stride as usize).map(f32::from_bits)
    }

    #[test]
    fn std_display_is_shortest_round_trip() {
        // The premise of the writer: std's `{}` / `{:e}` give digits that read back exactly and
        // that no shorter decimal does (checked here by trying one digit fewer).
        for v in sample(104_729) {
            let text = std_text(v);
            assert_eq!(text.parse::<f32>().unwrap(), v, "{text}");
            let e = format!("{v:e}");
            let (mantissa, exponent) = e.split_once('e').unwrap();
            let digits: String = mantissa.chars().filter(char::is_ascii_digit).collect();
            if digits.len() > 1 {
                let shorter = format!("{:.*e}", digits.len() - 2, v);
                assert_ne!(shorter.parse::<f32>().unwrap(), v, "{shorter} also reads as {e}");
            }
            let _ = exponent;
        }
    }

    #[test]
    fn fast_writer_matches_std_on_a_sample_of_all_f32() {
        for v in sample(7_919) {
            let mut fast = Vec::new();
            push_f32(&mut fast, v);
            assert_eq!(std::str::from_utf8(&fast).unwrap(), std_text(v), "bits {:#x}", v.to_bits());
        }
    }

    #[test]
    fn fast_writer_matches_std_at_edges() {
        let mut values = vec![
            f32::MIN_POSITIVE,
            f32::MAX,
            f32::EPSILON,
            1.0,
            0.1,
            0.3,
            1e-4,
            9.9999e-5,
            1e16,
            9.999999e15,
            33554432.0,
            33554430.0,
            16777216.0,
            16777215.0,
            1.0e-21,
            4.0e-22,
            f32::from_bits(1),
        ];
        // Every power of two and its neighbours (the asymmetric-interval case).
        for e in 1..254u32 {
            let p = f32::from_bits(e << 23);
            values.extend([p, f32::from_bits(p.to_bits() - 1), f32::from_bits(p.to_bits() + 1)]);
        }
        // Short decimals: 1..=4 digits at every exponent.
        for e in -45..39 {
            for d in [1u32, 2, 5, 9, 25, 125, 999, 1001, 4321] {
                if let Ok(v) = format!("{d}e{e}").parse::<f32>()
                    && v.is_finite()
                    && v > 0.0
                {
                    values.push(v);
                }
            }
        }
        for v in values {
            let mut fast = Vec::new();
            push_f32(&mut fast, v);
            assert_eq!(std::str::from_utf8(&fast).unwrap(), std_text(v), "bits {:#x}", v.to_bits());
        }
    }

    #[test]
    fn notation_examples() {
        assert_eq!(f32_to_text(0.0), "0");
        assert_eq!(f32_to_text(f32::INFINITY), "inf");
        assert_eq!(f32_to_text(1000.0), "1000");
        assert_eq!(f32_to_text(1.5), "1.5");
        assert_eq!(f32_to_text(0.1), "0.1");
        assert_eq!(f32_to_text(0.0001), "0.0001");
        assert_eq!(f32_to_text(0.00001), "1e-5");
        assert_eq!(f32_to_text(1.5e-7), "1.5e-7");
        assert_eq!(f32_to_text(1e15), "1000000000000000");
        assert_eq!(f32_to_text(1e16), "1e16");
        assert_eq!(f32_to_text(f32::MAX), "3.4028235e38");
        assert_eq!(f32_to_text(16777217.0), "16777216");
    }

    #[test]
    fn parser_reads_every_written_value_back_exactly() {
        for v in sample(6_007) {
            let mut text = Vec::new();
            push_f32(&mut text, v);
            let (parsed, length) = parse_f32_token(&text);
            assert_eq!(length, text.len());
            assert_eq!(parsed, Ok(v), "{}", String::from_utf8_lossy(&text));
        }
    }

    #[test]
    fn parser_agrees_with_std_on_awkward_decimals() {
        let cases = [
            "0",
            "00000",
            "0.0",
            "-0",
            "-0.0e5",
            "+1",
            "1.",
            ".5",
            "1e0",
            "1E+2",
            "1e-2",
            "3.4028235e38",
            "3.40282356e38",
            "1.17549435e-38",
            "1e-45",
            "7e-46",
            "1e-50",
            "123456789012345678901234567890",
            "0.000000000000000000000000000000000000000001",
            "16777217",
            "16777219",
            "33554433",
            "0.1000000000000000055511151231257827",
            "1.00000005960464477539062500",
            "1.000000059604644775390625001",
            "1.000000059604644775390624999",
            "9007199254740993",
            "4.7019774032891500318749461488889827112746622270883500860350068251e-38",
        ];
        for text in cases {
            let (parsed, length) = parse_f32_token(text.as_bytes());
            assert_eq!(length, text.len(), "{text}");
            let want: f32 = text.parse().unwrap();
            assert_eq!(parsed, Ok(want.abs()), "{text}");
        }
    }

    #[test]
    fn parser_rounds_midpoints_like_std() {
        // Decimals exactly at, just below and just above f32 rounding midpoints, where the
        // f64 fast path must hand over to std.
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..20_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let bits = (state as u32) % 0x7f00_0000 + 0x0080_0000;
            let a = f64::from(f32::from_bits(bits));
            let b = f64::from(f32::from_bits(bits + 1));
            let mid = 0.5 * (a + b);
            for x in [mid, f64::from_bits(mid.to_bits() - 1), f64::from_bits(mid.to_bits() + 1)] {
                for text in [format!("{x:e}"), format!("{x:.17e}"), format!("{x}")] {
                    let (parsed, _) = parse_f32_token(text.as_bytes());
                    assert_eq!(parsed, Ok(text.parse::<f32>().unwrap()), "{text}");
                }
            }
        }
    }

    #[test]
    fn parser_rejects_what_the_contract_rejects() {
        let cases: [(&str, Result<f32, TokenError>, usize); 17] = [
            ("inf", Ok(f32::INFINITY), 3),
            ("INF", Ok(f32::INFINITY), 3),
            ("+Infinity", Ok(f32::INFINITY), 9),
            ("-inf", Err(TokenError::Negative), 4),
            ("nan", Err(TokenError::NotANumber), 3),
            ("NaN", Err(TokenError::NotANumber), 3),
            ("-1.5", Err(TokenError::Negative), 4),
            ("-1e-60", Err(TokenError::Negative), 6),
            ("1e39", Err(TokenError::OutOfRange), 4),
            ("abc", Err(TokenError::Malformed), 3),
            ("1.2.3", Err(TokenError::Malformed), 5),
            ("1e", Err(TokenError::Malformed), 2),
            ("1e+", Err(TokenError::Malformed), 3),
            ("0x10", Err(TokenError::Malformed), 4),
            ("1,5", Err(TokenError::Malformed), 3),
            (".", Err(TokenError::Malformed), 1),
            ("", Err(TokenError::Malformed), 0),
        ];
        for (text, want, length) in cases {
            assert_eq!(parse_f32_token(text.as_bytes()), (want, length), "{text:?}");
        }
        assert_eq!(parse_f32_token(b"2.5 7"), (Ok(2.5), 3));
        assert_eq!(parse_f32_token(b"2.5\r\n"), (Ok(2.5), 3));
        assert_eq!(parse_f32_token(b"2.5x 7"), (Err(TokenError::Malformed), 4));
    }
}
