//! The arguments of a request: positional arguments (numbers, strings, arrays, handles) and
//! parameter lists (name-value pairs checked against the declarations and the request's class
//! counts). Each reader reports a wrong argument at its token and stops the request.

use super::{PResult, ParamContext, PeekKind, Reader, Stop};
use crate::diagnostics::DiagnosticKind;
use crate::lexer::{ArrayRead, Num, Token, TokenKind};
use crate::params::{self, ClassCounts};
use crate::scene::{Param, ParamDecl, ParamList, ParamType, ParamValues, StorageClass};

impl Reader {
    // -----------------------------------------------------------------------------------------
    // Positional arguments

    /// A number, bare or as a one-element array.
    pub(super) fn arg_num(&mut self, request: &str, what: &str) -> PResult<Num> {
        let nums = self.arg_nums(1, request, what)?;
        Ok(nums[0])
    }

    /// `n` numbers, given bare, as one array, or as a mix (`Color [1 0 0]`, `Color 1 0 0`).
    pub(super) fn arg_nums(&mut self, n: usize, request: &str, what: &str) -> PResult<Vec<Num>> {
        let mut out = Vec::with_capacity(n);
        while out.len() < n {
            let tok = self.tok()?;
            match tok.kind {
                TokenKind::Number(x) => out.push(x),
                TokenKind::ArrayBegin => loop {
                    let t = self.tok()?;
                    match t.kind {
                        TokenKind::Number(x) if out.len() < n => out.push(x),
                        TokenKind::ArrayEnd => break,
                        TokenKind::Number(_) => {
                            let loc = self.loc(t.start);
                            self.diagnostics.error(
                                DiagnosticKind::BadArguments,
                                &loc,
                                format!("{request}: too many values for {what} (expected {n})"),
                            );
                            return Err(Stop);
                        }
                        _ => return Err(self.arg_error(&t, request, &format!("{n} numbers for {what}"))),
                    }
                },
                _ => return Err(self.arg_error(&tok, request, &format!("{n} numbers for {what}"))),
            }
        }
        Ok(out)
    }

    pub(super) fn arg_f64s<const N: usize>(&mut self, request: &str, what: &str) -> PResult<[f64; N]> {
        let nums = self.arg_nums(N, request, what)?;
        let bytes = self.bytes();
        Ok(std::array::from_fn(|i| nums[i].to_f64(&bytes)))
    }

    pub(super) fn arg_f32s<const N: usize>(&mut self, request: &str, what: &str) -> PResult<[f32; N]> {
        let nums = self.arg_nums(N, request, what)?;
        let bytes = self.bytes();
        Ok(std::array::from_fn(|i| nums[i].to_f32(&bytes)))
    }

    pub(super) fn arg_f64(&mut self, request: &str, what: &str) -> PResult<f64> {
        Ok(self.arg_f64s::<1>(request, what)?[0])
    }

    pub(super) fn arg_f32(&mut self, request: &str, what: &str) -> PResult<f32> {
        Ok(self.arg_f32s::<1>(request, what)?[0])
    }

    pub(super) fn arg_i32(&mut self, request: &str, what: &str) -> PResult<i32> {
        let start = self.peek_start();
        let n = self.arg_num(request, what)?;
        let bytes = self.bytes();
        match n.to_i32(&bytes) {
            Some(i) => Ok(i),
            None => {
                let loc = self.loc(start);
                self.diagnostics.error(
                    DiagnosticKind::BadArguments,
                    &loc,
                    format!("{request}: {what} must be an integer, found {}", n.to_f64(&bytes)),
                );
                Err(Stop)
            }
        }
    }

    /// A non-negative count.
    pub(super) fn arg_count(&mut self, request: &str, what: &str) -> PResult<u32> {
        let start = self.peek_start();
        let v = self.arg_i32(request, what)?;
        u32::try_from(v).map_err(|_| {
            let loc = self.loc(start);
            self.diagnostics.error(
                DiagnosticKind::BadValue,
                &loc,
                format!("{request}: {what} must not be negative, got {v}"),
            );
            Stop
        })
    }

    /// A string, bare or as a one-element array.
    pub(super) fn arg_string(&mut self, request: &str, what: &str) -> PResult<String> {
        let tok = self.tok()?;
        match tok.kind {
            TokenKind::String(t) => Ok(self.text_to_string(&t)),
            TokenKind::ArrayBegin => {
                let t = self.tok()?;
                let TokenKind::String(s) = t.kind else {
                    return Err(self.arg_error(&t, request, what));
                };
                let s = self.text_to_string(&s);
                let end = self.tok()?;
                if end.kind != TokenKind::ArrayEnd {
                    return Err(self.arg_error(&end, request, &format!("']' after {what}")));
                }
                Ok(s)
            }
            _ => Err(self.arg_error(&tok, request, what)),
        }
    }

