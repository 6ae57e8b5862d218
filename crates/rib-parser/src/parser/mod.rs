//! The RIB parser: tokens in, one [`RibTarget`] call per request out.
//!
//! [`Reader`] owns everything that outlives one file: the declarations (`Declare` is global),
//! the sources read so far (for diagnostics), search paths, inline archives and the limits. It
//! reads the top-level file and follows `ReadArchive`, `ArchiveBegin`/`ArchiveEnd` and
//! `Procedural "DelayedReadArchive"`. It never executes anything a scene names
//! (`RunProgram`, `DynamicLoad` and `System` are refused with a warning).
//!
//! Error recovery: a request whose arguments are wrong is reported and skipped up to the next
//! request name; parsing goes on, so one run reports every error (up to
//! [`crate::diagnostics::MAX_ERRORS`]).

mod archive;
mod conditional;
mod geometry;
mod requests;

use crate::diagnostics::{DiagnosticKind, Diagnostics};
use crate::lexer::{ArrayRead, LexError, Lexer, Num, Text, Token, TokenKind};
use crate::limits::Limits;
use crate::params::{self, ClassCounts, DeclTable};
use crate::scene::{FileLoc, Param, ParamDecl, ParamList, ParamType, ParamValues, StorageClass};
use crate::source::{FileSystem, SourceFile, SourceMap, StdFileSystem};
use crate::target::{Cx, RibTarget};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub use archive::InlineArchive;

/// How a [`Reader`] reads.
#[derive(Clone)]
pub struct ReadOptions {
    pub limits: Limits,
    /// Where files and archives are read from.
    pub file_system: Arc<dyn FileSystem>,
}

impl Default for ReadOptions {
    fn default() -> Self {
        ReadOptions { limits: Limits::default(), file_system: Arc::new(StdFileSystem) }
    }
}

impl std::fmt::Debug for ReadOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ReadOptions").field("limits", &self.limits).finish_non_exhaustive()
    }
}

/// The request was abandoned; its diagnostic has been reported.
#[derive(Debug)]
pub(crate) struct Stop;

pub(crate) type PResult<T> = Result<T, Stop>;

/// Incremental line counting: locations are mostly asked for in increasing offset order, so
/// counting newlines from the last asked offset costs one pass over the file in total.
#[derive(Clone, Copy, Debug, Default)]
struct LocCursor {
    offset: usize,
    line: u32,
    line_start: usize,
}

/// One file (or inline archive) being read.
struct Input {
    lexer: Lexer,
    source: Arc<SourceFile>,
    cursor: LocCursor,
    /// The normalised path, for include-cycle detection (`None` for standard input and inline
    /// archives).
    key: Option<PathBuf>,
    /// The inline archive's name when this input is one (for cycle detection).
    inline_name: Option<String>,
    /// How many `IfBegin` blocks were open when this input started (it must close its own).
    conditional_depth: usize,
}

/// Parse-time state that decides how following requests are read: the basis steps (which
/// change how many values a bicubic `PatchMesh` or `Curves` takes) and the number of colour
/// samples, both scoped like the attributes and options they are.
#[derive(Clone, Copy, Debug)]
struct ScopeState {
    u_step: u32,
    v_step: u32,
    color_samples: usize,
}

impl Default for ScopeState {
    fn default() -> Self {
        ScopeState { u_step: 3, v_step: 3, color_samples: 3 }
    }
}

/// What a parameter list belongs to, which decides how undeclared names are treated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ParamContext {
    /// A geometric primitive: every parameter needs a declaration and a class-correct count.
    Geometry,
    /// Shader, option, attribute, display, hider, ...: undeclared names take their type from
    /// their values, as a renderer would take it from the shader or its own option table.
    Call,
}

/// Reads RIB input into a [`RibTarget`].
pub struct Reader {
    options: ReadOptions,
    diagnostics: Diagnostics,
    sources: SourceMap,
    decls: DeclTable,
    inputs: Vec<Input>,
    inline_archives: HashMap<String, InlineArchive>,
    search_paths: HashMap<String, Vec<String>>,
    /// Directory of the top-level file: `@` in search paths, and the base of relative entries.
    root_dir: PathBuf,
    total_bytes: u64,
    scopes: Vec<ScopeState>,
    requests: u64,
    /// The open `IfBegin` blocks, innermost last.
    conditionals: Vec<conditional::OpenIf>,
    /// Open `SolidBegin` blocks, counted against [`Limits::max_nesting_depth`] so that a CSG
    /// tree built from them stays bounded.
    solid_depth: usize,
    unnamed_handles: u32,
    warned: std::collections::HashSet<&'static str>,
    /// Single-valued float parameters of the last parameter list, at `f64` precision (for
    /// values that must not be rounded to `f32`, such as the camera's field of view).
    precise_floats: Vec<(String, f64)>,
}

