//! Warnings and errors with the `file:line:col` of the RIB request they concern.

use rib_parser::scene::FileLoc;
use std::collections::HashSet;
use std::fmt;

/// A warning about the scene: something skipped or interpreted. Printed by the CLI as
/// `PATH:LINE:COL: warning: message`.
#[derive(Clone, Debug, PartialEq)]
pub struct Warning {
    pub loc: Option<FileLoc>,
    pub message: String,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.loc {
            Some(loc) => write!(f, "{loc}: warning: {}", self.message),
            None => write!(f, "warning: {}", self.message),
        }
    }
}

/// Collects warnings, each distinct message once (with the location where it first occurred),
/// and counts what was skipped for `--stats`.
#[derive(Clone, Debug, Default)]
pub struct Diagnostics {
    pub warnings: Vec<Warning>,
    seen: HashSet<String>,
    /// What was skipped and why: `(what, count)`, in first-seen order.
    pub skipped: Vec<(String, usize)>,
}

impl Diagnostics {
    /// Records a warning unless the same message was recorded before.
    pub fn warn_once(&mut self, loc: Option<&FileLoc>, message: impl Into<String>) {
        let message = message.into();
        if self.seen.insert(message.clone()) {
            self.warnings.push(Warning { loc: loc.cloned(), message });
        }
    }

    /// Counts one skipped item of kind `what` (e.g. "Points primitives (not supported)").
    pub fn skip(&mut self, what: &str) {
        match self.skipped.iter_mut().find(|(w, _)| w == what) {
            Some((_, n)) => *n += 1,
            None => self.skipped.push((what.to_string(), 1)),
        }
    }
}