    /// An array of integers (a bare single integer counts as an array of one).
    pub(super) fn arg_int_array(&mut self, request: &str, what: &str) -> PResult<Vec<i32>> {
        let tok = self.tok()?;
        let bytes = self.bytes();
        match tok.kind {
            TokenKind::Number(n) => match n.to_i32(&bytes) {
                Some(i) => Ok(vec![i]),
                None => Err(self.arg_error(&tok, request, &format!("integers for {what}"))),
            },
            TokenKind::ArrayBegin => {
                let mut out = Vec::new();
                self.read_int_elements(&mut out, request, what)?;
                Ok(out)
            }
            _ => Err(self.arg_error(&tok, request, &format!("an array of integers for {what}"))),
        }
    }

    /// An array of non-negative integers.
    pub(super) fn arg_count_array(&mut self, request: &str, what: &str) -> PResult<Vec<u32>> {
        let start = self.peek_start();
        let ints = self.arg_int_array(request, what)?;
        if let Some(bad) = ints.iter().find(|&&i| i < 0) {
            let loc = self.loc(start);
            self.diagnostics.error(
                DiagnosticKind::BadValue,
                &loc,
                format!("{request}: {what} must not be negative, found {bad}"),
            );
            return Err(Stop);
        }
        // Non-negative i32 and u32 have the same bits; this reuses the allocation.
        Ok(ints.into_iter().map(|i| i as u32).collect())
    }

    pub(super) fn arg_float_array(&mut self, request: &str, what: &str) -> PResult<Vec<f32>> {
        let tok = self.tok()?;
        let bytes = self.bytes();
        match tok.kind {
            TokenKind::Number(n) => Ok(vec![n.to_f32(&bytes)]),
            TokenKind::ArrayBegin => {
                let mut out = Vec::new();
                self.read_float_elements(&mut out, request, what)?;
                Ok(out)
            }
            _ => Err(self.arg_error(&tok, request, &format!("an array of numbers for {what}"))),
        }
    }

    pub(super) fn arg_string_array(&mut self, request: &str, what: &str) -> PResult<Vec<String>> {
        let tok = self.tok()?;
        match tok.kind {
            TokenKind::String(t) => Ok(vec![self.text_to_string(&t)]),
            TokenKind::ArrayBegin => {
                let mut out = Vec::new();
                self.read_string_elements(&mut out, request, what)?;
                Ok(out)
            }
            _ => Err(self.arg_error(&tok, request, &format!("an array of strings for {what}"))),
        }
    }

    pub(super) fn check_array_len(&mut self, len: usize, start: usize, request: &str) -> PResult<()> {
        if len > self.options.limits.max_array_len {
            let loc = self.loc(start);
            let limit = self.options.limits.max_array_len;
            self.diagnostics.fatal(
                DiagnosticKind::Limit,
                Some(&loc),
                format!("{request}: array longer than the limit of {limit} values"),
            );
            return Err(Stop);
        }
        Ok(())
    }

    /// Reads numbers up to the closing `]` (the `[` is already read) as `f32`.
    pub(super) fn read_float_elements(
        &mut self,
        out: &mut Vec<f32>,
        request: &str,
        what: &str,
    ) -> PResult<()> {
        self.read_number_elements(out, request, what, "numbers", |n, b| Some(n.to_f32(b)))
    }

    /// Reads integers up to the closing `]` (the `[` is already read); a number that is not an
    /// integer is an error.
    pub(super) fn read_int_elements(&mut self, out: &mut Vec<i32>, request: &str, what: &str) -> PResult<()> {
        self.read_number_elements(out, request, what, "integers", |n, b| n.to_i32(b))
    }

