//! Device trajectories for replay (CONTRACTS.md §5): CSV with the header `t,x,y,z`, time in
//! seconds and positions in metres in the device frame, sampled by linear interpolation.
//!
//! Blank lines and lines starting with `#` are ignored; `\r\n` line ends are accepted. Times
//! must be finite and strictly increasing. Errors name `file:line:col`.

use glam::DVec3;
use std::fmt;
use std::path::Path;

/// The most samples one trajectory may hold (a day at 1 kHz fits; a runaway file does not).
pub const MAX_SAMPLES: usize = 100_000_000;

/// A malformed trajectory, with where the problem is (1-based line and column).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub struct TrajectoryError {
    pub file: String,
    pub line: usize,
    pub column: usize,
    pub message: String,
}

impl fmt::Display for TrajectoryError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}: error: {}", self.file, self.line, self.column, self.message)
    }
}

/// A device trajectory: samples `(t, position)` with strictly increasing `t`.
#[derive(Clone, Debug, PartialEq)]
pub struct Trajectory {
    times: Vec<f64>,
    positions: Vec<DVec3>,
}

impl Trajectory {
    /// A trajectory from samples; they must be finite with strictly increasing times.
    pub fn from_samples(samples: &[(f64, DVec3)]) -> Result<Trajectory, TrajectoryError> {
        let err = |i: usize, message: String| TrajectoryError {
            file: "<samples>".into(),
            line: i + 1,
            column: 1,
            message,
        };
        if samples.is_empty() {
            return Err(err(0, "a trajectory needs at least one sample".into()));
        }
        let mut times = Vec::with_capacity(samples.len());
        let mut positions = Vec::with_capacity(samples.len());
        for (i, &(t, p)) in samples.iter().enumerate() {
            if !t.is_finite() || !p.is_finite() {
                return Err(err(i, format!("sample {i} is not finite")));
            }
            if let Some(&prev) = times.last()
                && t <= prev
            {
                return Err(err(i, format!("time {t} is not after the previous sample's {prev}")));
            }
            times.push(t);
            positions.push(p);
        }
        Ok(Trajectory { times, positions })
    }

    /// Reads a trajectory file.
    pub fn read(path: &Path) -> Result<Trajectory, TrajectoryError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| TrajectoryError {
            file: name.clone(),
            line: 0,
            column: 0,
            message: format!("cannot read the trajectory: {e}"),
        })?;
        Trajectory::parse(&text, &name)
    }

    /// Parses trajectory CSV text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<Trajectory, TrajectoryError> {
        let err = |line: usize, column: usize, message: String| TrajectoryError {
            file: file.to_string(),
            line,
            column,
            message,
        };
        let mut header_seen = false;
        let mut times = Vec::new();
        let mut positions = Vec::new();
        for (index, raw) in text.split('\n').enumerate() {
            let line_no = index + 1;
            let line = raw.strip_suffix('\r').unwrap_or(raw);
            let trimmed = line.trim();
            if trimmed.is_empty() || trimmed.starts_with('#') {
                continue;
            }
            let fields = split_fields(line);
            if !header_seen {
                let names: Vec<String> = fields.iter().map(|(_, f)| f.trim().to_ascii_lowercase()).collect();
                if names != ["t", "x", "y", "z"] {
                    let column = fields.first().map_or(1, |(c, _)| *c);
                    return Err(err(
                        line_no,
                        column,
                        format!("expected the header `t,x,y,z`, found `{}`", trimmed),
                    ));
                }
                header_seen = true;
                continue;
            }
            if fields.len() != 4 {
                let column = fields.get(4).map_or(line.len() + 1, |(c, _)| *c);
                return Err(err(
                    line_no,
                    column,
                    format!("expected 4 values (t,x,y,z), found {}", fields.len()),
                ));
            }
            let mut values = [0.0f64; 4];
            for (k, (column, field)) in fields.iter().enumerate() {
                let text = field.trim();
                let column = column + (field.len() - field.trim_start().len());
                let value: f64 = text.parse().map_err(|_| {
                    if text.is_empty() {
                        err(line_no, column, format!("missing value for `{}`", ["t", "x", "y", "z"][k]))
                    } else {
                        err(line_no, column, format!("`{text}` is not a number"))
                    }
                })?;
                if !value.is_finite() {
                    return Err(err(line_no, column, format!("`{text}` is not a finite number")));
                }
                values[k] = value;
            }
            if let Some(&prev) = times.last()
                && values[0] <= prev
            {
                return Err(err(
                    line_no,
                    fields[0].0,
                    format!("time {} is not after the previous sample's {prev}", values[0]),
                ));
            }
            if times.len() >= MAX_SAMPLES {
                return Err(err(line_no, 1, format!("more than {MAX_SAMPLES} samples")));
            }
            times.push(values[0]);
            positions.push(DVec3::new(values[1], values[2], values[3]));
        }
        if !header_seen {
            return Err(err(1, 1, "empty trajectory: expected the header `t,x,y,z`".into()));
        }
        if times.is_empty() {
            return Err(err(
                text.split('\n').count(),
                1,
                "the trajectory has a header but no samples".into(),
            ));
        }
        Ok(Trajectory { times, positions })
    }

    pub fn len(&self) -> usize {
        self.times.len()
    }

    pub fn is_empty(&self) -> bool {
        self.times.is_empty()
    }

    pub fn start_time(&self) -> f64 {
        self.times[0]
    }

    pub fn end_time(&self) -> f64 {
        self.times[self.times.len() - 1]
    }

    /// The position at time `t`: linear interpolation between samples, held constant before
    /// the first and after the last.
    pub fn position_at(&self, t: f64) -> DVec3 {
        let n = self.times.len();
        if !(t > self.times[0]) {
            return self.positions[0];
        }
        if t >= self.times[n - 1] {
            return self.positions[n - 1];
        }
        // First sample strictly after t; 1 <= i <= n - 1 here.
        let i = self.times.partition_point(|&s| s <= t);
        let (t0, t1) = (self.times[i - 1], self.times[i]);
        let s = (t - t0) / (t1 - t0);
        self.positions[i - 1].lerp(self.positions[i], s)
    }

    /// The samples, in order.
    pub fn samples(&self) -> impl Iterator<Item = (f64, DVec3)> + '_ {
        self.times.iter().copied().zip(self.positions.iter().copied())
    }
}

