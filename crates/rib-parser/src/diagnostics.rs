//! Diagnostics: warnings and errors with the `file:line:col` they refer to.
//!
//! Three tiers, as in pbrt-v4:
//! - [`Severity::Warning`]: something was ignored or approximated (an unknown request, a
//!   displacement shader, motion blur); the scene is still built.
//! - [`Severity::Error`]: something is wrong with the scene (a parameter with the wrong number
//!   of values, a missing archive). Parsing goes on so that every error is reported in one run,
//!   but no scene comes out.
//! - [`Severity::Fatal`]: nothing sensible can follow (an unreadable file, a limit exceeded,
//!   too many errors); parsing stops at once.
//!
//! A diagnostic renders as `PATH:LINE:COL: error: message`, followed by the source line and a
//! caret under the column (CONTRACTS.md §4).

use crate::scene::FileLoc;
use crate::source::SourceMap;
use std::fmt;

/// How bad a diagnostic is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Severity {
    Warning,
    Error,
    Fatal,
}

impl Severity {
    fn label(self) -> &'static str {
        match self {
            Severity::Warning => "warning",
            Severity::Error | Severity::Fatal => "error",
        }
    }
}

/// What kind of problem a diagnostic reports, for programs that react to specific problems.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum DiagnosticKind {
    /// A byte sequence that is not a RIB token (bad number, unterminated string, bad binary).
    Syntax,
    /// A request's positional arguments are missing or of the wrong type.
    BadArguments,
    /// A request name nobody knows; it was skipped with its arguments.
    UnknownRequest,
    /// A request that is understood but not supported; it was skipped.
    Unsupported,
    /// A request in the wrong place (e.g. `WorldEnd` without `WorldBegin`).
    Nesting,
    /// A parameter declaration that cannot be parsed.
    BadDeclaration,
    /// A parameter nobody declared.
    UndeclaredParameter,
    /// A parameter whose value count or type does not fit its declaration and the primitive.
    ParameterValues,
    /// A value out of its valid range (negative resolution, index out of bounds, ...).
    BadValue,
    /// The camera cannot be built (`depth_remap::CameraError`).
    Camera,
    /// A `ReadArchive` target that cannot be found or read, or an include cycle.
    Archive,
    /// A request refused because it would run a program (`RunProgram`, `DynamicLoad`).
    Refused,
    /// A configured limit was exceeded.
    Limit,
    /// The input file cannot be read or decompressed.
    Io,
    /// A light or object handle that was never defined.
    UnknownHandle,
}

/// One warning or error.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    pub severity: Severity,
    pub kind: DiagnosticKind,
    /// Where the problem is; `None` for problems without a place (an unreadable file given on the
    /// command line).
    pub loc: Option<FileLoc>,
    pub message: String,
}

impl Diagnostic {
    pub fn new(
        severity: Severity,
        kind: DiagnosticKind,
        loc: Option<FileLoc>,
        message: impl Into<String>,
    ) -> Self {
        Diagnostic { severity, kind, loc, message: message.into() }
    }

    /// `PATH:LINE:COL: error: message` (the first line of [`Diagnostic::render`]).
    pub fn headline(&self) -> String {
        match &self.loc {
            Some(loc) => format!("{loc}: {}: {}", self.severity.label(), self.message),
            None => format!("{}: {}", self.severity.label(), self.message),
        }
    }

    /// The headline, then the source line and a caret under the column when the source is known.
    pub fn render(&self, sources: &SourceMap) -> String {
        let mut out = self.headline();
        if let Some(loc) = &self.loc
            && let Some(snippet) = sources.snippet(loc)
        {
            out.push('\n');
            out.push_str(&snippet);
        }
        out
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.headline())
    }
}

/// How many diagnostics of each tier are kept before the rest are only counted.
const MAX_KEPT_WARNINGS: usize = 200;
/// After this many errors parsing stops: the input is probably not RIB at all.
pub const MAX_ERRORS: usize = 100;

/// The collected diagnostics of one run.
#[derive(Clone, Debug, Default)]
pub struct Diagnostics {
    items: Vec<Diagnostic>,
    warnings: usize,
    errors: usize,
    fatal: bool,
    dropped_warnings: usize,
}