    /// Reads numbers up to the closing `]`, each converted by `convert` (`None`: not a `noun`):
    /// the lexer's fast path first, then token by token from wherever it stopped (another
    /// token, a number `convert` refuses, the array-length limit).
    fn read_number_elements<T>(
        &mut self,
        out: &mut Vec<T>,
        request: &str,
        what: &str,
        noun: &str,
        convert: impl Fn(Num, &[u8]) -> Option<T> + Copy,
    ) -> PResult<()> {
        let bytes = self.bytes();
        let max = self.options.limits.max_array_len;
        match self.input().lexer.read_number_array(out, max, convert) {
            Ok(ArrayRead::Closed) => return Ok(()),
            Ok(ArrayRead::Interrupted) => {}
            Err(e) => {
                self.report_lex_error(e);
                return Err(Stop);
            }
        }
        loop {
            let tok = self.tok()?;
            match tok.kind {
                TokenKind::Number(n) => {
                    if out.len() >= max {
                        self.check_array_len(out.len() + 1, tok.start, request)?;
                    }
                    match convert(n, &bytes) {
                        Some(v) => out.push(v),
                        None => return Err(self.arg_error(&tok, request, &format!("{noun} in {what}"))),
                    }
                }
                TokenKind::ArrayEnd => return Ok(()),
                _ => return Err(self.arg_error(&tok, request, &format!("{noun} or ']' in {what}"))),
            }
        }
    }

    pub(super) fn read_string_elements(
        &mut self,
        out: &mut Vec<String>,
        request: &str,
        what: &str,
    ) -> PResult<()> {
        loop {
            let tok = self.tok()?;
            match tok.kind {
                TokenKind::String(t) => {
                    if out.len() >= self.options.limits.max_array_len {
                        self.check_array_len(out.len() + 1, tok.start, request)?;
                    }
                    let s = self.text_to_string(&t);
                    out.push(s);
                }
                TokenKind::ArrayEnd => return Ok(()),
                _ => return Err(self.arg_error(&tok, request, &format!("strings or ']' in {what}"))),
            }
        }
    }

    /// A light or object handle: an integer sequence number or a name.
    pub(super) fn arg_handle(&mut self, request: &str) -> PResult<crate::scene::Handle> {
        match self.peek(0) {
            Some(PeekKind::String) => Ok(crate::scene::Handle::Name(self.arg_string(request, "a handle")?)),
            _ => Ok(crate::scene::Handle::Int(self.arg_i32(request, "a handle")?)),
        }
    }

    // -----------------------------------------------------------------------------------------
    // Parameter lists

    /// Reads `"name" value` pairs up to the next request. Declarations are resolved and values
    /// typed; counts are checked separately ([`Reader::check_counts`]) once the primitive's
    /// sizes are known.
    pub(super) fn param_list(
        &mut self,
        request: &str,
        context: ParamContext,
        namespace: Option<(&str, &str)>,
    ) -> PResult<ParamList> {
        let mut params = Vec::new();
        loop {
            match self.peek(0) {
                Some(PeekKind::Request | PeekKind::Eof) => return Ok(ParamList(params)),
                Some(PeekKind::String) => {}
                _ => {
                    let tok = self.tok()?;
                    return Err(self.arg_error(&tok, request, "a parameter name"));
                }
            }
            let name_tok = self.tok()?;
            let full_name = match &name_tok.kind {
                TokenKind::String(name_text) => self.text_to_string(name_text),
                _ => return Err(self.arg_error(&name_tok, request, "a parameter name")),
            };
            let loc = self.loc(name_tok.start);
            if !matches!(self.peek(0), Some(PeekKind::ArrayBegin | PeekKind::Number | PeekKind::String)) {
                let tok = self.tok()?;
                return Err(self.arg_error(&tok, request, &format!("a value for parameter \"{full_name}\"")));
            }
            let (decl, name) = match params::parse_inline(&full_name) {
                Ok(Some((decl, bare))) => (Some(decl), bare.to_string()),
                Ok(None) => (self.decls.lookup(&full_name, namespace), full_name.clone()),
                Err(e) => {
                    self.diagnostics.error(
                        DiagnosticKind::BadDeclaration,
                        &loc,
                        format!("{request}: parameter \"{full_name}\": {e}"),
                    );
                    self.skip_value()?;
                    continue;
                }
            };
            let decl = match (decl, context) {
                (Some(d), _) => d,
                (None, ParamContext::Call) => {
                    let values = self.read_values(None, request, &name)?;
                    let ty = match &values {
                        ParamValues::Strings(_) => ParamType::String,
                        ParamValues::Ints(_) | ParamValues::Floats(_) => ParamType::Float,
                    };
                    let n = values.len().max(1) as u32;
                    let decl = ParamDecl { class: StorageClass::Uniform, ty, array_len: n };
                    params.push(Param { name, decl, values, loc });
                    continue;
                }
                (None, ParamContext::Geometry) => {
                    self.diagnostics.warn(
                        DiagnosticKind::UndeclaredParameter,
                        &loc,
                        format!("{request}: parameter \"{name}\" is not declared (use Declare or an inline type); ignored"),
                    );
                    self.skip_value()?;
                    continue;
                }
            };
            if decl.ty == ParamType::Float
                && decl.array_len == 1
                && let Some(v) = self.peek_single_f64()
            {
                self.precise_floats.push((name.clone(), v));
            }
            let values = self.read_values(Some(decl.ty), request, &name)?;
            params.push(Param { name, decl, values, loc });
        }
    }