/// Splits a CSV line on commas, keeping each field's 1-based start column.
fn split_fields(line: &str) -> Vec<(usize, &str)> {
    let mut fields = Vec::new();
    let mut start = 0;
    for (i, c) in line.char_indices() {
        if c == ',' {
            fields.push((start + 1, &line[start..i]));
            start = i + 1;
        }
    }
    fields.push((start + 1, &line[start..]));
    fields
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_interpolates() {
        let text = "# a press\r\nt,x,y,z\r\n0,0,0,0.01\r\n\r\n1,0,0,-0.01\r\n2, 0.5 ,0,-0.01\n";
        let tr = Trajectory::parse(text, "press.csv").unwrap();
        assert_eq!(tr.len(), 3);
        assert_eq!(tr.position_at(-1.0), DVec3::new(0.0, 0.0, 0.01));
        assert!((tr.position_at(0.25) - DVec3::new(0.0, 0.0, 0.005)).length() < 1e-15);
        assert!((tr.position_at(1.5) - DVec3::new(0.25, 0.0, -0.01)).length() < 1e-15);
        assert_eq!(tr.position_at(10.0), DVec3::new(0.5, 0.0, -0.01));
        assert_eq!(tr.position_at(1.0), DVec3::new(0.0, 0.0, -0.01));
    }

    fn error(text: &str) -> String {
        Trajectory::parse(text, "t.csv").unwrap_err().to_string()
    }

    #[test]
    fn errors_name_line_and_column() {
        assert_eq!(error(""), "t.csv:1:1: error: empty trajectory: expected the header `t,x,y,z`");
        assert_eq!(
            error("time,x,y,z\n"),
            "t.csv:1:1: error: expected the header `t,x,y,z`, found `time,x,y,z`"
        );
        assert_eq!(error("t,x,y,z\n0,1,2\n"), "t.csv:2:6: error: expected 4 values (t,x,y,z), found 3");
        assert_eq!(error("t,x,y,z\n0,1,2,3,4\n"), "t.csv:2:9: error: expected 4 values (t,x,y,z), found 5");
        assert_eq!(error("t,x,y,z\n0,1,abc,3\n"), "t.csv:2:5: error: `abc` is not a number");
        assert_eq!(error("t,x,y,z\n0,1, ,3\n"), "t.csv:2:6: error: missing value for `y`");
        assert_eq!(error("t,x,y,z\n0,1,2,inf\n"), "t.csv:2:7: error: `inf` is not a finite number");
        assert_eq!(error("t,x,y,z\n0,1,2,NaN\n"), "t.csv:2:7: error: `NaN` is not a finite number");
        assert_eq!(
            error("t,x,y,z\n1,0,0,0\n1,0,0,0\n"),
            "t.csv:3:1: error: time 1 is not after the previous sample's 1"
        );
        assert_eq!(error("t,x,y,z\n"), "t.csv:2:1: error: the trajectory has a header but no samples");
    }

    proptest::proptest! {
        #[test]
        fn parsing_never_panics(text in ".{0,200}") {
            let _ = Trajectory::parse(&text, "fuzz.csv");
        }

        #[test]
        fn interpolation_stays_between_samples(t in -1.0f64..3.0) {
            let tr = Trajectory::parse("t,x,y,z\n0,0,0,0\n1,1,2,3\n2,0,0,0\n", "p.csv").unwrap();
            let p = tr.position_at(t);
            proptest::prop_assert!(p.x >= 0.0 && p.x <= 1.0 && p.y <= 2.0 && p.z <= 3.0);
        }
    }
}