impl std::fmt::Debug for Reader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Reader")
            .field("options", &self.options)
            .field("requests", &self.requests)
            .field("total_bytes", &self.total_bytes)
            .finish_non_exhaustive()
    }
}

impl Reader {
    pub fn new(options: ReadOptions) -> Reader {
        Reader {
            options,
            diagnostics: Diagnostics::new(),
            sources: SourceMap::new(),
            decls: DeclTable::default(),
            inputs: Vec::new(),
            inline_archives: HashMap::new(),
            search_paths: HashMap::new(),
            root_dir: PathBuf::from("."),
            total_bytes: 0,
            scopes: vec![ScopeState::default()],
            requests: 0,
            conditionals: Vec::new(),
            solid_depth: 0,
            unnamed_handles: 0,
            warned: Default::default(),
            precise_floats: Vec::new(),
        }
    }

    /// Reads the file at `path` (gzip or not, ASCII or binary) into `target`. `-` reads standard
    /// input. Problems are collected in [`Reader::diagnostics`].
    pub fn read_file<T: RibTarget + ?Sized>(&mut self, path: &Path, target: &mut T) {
        let name: Arc<str> = Arc::from(path.to_string_lossy().as_ref());
        let raw = if path == Path::new("-") {
            let mut buf = Vec::new();
            match std::io::Read::read_to_end(&mut std::io::stdin(), &mut buf) {
                Ok(_) => Ok(buf),
                Err(e) => Err(e),
            }
        } else {
            self.options.file_system.read(path)
        };
        let raw = match raw {
            Ok(r) => r,
            Err(e) => {
                self.diagnostics.fatal(DiagnosticKind::Io, None, format!("cannot read '{name}': {e}"));
                return;
            }
        };
        let file_path = (path != Path::new("-")).then(|| path.to_path_buf());
        if let Some(p) = &file_path {
            self.root_dir = p.parent().map(Path::to_path_buf).unwrap_or_default();
        }
        self.read_source(name, file_path, raw, target);
    }

    /// Reads RIB bytes (gzip or not) named `name` into `target`. `path`, when given, is where
    /// relative archive names are resolved from.
    pub fn read_bytes<T: RibTarget + ?Sized>(
        &mut self,
        name: &str,
        path: Option<PathBuf>,
        bytes: Vec<u8>,
        target: &mut T,
    ) {
        if let Some(p) = &path {
            self.root_dir = p.parent().map(Path::to_path_buf).unwrap_or_default();
        }
        self.read_source(Arc::from(name), path, bytes, target);
    }

    fn read_source<T: RibTarget + ?Sized>(
        &mut self,
        name: Arc<str>,
        path: Option<PathBuf>,
        raw: Vec<u8>,
        target: &mut T,
    ) {
        let Some(source) = self.load(name, path.clone(), raw, None) else { return };
        let key = path.as_deref().map(archive::normalize);
        self.push_input(source, key, None);
        self.run(target);
    }

    /// Every warning and error so far.
    pub fn diagnostics(&self) -> &Diagnostics {
        &self.diagnostics
    }

    pub fn diagnostics_mut(&mut self) -> &mut Diagnostics {
        &mut self.diagnostics
    }

    /// Every source read so far (for rendering diagnostics with their source lines).
    pub fn sources(&self) -> &SourceMap {
        &self.sources
    }

    /// Number of requests read.
    pub fn request_count(&self) -> u64 {
        self.requests
    }

    /// Total RIB bytes read (after decompression, archives included).
    pub fn bytes_read(&self) -> u64 {
        self.total_bytes
    }

    pub fn into_parts(self) -> (Diagnostics, SourceMap) {
        (self.diagnostics, self.sources)
    }

