//! The one writer of a run's trajectories, `trajectory.tum`, `trajectory_all.tum` and
//! `trajectory_sent.tum`
//! ([`TrajectoryWriter`]): a comment header, then one TUM line per pose (`t x y z qx qy qz qw`,
//! the format of [`crate::dataset::truth::write_tum`]), written as the poses come and flushed
//! explicitly at the end, so that a failed write is an error and not lost when a buffer is
//! dropped. The file is handed whole lines only ([`WholeRecords`]): a program killed while it
//! writes leaves a file that ends with a whole line. The batch run writes through it
//! ([`super::output`] from memory, [`super::spool`] as the replay goes), and so does
//! `wins live` ([`crate::live`]), which flushes it every half second.

use std::fs::File;
use std::io::{self, Write};
use std::path::Path;

use crate::dataset::truth::{Pose, write_tum_header, write_tum_pose};
use crate::fusion::pose::PoseEstimate;
use crate::io_safety::WholeRecords;

/// A frame's pose, as a trajectory file holds it.
pub(crate) fn pose_of(p: &PoseEstimate) -> Pose {
    Pose {
        t: p.t,
        p_b_in_w: p.p_b_in_w,
        world_from_body: p.world_from_body,
    }
}

/// A TUM trajectory being written: the header is written when it is made, a line per pose after.
#[derive(Debug)]
pub struct TrajectoryWriter<W: Write> {
    out: WholeRecords<W>,
    poses: usize,
}

impl TrajectoryWriter<File> {
    /// Creates (or truncates) the file at `path` and writes the header (buffered: the writer is
    /// its buffer).
    pub fn create(path: &Path) -> io::Result<Self> {
        Self::new(File::create(path)?)
    }
}

impl<W: Write> TrajectoryWriter<W> {
    /// Writes the header into `out` (best unbuffered: the writer buffers whole lines).
    pub fn new(out: W) -> io::Result<Self> {
        let mut out = WholeRecords::new(out);
        out.line(write_tum_header)?;
        Ok(Self { out, poses: 0 })
    }

    /// Writes one pose's line.
    pub fn pose(&mut self, pose: &Pose) -> io::Result<()> {
        self.out.line(|b| write_tum_pose(b, pose))?;
        self.poses += 1;
        Ok(())
    }

    /// Writes one frame's pose ([`TrajectoryWriter::pose`]).
    pub fn frame(&mut self, frame: &PoseEstimate) -> io::Result<()> {
        self.pose(&pose_of(frame))
    }

    /// Writes every frame of `frames`, in order.
    pub fn frames<'a>(
        &mut self,
        frames: impl IntoIterator<Item = &'a PoseEstimate>,
    ) -> io::Result<()> {
        frames.into_iter().try_for_each(|f| self.frame(f))
    }

    /// Poses written so far.
    pub fn poses(&self) -> usize {
        self.poses
    }

    /// Hands what is buffered (whole lines) to the file and flushes it (the writer stays
    /// usable).
    pub fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }

    /// Flushes and gives the writer back.
    pub fn finish(self) -> io::Result<W> {
        self.out.into_inner()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::truth::write_tum;
    use crate::time::Timestamp;
    use nalgebra::{UnitQuaternion, Vector3};

    #[test]
    fn the_file_is_the_tum_format_of_the_truth() {
        let poses: Vec<Pose> = (0..3)
            .map(|k| Pose {
                t: Timestamp(1_000_000_007 * k - 5),
                p_b_in_w: Vector3::new(0.1 * k as f64, -2.0, 1e-9),
                world_from_body: UnitQuaternion::from_euler_angles(0.1, 0.2 * k as f64, -0.3),
            })
            .collect();
        let mut want = Vec::new();
        write_tum(&mut want, &poses).expect("in memory");
        let mut w = TrajectoryWriter::new(Vec::new()).expect("in memory");
        for p in &poses {
            w.pose(p).expect("in memory");
        }
        assert_eq!(w.poses(), 3);
        assert_eq!(w.finish().expect("in memory"), want);
    }
}
