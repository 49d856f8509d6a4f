//! `imu.csv`: EuRoC-style IMU samples (`#timestamp [ns]`, gyro xyz rad/s, accel xyz m/s²).

use std::io::{self, BufRead, Write};

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
    /// Time does not increase.
    #[error("line {line}: timestamp {t_ns} ns is not after the previous one ({previous_ns} ns)")]
    NotIncreasing {
        /// 1-based line number.
        line: usize,
        /// This row's time.
        t_ns: i64,
        /// The previous row's time.
        previous_ns: i64,
    },
}

/// Writes samples with the EuRoC header; floats in shortest round-trip form, so reading back is
/// exact.
pub fn write(out: &mut impl Write, samples: &[ImuSample]) -> io::Result<()> {
    writeln!(out, "{HEADER}")?;
    for s in samples {
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
        )?;
    }
    Ok(())
}

/// Reads samples. Lines starting with `#` and blank lines are skipped; every other line must hold
/// 7 numbers (integer ns, then 6 floats) with strictly increasing time.
pub fn read(input: impl BufRead) -> Result<Vec<ImuSample>, ImuCsvError> {
    let mut out: Vec<ImuSample> = Vec::new();
    for (i, line) in input.lines().enumerate() {
        let line = line?;
        let number = i + 1;
        let text = line.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
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
        let mut v = [0.0; 6];
        for (k, f) in fields[1..].iter().enumerate() {
            v[k] = f
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| ImuCsvError::Row {
                    line: number,
                    reason: format!("field {} ({f:?}) is not a finite number", k + 2),
                })?;
        }
        if let Some(prev) = out.last()
            && prev.t.as_nanos() >= t_ns
        {
            return Err(ImuCsvError::NotIncreasing {
                line: number,
                t_ns,
                previous_ns: prev.t.as_nanos(),
            });
        }
        out.push(ImuSample {
            t: Timestamp(t_ns),
            gyro_rad_s: Vector3::new(v[0], v[1], v[2]),
            accel_m_s2: Vector3::new(v[3], v[4], v[5]),
        });
    }
    Ok(out)
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
        assert_eq!(read(buf.as_slice()).unwrap(), samples);
    }

    #[test]
    fn bad_rows_name_their_line() {
        let text = format!("{HEADER}\n1,0,0,0,0,0,9.8\n2,0,0,0,0,x,9.8\n");
        match read(text.as_bytes()) {
            Err(ImuCsvError::Row { line: 3, reason }) => assert!(reason.contains("field 6")),
            other => panic!("{other:?}"),
        }
        let text = "5,0,0,0,0,0,9.8\n5,0,0,0,0,0,9.8\n";
        assert!(matches!(
            read(text.as_bytes()),
            Err(ImuCsvError::NotIncreasing { line: 2, .. })
        ));
        assert!(matches!(
            read("1,2,3\n".as_bytes()),
            Err(ImuCsvError::Row { line: 1, .. })
        ));
    }
}
