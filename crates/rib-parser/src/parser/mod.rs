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
mod arguments;
mod conditional;
mod geometry;
mod requests;

use crate::diagnostics::{DiagnosticKind, Diagnostics};
use crate::lexer::{LexError, Lexer, Text, Token, TokenKind};
use crate::limits::Limits;
use crate::params::DeclTable;
use crate::scene::FileLoc;
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