    /// Decompresses and registers a source, charging it against the byte budget.
    fn load(
        &mut self,
        name: Arc<str>,
        path: Option<PathBuf>,
        raw: Vec<u8>,
        at: Option<&FileLoc>,
    ) -> Option<Arc<SourceFile>> {
        let budget = self.options.limits.max_total_bytes.saturating_sub(self.total_bytes);
        match crate::source::decode(raw, budget) {
            Ok((bytes, was_gzip)) => {
                self.total_bytes += bytes.len() as u64;
                let file = Arc::new(SourceFile::new(name, path, bytes, was_gzip));
                self.sources.add(file.clone());
                Some(file)
            }
            Err(crate::source::DecodeError::TooLarge { .. }) => {
                self.diagnostics.fatal(
                    DiagnosticKind::Limit,
                    at,
                    format!(
                        "reading '{name}' would exceed the limit of {} bytes of RIB input",
                        self.options.limits.max_total_bytes
                    ),
                );
                None
            }
            Err(e) => {
                let kind = DiagnosticKind::Io;
                match at {
                    Some(loc) => self.diagnostics.error(kind, loc, format!("cannot read '{name}': {e}")),
                    None => self.diagnostics.fatal(kind, None, format!("cannot read '{name}': {e}")),
                }
                None
            }
        }
    }

    fn push_input(&mut self, source: Arc<SourceFile>, key: Option<PathBuf>, inline_name: Option<String>) {
        let lexer = Lexer::new(source.bytes.clone());
        self.inputs.push(Input {
            lexer,
            source,
            cursor: LocCursor { offset: 0, line: 1, line_start: 0 },
            key,
            inline_name,
            conditional_depth: self.conditionals.len(),
        });
    }

    /// The main loop: one request at a time until every input is exhausted.
    fn run<T: RibTarget + ?Sized>(&mut self, target: &mut T) {
        let base_depth = self.inputs.len().saturating_sub(1);
        while self.inputs.len() > base_depth {
            if self.diagnostics.is_fatal() {
                self.inputs.truncate(base_depth);
                return;
            }
            let Some(input) = self.inputs.last_mut() else { return };
            match input.lexer.next() {
                Ok(Token { kind: TokenKind::Eof, .. }) => {
                    let depth = input.conditional_depth;
                    self.inputs.pop();
                    self.close_conditionals_of_input(depth);
                }
                Ok(Token { kind: TokenKind::Request(name), start }) => {
                    let name = String::from_utf8_lossy(name.bytes(input.lexer.bytes())).into_owned();
                    self.requests += 1;
                    if self.request(&name, start, target).is_err() {
                        self.skip_to_request();
                    }
                }
                Ok(tok) => {
                    let what = self.describe(&tok);
                    let loc = self.loc(tok.start);
                    self.diagnostics.error(
                        DiagnosticKind::Syntax,
                        &loc,
                        format!("expected a request name, found {what}"),
                    );
                    self.skip_to_request();
                }
                Err(e) => {
                    self.report_lex_error(e);
                    self.skip_to_request();
                }
            }
        }
    }

    // -----------------------------------------------------------------------------------------
    // Tokens and locations

    fn input(&mut self) -> &mut Input {
        // `run` only calls into request handling while an input is open.
        let last = self.inputs.len() - 1;
        &mut self.inputs[last]
    }

    /// The source bytes of the current input (a cheap `Arc` clone, so values can be read out of
    /// them while the lexer moves on).
    fn bytes(&mut self) -> Arc<Vec<u8>> {
        self.input().lexer.bytes().clone()
    }

    /// `file:line:col` of a byte offset in the current input.
    pub(crate) fn loc(&mut self, offset: usize) -> FileLoc {
        let input = self.input();
        let c = &mut input.cursor;
        if offset < c.offset {
            return input.source.loc(offset);
        }
        let bytes = &input.source.bytes[c.offset..offset.min(input.source.bytes.len())];
        // Counting and finding the last newline separately lets both loops vectorise.
        let newlines = bytes.iter().filter(|&&b| b == b'\n').count();
        if let Some(last) = bytes.iter().rposition(|&b| b == b'\n') {
            c.line = c.line.saturating_add(u32::try_from(newlines).unwrap_or(u32::MAX));
            c.line_start = c.offset + last + 1;
        }
        c.offset = offset;
        let column = u32::try_from(offset - c.line_start + 1).unwrap_or(u32::MAX);
        FileLoc { file: input.source.name.clone(), line: c.line, column }
    }