    /// The value of a one-number parameter about to be read (`1.5` or `[1.5]`) at `f64`
    /// precision, without consuming it.
    pub(super) fn peek_single_f64(&mut self) -> Option<f64> {
        let bytes = self.bytes();
        let lexer = &mut self.input().lexer;
        let first = match lexer.peek(0) {
            Ok(Token { kind: TokenKind::Number(n), .. }) => return Some(n.to_f64(&bytes)),
            Ok(Token { kind: TokenKind::ArrayBegin, .. }) => match lexer.peek(1) {
                Ok(Token { kind: TokenKind::Number(n), .. }) => *n,
                _ => return None,
            },
            _ => return None,
        };
        match lexer.peek(2) {
            Ok(Token { kind: TokenKind::ArrayEnd, .. }) => Some(first.to_f64(&bytes)),
            _ => None,
        }
    }

    /// Skips one parameter value (an array or a single token).
    pub(super) fn skip_value(&mut self) -> PResult<()> {
        let tok = self.tok()?;
        if tok.kind == TokenKind::ArrayBegin {
            loop {
                let t = self.tok()?;
                match t.kind {
                    TokenKind::ArrayEnd => break,
                    TokenKind::Request(_) | TokenKind::Eof => {
                        return Err(self.arg_error(&t, "parameter list", "']'"));
                    }
                    _ => {}
                }
            }
        }
        Ok(())
    }

    /// Reads one parameter value of type `ty` (or of the type its tokens have, for `None`).
    pub(super) fn read_values(
        &mut self,
        ty: Option<ParamType>,
        request: &str,
        name: &str,
    ) -> PResult<ParamValues> {
        let what = format!("parameter \"{name}\"");
        let is_string = match ty {
            Some(t) => t == ParamType::String,
            None => {
                let k = match self.peek(0) {
                    Some(PeekKind::ArrayBegin) => self.peek(1),
                    other => other,
                };
                k == Some(PeekKind::String)
            }
        };
        if is_string {
            return Ok(ParamValues::Strings(self.arg_string_array(request, &what)?));
        }
        // Some writers (RiCPP) give several values without brackets: `"MyArray" 1 2 3`. After a
        // parameter name, consecutive numbers can only be its values.
        let bare = self.peek(0) == Some(PeekKind::Number);
        if ty == Some(ParamType::Integer) {
            let mut v = self.arg_int_array(request, &what)?;
            while bare && self.peek(0) == Some(PeekKind::Number) {
                v.extend(self.arg_int_array(request, &what)?);
            }
            return Ok(ParamValues::Ints(v));
        }
        // An empty array of unknown type reads as floats.
        let mut v = self.arg_float_array(request, &what)?;
        while bare && self.peek(0) == Some(PeekKind::Number) {
            v.extend(self.arg_float_array(request, &what)?);
        }
        Ok(ParamValues::Floats(v))
    }

    /// Checks every parameter's value count against its class and the primitive's sizes.
    /// `color` parameters take as many values per element as there are colour samples.
    pub(crate) fn check_counts(
        &mut self,
        request: &str,
        params: &ParamList,
        counts: &ClassCounts,
    ) -> PResult<()> {
        let color_samples = self.scope().color_samples;
        let mut ok = true;
        for p in &params.0 {
            let per = if p.decl.ty == ParamType::Color { color_samples } else { p.decl.ty.components() };
            let per_element = per * p.decl.array_len as usize;
            let elements = counts.of(p.decl.class);
            let expected = elements.saturating_mul(per_element);
            if p.values.len() != expected {
                ok = false;
                let class = params::class_name(p.decl.class);
                let ty = params::type_name(p.decl.ty);
                let explain = if per_element == 1 {
                    format!("{elements} {class} value(s)")
                } else {
                    format!("{elements} {class} element(s) of {per_element} values each")
                };
                self.diagnostics.error(
                    DiagnosticKind::ParameterValues,
                    &p.loc,
                    format!(
                        "{request}: parameter \"{}\" ({class} {ty}) has {} values, but this {request} takes {expected} ({explain})",
                        p.name,
                        p.values.len()
                    ),
                );
            }
        }
        if ok { Ok(()) } else { Err(Stop) }
    }
}
