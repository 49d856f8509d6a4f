//! Fixed-size binary records of what scoring a run reads, written to a file as the run produces
//! them and read back in passes ([`super::stream`]): per converged frame its pose and position
//! covariance ([`EstRecord`]), per fed packet its AoA ([`AoaRecord`]). The numbers are stored
//! bit for bit (little endian), so a pass over the file sees exactly what the run held.

use std::fs::File;
use std::io::{self, BufReader, Read, Write};
use std::path::Path;

use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

use crate::dataset::truth::Pose;
use crate::time::Timestamp;

/// A record of fixed length, encoded bit for bit.
pub(crate) trait Record: Sized {
    /// Bytes per record.
    const LEN: usize;
    /// Writes `self` into `out` (`LEN` bytes).
    fn encode(&self, out: &mut Vec<u8>);
    /// Reads a record from `bytes` (`LEN` bytes).
    fn decode(bytes: &[u8]) -> Self;
}

/// One converged frame as scoring reads it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct EstRecord {
    /// The pose.
    pub(crate) pose: Pose,
    /// Its position covariance in `w`, m² (`None`: none given).
    pub(crate) position_covariance: Option<Matrix3<f64>>,
}

/// One fed packet as scoring reads it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct AoaRecord {
    /// The AP's index.
    pub(crate) ap: usize,
    /// Arrival time, ns.
    pub(crate) t_ns: i64,
    /// Measured AoA, °.
    pub(crate) aoa_deg: Option<f64>,
}

/// The `k`-th 8 bytes of `bytes` as a `u64`.
fn word(bytes: &[u8], k: usize) -> u64 {
    let mut w = [0u8; 8];
    w.copy_from_slice(&bytes[8 * k..8 * k + 8]);
    u64::from_le_bytes(w)
}

fn float(bytes: &[u8], k: usize) -> f64 {
    f64::from_bits(word(bytes, k))
}

fn put(out: &mut Vec<u8>, x: f64) {
    out.extend_from_slice(&x.to_bits().to_le_bytes());
}

impl Record for EstRecord {
    // Time, position, quaternion, covariance: 17 words, and a flag.
    const LEN: usize = 17 * 8 + 1;

    fn encode(&self, out: &mut Vec<u8>) {
        let p = &self.pose;
        out.extend_from_slice(&p.t.as_nanos().to_le_bytes());
        p.p_b_in_w.iter().for_each(|&x| put(out, x));
        p.world_from_body.coords.iter().for_each(|&x| put(out, x));
        let c = self.position_covariance.unwrap_or_else(Matrix3::zeros);
        c.iter().for_each(|&x| put(out, x));
        out.push(u8::from(self.position_covariance.is_some()));
    }

    fn decode(bytes: &[u8]) -> Self {
        let f = |k| float(bytes, k);
        let q = Quaternion::new(f(7), f(4), f(5), f(6));
        Self {
            pose: Pose {
                t: Timestamp(word(bytes, 0) as i64),
                p_b_in_w: Vector3::new(f(1), f(2), f(3)),
                world_from_body: UnitQuaternion::new_unchecked(q),
            },
            position_covariance: (bytes[17 * 8] != 0)
                .then(|| Matrix3::from_iterator((8..17).map(f))),
        }
    }
}

impl Record for AoaRecord {
    // AP, time, AoA: 3 words, and a flag.
    const LEN: usize = 3 * 8 + 1;

    fn encode(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&(self.ap as u64).to_le_bytes());
        out.extend_from_slice(&self.t_ns.to_le_bytes());
        put(out, self.aoa_deg.unwrap_or(0.0));
        out.push(u8::from(self.aoa_deg.is_some()));
    }

    fn decode(bytes: &[u8]) -> Self {
        Self {
            ap: word(bytes, 0) as usize,
            t_ns: word(bytes, 1) as i64,
            aoa_deg: (bytes[3 * 8] != 0).then(|| float(bytes, 2)),
        }
    }
}

/// Appends records to a writer.
#[derive(Debug)]
pub(crate) struct RecordWriter<W: Write> {
    out: W,
    buf: Vec<u8>,
    written: usize,
}

impl<W: Write> RecordWriter<W> {
    /// Records into `out`.
    pub(crate) fn new(out: W) -> Self {
        Self {
            out,
            buf: Vec::new(),
            written: 0,
        }
    }

    /// Appends one record.
    pub(crate) fn push<R: Record>(&mut self, r: &R) -> io::Result<()> {
        self.buf.clear();
        r.encode(&mut self.buf);
        self.out.write_all(&self.buf)?;
        self.written += 1;
        Ok(())
    }

    /// Records appended so far.
    pub(crate) fn written(&self) -> usize {
        self.written
    }

    /// Flushes the writer.
    pub(crate) fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }
}

/// The `count` records of the file at `path`, in order (a short file is an error).
pub(crate) fn read_records<R: Record>(
    path: &Path,
    count: usize,
) -> io::Result<impl Iterator<Item = io::Result<R>>> {
    let mut input = BufReader::new(File::open(path)?);
    let mut buf = vec![0u8; R::LEN];
    Ok((0..count).map(move |_| {
        input.read_exact(&mut buf)?;
        Ok(R::decode(&buf))
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_read_back_bit_for_bit() {
        let dir = std::env::temp_dir().join(format!("wins-records-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("est.bin");
        let q = UnitQuaternion::from_euler_angles(0.1, -0.2, 2.9);
        let est = [
            EstRecord {
                pose: Pose {
                    t: Timestamp(-12_345),
                    p_b_in_w: Vector3::new(0.1, -1e-300, 7.25),
                    world_from_body: q,
                },
                position_covariance: Some(Matrix3::from_fn(|i, j| (i * 3 + j) as f64 / 7.0)),
            },
            EstRecord {
                pose: Pose {
                    t: Timestamp(99),
                    p_b_in_w: Vector3::zeros(),
                    world_from_body: q.inverse(),
                },
                position_covariance: None,
            },
        ];
        let mut w = RecordWriter::new(File::create(&path).expect("file"));
        est.iter().for_each(|r| w.push(r).expect("written"));
        w.flush().expect("flushed");
        let back: Vec<EstRecord> = read_records(&path, 2)
            .expect("opened")
            .collect::<io::Result<_>>()
            .expect("read");
        assert_eq!(back, est);
        assert!(
            read_records::<EstRecord>(&path, 3)
                .expect("opened")
                .any(|r| r.is_err())
        );
        let aoa = AoaRecord {
            ap: 2,
            t_ns: 5,
            aoa_deg: Some(-31.5),
        };
        let mut bytes = Vec::new();
        aoa.encode(&mut bytes);
        assert_eq!(
            (bytes.len(), AoaRecord::decode(&bytes)),
            (AoaRecord::LEN, aoa)
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