impl Diagnostics {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn push(&mut self, diagnostic: Diagnostic) {
        match diagnostic.severity {
            Severity::Warning => {
                self.warnings += 1;
                if self.warnings > MAX_KEPT_WARNINGS {
                    self.dropped_warnings += 1;
                    return;
                }
            }
            Severity::Error => {
                self.errors += 1;
                if self.errors == MAX_ERRORS {
                    self.items.push(diagnostic);
                    self.items.push(Diagnostic::new(
                        Severity::Fatal,
                        DiagnosticKind::Limit,
                        None,
                        format!("too many errors ({MAX_ERRORS}); stopping"),
                    ));
                    self.fatal = true;
                    return;
                }
            }
            Severity::Fatal => {
                self.errors += 1;
                self.fatal = true;
            }
        }
        self.items.push(diagnostic);
    }

    pub fn warn(&mut self, kind: DiagnosticKind, loc: &FileLoc, message: impl Into<String>) {
        self.push(Diagnostic::new(Severity::Warning, kind, Some(loc.clone()), message));
    }

    pub fn error(&mut self, kind: DiagnosticKind, loc: &FileLoc, message: impl Into<String>) {
        self.push(Diagnostic::new(Severity::Error, kind, Some(loc.clone()), message));
    }

    pub fn fatal(&mut self, kind: DiagnosticKind, loc: Option<&FileLoc>, message: impl Into<String>) {
        self.push(Diagnostic::new(Severity::Fatal, kind, loc.cloned(), message));
    }

    /// Every kept diagnostic, in the order reported.
    pub fn items(&self) -> &[Diagnostic] {
        &self.items
    }

    pub fn into_items(self) -> Vec<Diagnostic> {
        self.items
    }

    /// Number of warnings reported (including any not kept).
    pub fn warning_count(&self) -> usize {
        self.warnings
    }

    /// Number of errors reported (fatal ones included).
    pub fn error_count(&self) -> usize {
        self.errors
    }

    pub fn has_errors(&self) -> bool {
        self.errors > 0
    }

    /// True once a fatal diagnostic was reported: the parser stops.
    pub fn is_fatal(&self) -> bool {
        self.fatal
    }

    /// Warnings reported beyond the number kept.
    pub fn dropped_warnings(&self) -> usize {
        self.dropped_warnings
    }

    /// Every diagnostic rendered with its source snippet, one after another.
    pub fn render(&self, sources: &SourceMap) -> String {
        let mut out = String::new();
        for d in &self.items {
            out.push_str(&d.render(sources));
            out.push('\n');
        }
        if self.dropped_warnings > 0 {
            out.push_str(&format!("note: {} more warnings not shown\n", self.dropped_warnings));
        }
        out
    }
}

/// The error returned when a RIB file does not give a scene: every diagnostic of the run (the
/// errors and the warnings before them) and the sources they point into, so it can be rendered
/// with source lines.
#[derive(Clone, Debug, thiserror::Error)]
#[error("{}", self.summary())]
pub struct RibError {
    pub diagnostics: Vec<Diagnostic>,
    pub sources: SourceMap,
}

impl RibError {
    pub fn new(diagnostics: Vec<Diagnostic>, sources: SourceMap) -> Self {
        RibError { diagnostics, sources }
    }

    /// The first error (the one to fix first).
    pub fn first_error(&self) -> Option<&Diagnostic> {
        self.diagnostics.iter().find(|d| d.severity >= Severity::Error)
    }

    fn summary(&self) -> String {
        let errors = self.diagnostics.iter().filter(|d| d.severity >= Severity::Error).count();
        match self.first_error() {
            Some(first) if errors > 1 => format!("{} (and {} more errors)", first.headline(), errors - 1),
            Some(first) => first.headline(),
            None => "the RIB input did not produce a scene".into(),
        }
    }

    /// Every diagnostic with its source line and caret.
    pub fn render(&self) -> String {
        let mut out = String::new();
        for d in &self.diagnostics {
            out.push_str(&d.render(&self.sources));
            out.push('\n');
        }
        out
    }
}
