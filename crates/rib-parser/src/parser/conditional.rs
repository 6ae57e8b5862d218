//! `IfBegin`/`ElseIf`/`Else`/`IfEnd`: only the requests of the active branch reach the target.
//!
//! The expressions are evaluated (by [`crate::conditional`]) against the target's options and
//! attributes at the point of the request, as PRMan does. A block opened in a file must close in
//! the same file. Inside an inactive branch nested blocks are only counted, never evaluated.

use super::{PResult, Reader};
use crate::conditional::{self, Value, Variables};
use crate::diagnostics::DiagnosticKind;
use crate::scene::FileLoc;
use crate::target::RibTarget;

/// One open `IfBegin` block.
#[derive(Debug)]
pub(super) struct OpenIf {
    loc: FileLoc,
    /// A branch of this block was taken, or the whole block lies in an inactive branch.
    done: bool,
    /// The requests of the current branch are read.
    active: bool,
    seen_else: bool,
}

/// The target's variables as [`conditional::Variables`].
struct TargetVariables<'a, T: RibTarget + ?Sized>(&'a T);

impl<T: RibTarget + ?Sized> Variables for TargetVariables<'_, T> {
    fn lookup(&self, name: &str) -> Option<Value> {
        self.0.variable(name)
    }
}

impl Reader {
    /// Whether requests are read here (not inside an inactive branch).
    pub(super) fn branch_active(&self) -> bool {
        self.conditionals.last().is_none_or(|c| c.active)
    }

    /// Handles the four conditional requests; `name` is one of them.
    pub(super) fn conditional<T: RibTarget + ?Sized>(
        &mut self,
        name: &str,
        loc: FileLoc,
        t: &mut T,
    ) -> PResult<()> {
        match name {
            "IfBegin" => {
                let limit = self.options.limits.max_nesting_depth;
                if self.conditionals.len() >= limit {
                    self.diagnostics.fatal(
                        DiagnosticKind::Limit,
                        Some(&loc),
                        format!("IfBegin blocks nested deeper than the limit of {limit}"),
                    );
                    return Err(super::Stop);
                }
                let value = if self.branch_active() { Some(self.condition(name, t)?) } else { None };
                self.skip_to_request();
                let taken = value.unwrap_or(false);
                self.conditionals.push(OpenIf {
                    loc,
                    done: value.is_none() || taken,
                    active: taken,
                    seen_else: false,
                });
            }
            "ElseIf" | "Else" => {
                let Some(open) = self.conditionals.last() else {
                    self.skip_to_request();
                    self.diagnostics.error(DiagnosticKind::Nesting, &loc, format!("{name} without IfBegin"));
                    return Ok(());
                };
                if open.seen_else {
                    let at = open.loc.clone();
                    self.skip_to_request();
                    self.diagnostics.error(
                        DiagnosticKind::Nesting,
                        &loc,
                        format!("{name} after Else (in the IfBegin block at {at})"),
                    );
                    return Ok(());
                }
                let decide = !open.done;
                let taken = match (name, decide) {
                    ("ElseIf", true) => self.condition(name, t)?,
                    ("Else", true) => true,
                    _ => false,
                };
                self.skip_to_request();
                if let Some(open) = self.conditionals.last_mut() {
                    open.active = taken;
                    open.done |= taken;
                    open.seen_else = name == "Else";
                }
            }
            _ => {
                self.skip_to_request();
                if self.conditionals.len() <= self.input().conditional_depth {
                    self.diagnostics.error(DiagnosticKind::Nesting, &loc, "IfEnd without IfBegin");
                } else {
                    self.conditionals.pop();
                }
            }
        }
        Ok(())
    }

    /// Reads the expression argument of `request` and evaluates it; a malformed expression is
    /// an error located at the offending character, and counts as false.
    fn condition<T: RibTarget + ?Sized>(&mut self, request: &str, t: &mut T) -> PResult<bool> {
        let start = self.peek_start();
        let expr = self.arg_string(request, "the condition expression")?;
        match conditional::evaluate(&expr, &TargetVariables(&*t)) {
            Ok(v) => Ok(v),
            Err(e) => {
                let loc = self.expression_loc(start, &expr, e.offset);
                self.diagnostics.error(
                    DiagnosticKind::BadValue,
                    &loc,
                    format!("{request} \"{expr}\": {}; the branch is not taken", e.message),
                );
                Ok(false)
            }
        }
    }

    /// The location of byte `offset` of an expression read from the string token at `start`:
    /// exact when the token holds the text as written (one line, no escapes), else the token's.
    fn expression_loc(&mut self, start: usize, expr: &str, offset: usize) -> FileLoc {
        let bytes = self.bytes();
        let body = start + 1;
        let written = bytes.get(body..body + expr.len()).is_some_and(|b| b == expr.as_bytes())
            && bytes.get(start) == Some(&b'"');
        self.loc(if written { body + offset.min(expr.len()) } else { start })
    }

    /// At the end of a file: reports the blocks it left open and closes them.
    pub(super) fn close_conditionals_of_input(&mut self, depth: usize) {
        while self.conditionals.len() > depth {
            if let Some(open) = self.conditionals.pop() {
                self.diagnostics.error(
                    DiagnosticKind::Nesting,
                    &open.loc,
                    "IfBegin is never closed (the file ends inside it; IfEnd must be in the same file)",
                );
            }
        }
    }
}