    fn report_lex_error(&mut self, e: LexError) {
        let loc = self.loc(e.offset);
        self.diagnostics.error(DiagnosticKind::Syntax, &loc, e.message);
    }

    /// The next token of the current request; lexical errors are reported and stop the request.
    fn tok(&mut self) -> PResult<Token> {
        match self.input().lexer.next() {
            Ok(t) => Ok(t),
            Err(e) => {
                self.report_lex_error(e);
                Err(Stop)
            }
        }
    }

    /// Kind of the token `n` ahead, without consuming it (`None` for a lexical error).
    fn peek(&mut self, n: usize) -> Option<PeekKind> {
        match self.input().lexer.peek(n) {
            Ok(t) => Some(match t.kind {
                TokenKind::Request(_) => PeekKind::Request,
                TokenKind::String(_) => PeekKind::String,
                TokenKind::Number(_) => PeekKind::Number,
                TokenKind::ArrayBegin => PeekKind::ArrayBegin,
                TokenKind::ArrayEnd => PeekKind::ArrayEnd,
                TokenKind::Eof => PeekKind::Eof,
            }),
            Err(_) => None,
        }
    }

    fn peek_start(&mut self) -> usize {
        match self.input().lexer.peek(0) {
            Ok(t) => t.start,
            Err(e) => e.offset,
        }
    }

    /// Skips tokens up to the next request name (or the end of the input).
    fn skip_to_request(&mut self) {
        loop {
            if self.diagnostics.is_fatal() {
                return;
            }
            match self.input().lexer.peek(0) {
                Ok(Token { kind: TokenKind::Request(_) | TokenKind::Eof, .. }) => return,
                Ok(_) => {
                    let _ = self.input().lexer.next();
                }
                Err(_) => {
                    if let Err(e) = self.input().lexer.next() {
                        self.report_lex_error(e);
                    }
                }
            }
        }
    }

    fn describe(&mut self, tok: &Token) -> String {
        let bytes = self.bytes();
        match &tok.kind {
            TokenKind::Request(t) => format!("'{}'", String::from_utf8_lossy(t.bytes(&bytes))),
            TokenKind::String(t) => format!("string \"{}\"", String::from_utf8_lossy(t.bytes(&bytes))),
            TokenKind::Number(n) => format!("number {}", n.to_f64(&bytes)),
            TokenKind::ArrayBegin => "'['".into(),
            TokenKind::ArrayEnd => "']'".into(),
            TokenKind::Eof => "the end of the file".into(),
        }
    }

    fn arg_error(&mut self, tok: &Token, request: &str, what: &str) -> Stop {
        let found = self.describe(tok);
        let loc = self.loc(tok.start);
        self.diagnostics.error(
            DiagnosticKind::BadArguments,
            &loc,
            format!("{request}: expected {what}, found {found}"),
        );
        // A request name that ends the arguments too early starts the next request: keep it.
        if matches!(tok.kind, TokenKind::Request(_) | TokenKind::Eof) {
            self.input().lexer.unread(tok.clone());
        }
        Stop
    }

    fn text_to_string(&mut self, t: &Text) -> String {
        let bytes = self.bytes();
        String::from_utf8_lossy(t.bytes(&bytes)).into_owned()
    }

