//! `imu.csv`: EuRoC-style IMU samples (`#timestamp [ns]`, gyro xyz rad/s, accel xyz m/s²).

use std::io::{self, BufRead, Read, Write};

use nalgebra::Vector3;

use crate::imu::ImuSample;
use crate::time::Timestamp;

/// The header line, exactly as the EuRoC MAV datasets write it.
pub const HEADER: &str = "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]";

/// A line of an IMU CSV that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ImuCsvError {
    /// Reading failed.
    #[error("reading the IMU CSV: {0}")]
    Io(#[from] io::Error),
    /// A row is malformed.
    #[error("line {line}: {reason}")]
    Row {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        reason: String,
    },
}

/// Writes samples with the EuRoC header; floats in shortest round-trip form, so reading back is
/// exact.
pub fn write(out: &mut impl Write, samples: &[ImuSample]) -> io::Result<()> {
    writeln!(out, "{HEADER}")?;
    for s in samples {
        write_row(out, s)?;
    }
    Ok(())
}

/// Writes one sample's row (after the header [`HEADER`]), exact on reading back.
pub fn write_row(out: &mut impl Write, s: &ImuSample) -> io::Result<()> {
    let (g, a) = (&s.gyro_rad_s, &s.accel_m_s2);
    writeln!(
        out,
        "{},{},{},{},{},{},{}",
        s.t.as_nanos(),
        g.x,
        g.y,
        g.z,
        a.x,
        a.y,
        a.z
    )
}

/// The rows of an IMU CSV in file order, before any check of their values or times
/// ([`crate::dataset::checks`] counts and drops what cannot be used).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImuRows {
    /// Every row that holds 7 numbers (values may be non-finite; times in file order).
    pub samples: Vec<ImuSample>,
    /// The 1-based line of each of `samples`.
    pub lines: Vec<usize>,
    /// The 1-based line of a last row that had no line end and was dropped (a file cut while it
    /// was written: its last number may be cut short too).
    pub cut_last_line: Option<usize>,
}

/// Reads rows. Lines starting with `#` and blank lines are skipped; every other line must hold
/// 7 numbers (integer ns, then 6 floats, `NaN` and `inf` allowed here). A last line without a
/// line end is dropped and reported.
pub fn read_rows(input: impl BufRead) -> Result<ImuRows, ImuCsvError> {
    let mut out = ImuRows::default();
    let mut reader = RowReader::new(input);
    while let Some(sample) = reader.next_row()? {
        out.samples.push(sample);
        out.lines.push(reader.line());
    }
    out.cut_last_line = reader.cut_last_line();
    Ok(out)
}

/// Reads an IMU CSV one row at a time ([`read_rows`]'s rules), holding one line.
#[derive(Debug)]
pub struct RowReader<R> {
    input: R,
    line: String,
    number: usize,
    cut_last_line: Option<usize>,
    done: bool,
}

impl<R: BufRead> RowReader<R> {
    /// A reader at the first line.
    pub fn new(input: R) -> Self {
        Self {
            input,
            line: String::new(),
            number: 0,
            cut_last_line: None,
            done: false,
        }
    }

    /// The 1-based line of the row last returned.
    pub fn line(&self) -> usize {
        self.number
    }

    /// After the end: the 1-based line of a last row without a line end (dropped).
    pub fn cut_last_line(&self) -> Option<usize> {
        self.cut_last_line
    }

    /// The next row, or `None` at the end of the file.
    pub fn next_row(&mut self) -> Result<Option<ImuSample>, ImuCsvError> {
        while !self.done {
            self.number += 1;
            let number = self.number;
            if !read_line(&mut self.input, &mut self.line, number)? {
                self.done = true;
                break;
            }
            let text = self.line.trim();
            if text.is_empty() || text.starts_with('#') {
                continue;
            }
            if !self.line.ends_with('\n') {
                self.cut_last_line = Some(number);
                self.done = true;
                break;
            }
            return parse_row(text, number).map(Some);
        }
        Ok(None)
    }
}

