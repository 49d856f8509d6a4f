//! `baro.csv`: barometric altitude from the flight controller (`t_ns,altitude_m`).
//!
//! The altitude is the barometer's pressure altitude in metres above an arbitrary datum (it
//! carries a per-flight offset and a slow drift): only its changes are meaningful. Time is on the
//! IMU clock, integer nanoseconds.

use std::io::{self, BufRead, Write};

use crate::time::Timestamp;

/// The header line.
pub const HEADER: &str = "t_ns,altitude_m";

/// One barometer reading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaroSample {
    /// Time on the IMU clock.
    pub t: Timestamp,
    /// Barometric altitude above the barometer's datum, m.
    pub altitude_m: f64,
}

/// A line of `baro.csv` that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum BaroCsvError {
    /// Reading failed.
    #[error("reading the barometer CSV: {0}")]
    Io(#[from] io::Error),
    /// A row is malformed or time does not increase.
    #[error("line {line}: {reason}")]
    Row {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        reason: String,
    },
}

/// Writes samples with the header; floats in shortest round-trip form.
pub fn write(out: &mut impl Write, samples: &[BaroSample]) -> io::Result<()> {
    writeln!(out, "{HEADER}")?;
    for s in samples {
        writeln!(out, "{},{}", s.t.as_nanos(), s.altitude_m)?;
    }
    Ok(())
}

/// Reads samples: the header (or any line starting with `#` or `t_ns`) and blank lines are
/// skipped; every other line holds an integer time in ns and a finite altitude, with strictly
/// increasing time.
pub fn read(input: impl BufRead) -> Result<Vec<BaroSample>, BaroCsvError> {
    let mut out: Vec<BaroSample> = Vec::new();
    for (i, line) in input.lines().enumerate() {
        let line = line?;
        let number = i + 1;
        let text = line.trim();
        if text.is_empty() || text.starts_with('#') || text.starts_with("t_ns") {
            continue;
        }
        let row = |reason: String| BaroCsvError::Row {
            line: number,
            reason,
        };
        let fields: Vec<&str> = text.split(',').map(str::trim).collect();
        let [t, altitude] = fields[..] else {
            return Err(row(format!("{} fields, expected 2", fields.len())));
        };
        let t_ns: i64 = t
            .parse()
            .map_err(|_| row(format!("time {t:?} is not an integer number of ns")))?;
        if !Timestamp(t_ns).is_in_range() {
            return Err(row(format!(
                "time {t_ns} ns is 146 years or more from the clock's origin"
            )));
        }
        let altitude_m = altitude
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| row(format!("altitude {altitude:?} is not a finite number")))?;
        if let Some(prev) = out.last()
            && prev.t.as_nanos() >= t_ns
        {
            return Err(row(format!(
                "time {t_ns} ns is not after the previous one ({} ns)",
                prev.t.as_nanos()
            )));
        }
        out.push(BaroSample {
            t: Timestamp(t_ns),
            altitude_m,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_is_exact_and_bad_rows_name_their_line() {
        let samples: Vec<BaroSample> = (0..4)
            .map(|k| BaroSample {
                t: Timestamp(k * 40_000_000),
                altitude_m: 101.3 + 1.0 / 3.0 * k as f64,
            })
            .collect();
        let mut buf = Vec::new();
        write(&mut buf, &samples).unwrap();
        assert_eq!(read(buf.as_slice()).unwrap(), samples);
        for (text, line, what) in [
            ("t_ns,altitude_m\n1,2\n2,x\n", 3, "altitude"),
            ("1,2\n1,3\n", 2, "not after"),
            ("1,2,3\n", 1, "3 fields"),
            ("1.5,2\n", 1, "integer"),
            ("1,inf\n", 1, "finite"),
            ("-9223372036854775808,2\n", 1, "146 years"),
        ] {
            match read(text.as_bytes()) {
                Err(BaroCsvError::Row { line: l, reason }) => {
                    assert_eq!(l, line, "{text:?}");
                    assert!(reason.contains(what), "{reason}");
                }
                other => panic!("{text:?}: {other:?}"),
            }
        }
    }
}