    pub(crate) fn cx(&mut self, loc: FileLoc) -> Cx<'_> {
        Cx { loc, diagnostics: &mut self.diagnostics }
    }

    fn warn_once(
        &mut self,
        key: &'static str,
        loc: &FileLoc,
        kind: DiagnosticKind,
        message: impl Into<String>,
    ) {
        if self.warned.insert(key) {
            self.diagnostics.warn(kind, loc, message);
        }
    }

    // -----------------------------------------------------------------------------------------
    // Positional arguments

    /// A number, bare or as a one-element array.
    fn arg_num(&mut self, request: &str, what: &str) -> PResult<Num> {
        let nums = self.arg_nums(1, request, what)?;
        Ok(nums[0])
    }

    /// `n` numbers, given bare, as one array, or as a mix (`Color [1 0 0]`, `Color 1 0 0`).
    fn arg_nums(&mut self, n: usize, request: &str, what: &str) -> PResult<Vec<Num>> {
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

    fn arg_f64s<const N: usize>(&mut self, request: &str, what: &str) -> PResult<[f64; N]> {
        let nums = self.arg_nums(N, request, what)?;
        let bytes = self.bytes();
        Ok(std::array::from_fn(|i| nums[i].to_f64(&bytes)))
    }

    fn arg_f32s<const N: usize>(&mut self, request: &str, what: &str) -> PResult<[f32; N]> {
        let nums = self.arg_nums(N, request, what)?;
        let bytes = self.bytes();
        Ok(std::array::from_fn(|i| nums[i].to_f32(&bytes)))
    }

    fn arg_f64(&mut self, request: &str, what: &str) -> PResult<f64> {
        Ok(self.arg_f64s::<1>(request, what)?[0])
    }

    fn arg_f32(&mut self, request: &str, what: &str) -> PResult<f32> {
        Ok(self.arg_f32s::<1>(request, what)?[0])
    }

    fn arg_i32(&mut self, request: &str, what: &str) -> PResult<i32> {
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
    fn arg_count(&mut self, request: &str, what: &str) -> PResult<u32> {
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
    fn arg_string(&mut self, request: &str, what: &str) -> PResult<String> {
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
    fn arg_int_array(&mut self, request: &str, what: &str) -> PResult<Vec<i32>> {
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
    fn arg_count_array(&mut self, request: &str, what: &str) -> PResult<Vec<u32>> {
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

    fn arg_float_array(&mut self, request: &str, what: &str) -> PResult<Vec<f32>> {
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

    fn arg_string_array(&mut self, request: &str, what: &str) -> PResult<Vec<String>> {
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

    fn check_array_len(&mut self, len: usize, start: usize, request: &str) -> PResult<()> {
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
    fn read_float_elements(&mut self, out: &mut Vec<f32>, request: &str, what: &str) -> PResult<()> {
        let bytes = self.bytes();
        let max = self.options.limits.max_array_len;
        match self.input().lexer.read_number_array(out, max, |n, b| Some(n.to_f32(b))) {
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
                    out.push(n.to_f32(&bytes));
                }
                TokenKind::ArrayEnd => return Ok(()),
                _ => return Err(self.arg_error(&tok, request, &format!("numbers or ']' in {what}"))),
            }
        }
    }

    fn read_int_elements(&mut self, out: &mut Vec<i32>, request: &str, what: &str) -> PResult<()> {
        let bytes = self.bytes();
        let max = self.options.limits.max_array_len;
        match self.input().lexer.read_number_array(out, max, |n, b| n.to_i32(b)) {
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
                    match n.to_i32(&bytes) {
                        Some(i) => out.push(i),
                        None => return Err(self.arg_error(&tok, request, &format!("integers in {what}"))),
                    }
                }
                TokenKind::ArrayEnd => return Ok(()),
                _ => return Err(self.arg_error(&tok, request, &format!("integers or ']' in {what}"))),
            }
        }
    }

    fn read_string_elements(&mut self, out: &mut Vec<String>, request: &str, what: &str) -> PResult<()> {
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
    fn arg_handle(&mut self, request: &str) -> PResult<crate::scene::Handle> {
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
    fn param_list(
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
    fn peek_single_f64(&mut self) -> Option<f64> {
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
    fn skip_value(&mut self) -> PResult<()> {
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
    fn read_values(&mut self, ty: Option<ParamType>, request: &str, name: &str) -> PResult<ParamValues> {
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

    fn scope(&self) -> ScopeState {
        self.scopes.last().copied().unwrap_or_default()
    }

    fn scope_mut(&mut self) -> &mut ScopeState {
        if self.scopes.is_empty() {
            self.scopes.push(ScopeState::default());
        }
        let last = self.scopes.len() - 1;
        &mut self.scopes[last]
    }

    fn push_scope(&mut self, loc: &FileLoc) -> PResult<()> {
        if self.scopes.len() > self.options.limits.max_nesting_depth {
            let limit = self.options.limits.max_nesting_depth;
            self.diagnostics.fatal(
                DiagnosticKind::Limit,
                Some(loc),
                format!("blocks nested deeper than the limit of {limit}"),
            );
            return Err(Stop);
        }
        let s = self.scope();
        self.scopes.push(s);
        Ok(())
    }

    fn pop_scope(&mut self) {
        if self.scopes.len() > 1 {
            self.scopes.pop();
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PeekKind {
    Request,
    String,
    Number,
    ArrayBegin,
    ArrayEnd,
    Eof,
}