/// One row's 7 numbers.
fn parse_row(text: &str, number: usize) -> Result<ImuSample, ImuCsvError> {
    let fields: Vec<&str> = text.split(',').map(str::trim).collect();
    if fields.len() != 7 {
        return Err(ImuCsvError::Row {
            line: number,
            reason: format!("{} fields, expected 7", fields.len()),
        });
    }
    let t_ns: i64 = fields[0].parse().map_err(|_| ImuCsvError::Row {
        line: number,
        reason: format!("timestamp {:?} is not an integer number of ns", fields[0]),
    })?;
    if !Timestamp(t_ns).is_in_range() {
        return Err(ImuCsvError::Row {
            line: number,
            reason: format!("timestamp {t_ns} ns is 146 years or more from the clock's origin"),
        });
    }
    let mut v = [0.0; 6];
    for (k, f) in fields[1..].iter().enumerate() {
        v[k] = f.parse::<f64>().map_err(|_| ImuCsvError::Row {
            line: number,
            reason: format!("field {} ({f:?}) is not a number", k + 2),
        })?;
    }
    Ok(ImuSample {
        t: Timestamp(t_ns),
        gyro_rad_s: Vector3::new(v[0], v[1], v[2]),
        accel_m_s2: Vector3::new(v[3], v[4], v[5]),
    })
}

/// Longest line of an IMU CSV, bytes (a row takes about 130): a file without line ends (a wrong
/// file, a device) is refused, not read whole into one line.
pub const MAX_LINE_BYTES: usize = 4096;

/// Reads line `number` into `line` (its end kept); `false` at the end of the input. A line longer
/// than [`MAX_LINE_BYTES`] or not UTF-8 is an error.
pub(crate) fn read_line(
    input: &mut impl BufRead,
    line: &mut String,
    number: usize,
) -> Result<bool, ImuCsvError> {
    let mut bytes = Vec::new();
    let n = input
        .take(MAX_LINE_BYTES as u64 + 1)
        .read_until(b'\n', &mut bytes)?;
    if n > MAX_LINE_BYTES {
        return Err(ImuCsvError::Row {
            line: number,
            reason: format!("longer than {MAX_LINE_BYTES} bytes (not an IMU CSV?)"),
        });
    }
    line.clear();
    line.push_str(std::str::from_utf8(&bytes).map_err(|_| ImuCsvError::Row {
        line: number,
        reason: "not UTF-8 text".into(),
    })?);
    Ok(n > 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_is_exact() {
        let samples: Vec<ImuSample> = (0..5)
            .map(|k| ImuSample {
                t: Timestamp(k * 5_000_000 + 3),
                gyro_rad_s: Vector3::new(0.1 * k as f64, -1e-7, std::f64::consts::PI),
                accel_m_s2: Vector3::new(1.0 / 3.0, 0.0, 9.806_65),
            })
            .collect();
        let mut buf = Vec::new();
        write(&mut buf, &samples).unwrap();
        assert!(buf.starts_with(HEADER.as_bytes()));
        let rows = read_rows(buf.as_slice()).unwrap();
        assert_eq!(rows.samples, samples);
        assert_eq!(rows.lines, vec![2, 3, 4, 5, 6]);
        assert_eq!(rows.cut_last_line, None);
    }

    #[test]
    fn bad_rows_name_their_line_and_a_last_line_without_an_end_is_reported() {
        let text = format!("{HEADER}\n1,0,0,0,0,0,9.8\n2,0,0,0,0,x,9.8\n");
        match read_rows(text.as_bytes()) {
            Err(ImuCsvError::Row { line: 3, reason }) => assert!(reason.contains("field 6")),
            other => panic!("{other:?}"),
        }
        assert!(matches!(
            read_rows("1,2,3\n".as_bytes()),
            Err(ImuCsvError::Row { line: 1, .. })
        ));
        // Order and values are the checks' (`dataset::checks`): kept here as read.
        let rows =
            read_rows("5,0,0,0,0,0,NaN\n4,0,0,0,0,0,9.8\n3,0,0,0,0,0,9.".as_bytes()).unwrap();
        assert_eq!(rows.samples.len(), 2);
        assert!(rows.samples[0].accel_m_s2.z.is_nan());
        assert_eq!(rows.cut_last_line, Some(3));
    }
}
