//! Estimated AP positions: the CSV the pipeline writes and `wins eval --aps` reads, and their
//! error after the trajectory's alignment.

use std::collections::BTreeMap;
use std::io::{self, Read, Write};

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use super::{Alignment, EvalError};
use crate::dataset::truth::{ApRow, write_csv};

/// One row of an estimated-AP CSV (`name,x_m,y_m,z_m`, then the position's covariance
/// `c_x_x,c_x_y,c_x_z,c_y_y,c_y_z,c_z_z` when known), the file the pipeline writes and `wins eval
/// --aps` reads. The first columns are those of `truth/aps.csv`, but the position is in the
/// estimate's world frame. The covariance columns may be absent or empty.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct EstimatedAp {
    /// AP name (as in `dataset.toml` and `truth/aps.csv`).
    pub name: String,
    /// Position in the estimate's world frame, m.
    pub x_m: f64,
    /// Position in the estimate's world frame, m.
    pub y_m: f64,
    /// Position in the estimate's world frame, m.
    pub z_m: f64,
    /// Covariance of the position in the estimate's world frame, m² (upper triangle).
    #[serde(default)]
    pub c_x_x: Option<f64>,
    /// See `c_x_x`.
    #[serde(default)]
    pub c_x_y: Option<f64>,
    /// See `c_x_x`.
    #[serde(default)]
    pub c_x_z: Option<f64>,
    /// See `c_x_x`.
    #[serde(default)]
    pub c_y_y: Option<f64>,
    /// See `c_x_x`.
    #[serde(default)]
    pub c_y_z: Option<f64>,
    /// See `c_x_x`.
    #[serde(default)]
    pub c_z_z: Option<f64>,
}

impl EstimatedAp {
    /// The position as a vector, m.
    pub fn position(&self) -> Vector3<f64> {
        Vector3::new(self.x_m, self.y_m, self.z_m)
    }

    /// A row with the position `p` and its covariance `c`, both in the estimate's world frame.
    pub fn with_covariance(name: &str, p: &Vector3<f64>, c: &Matrix3<f64>) -> Self {
        let finite = |x: f64| x.is_finite().then_some(x);
        Self {
            name: name.to_string(),
            x_m: p.x,
            y_m: p.y,
            z_m: p.z,
            c_x_x: finite(c[(0, 0)]),
            c_x_y: finite(c[(0, 1)]),
            c_x_z: finite(c[(0, 2)]),
            c_y_y: finite(c[(1, 1)]),
            c_y_z: finite(c[(1, 2)]),
            c_z_z: finite(c[(2, 2)]),
        }
    }

    /// The position's covariance, when every cell of it is given, m².
    pub fn covariance(&self) -> Option<Matrix3<f64>> {
        let (xx, xy, xz) = (self.c_x_x?, self.c_x_y?, self.c_x_z?);
        let (yy, yz, zz) = (self.c_y_y?, self.c_y_z?, self.c_z_z?);
        Some(Matrix3::new(xx, xy, xz, xy, yy, yz, xz, yz, zz))
    }
}

/// Writes estimated AP positions as CSV with a header.
pub fn write_estimated_aps(out: impl Write, aps: &[EstimatedAp]) -> io::Result<()> {
    write_csv(out, aps)
}

/// Reads an estimated-AP CSV (header `name,x_m,y_m,z_m`; non-finite positions rejected).
pub fn read_estimated_aps(input: impl Read) -> Result<Vec<EstimatedAp>, EvalError> {
    let mut rows = Vec::new();
    for (i, r) in csv::Reader::from_reader(input).deserialize().enumerate() {
        let row = i + 1;
        let ap: EstimatedAp = r.map_err(|e| EvalError::ApCsv {
            row,
            reason: e.to_string(),
        })?;
        if !ap.position().iter().all(|x| x.is_finite()) {
            return Err(EvalError::ApCsv {
                row,
                reason: format!("non-finite position of {}", ap.name),
            });
        }
        rows.push(ap);
    }
    Ok(rows)
}

/// Per AP name, the distance between the aligned estimate and the truth AP of that name, m. A
/// truth without APs (e.g. motion capture only) scores none.
pub(crate) fn ap_errors(
    aps: &[EstimatedAp],
    truth_aps: &[ApRow],
    alignment: &Alignment,
) -> Result<BTreeMap<String, f64>, EvalError> {
    let mut out = BTreeMap::new();
    if truth_aps.is_empty() {
        return Ok(out);
    }
    for ap in aps {
        let truth = truth_aps
            .iter()
            .find(|t| t.name == ap.name)
            .ok_or_else(|| EvalError::ApNotInTruth {
                name: ap.name.clone(),
            })?;
        let p_truth = Vector3::new(truth.x_m, truth.y_m, truth.z_m);
        let error = (alignment.apply_point(&ap.position()) - p_truth).norm();
        if out.insert(ap.name.clone(), error).is_some() {
            return Err(EvalError::DuplicateAp {
                name: ap.name.clone(),
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Isometry3, UnitQuaternion};

    fn truth_ap(name: &str, p: [f64; 3]) -> ApRow {
        ApRow {
            name: name.into(),
            x_m: p[0],
            y_m: p[1],
            z_m: p[2],
        }
    }

    #[test]
    fn csv_round_trips_and_rejects_bad_rows() {
        let aps = vec![
            EstimatedAp {
                name: "ap0".into(),
                x_m: 1.25,
                y_m: -3.0,
                z_m: 0.1,
                ..Default::default()
            },
            EstimatedAp {
                name: "ap1".into(),
                x_m: 0.0,
                y_m: 1e-17,
                z_m: 2.0,
                ..Default::default()
            },
        ];
        let mut bytes = Vec::new();
        write_estimated_aps(&mut bytes, &aps).expect("written");
        let text = String::from_utf8(bytes.clone()).expect("utf-8");
        assert!(
            text.starts_with("name,x_m,y_m,z_m,c_x_x,c_x_y,c_x_z,c_y_y,c_y_z,c_z_z\n"),
            "{text}"
        );
        assert_eq!(read_estimated_aps(bytes.as_slice()).expect("read"), aps);
        // The covariance round trips; a file without its columns reads without it.
        let c = Matrix3::new(4.0, 0.5, 0.1, 0.5, 1.0, 0.2, 0.1, 0.2, 2.0);
        let with = [EstimatedAp::with_covariance(
            "ap2",
            &Vector3::new(1.0, 2.0, 3.0),
            &c,
        )];
        let mut bytes = Vec::new();
        write_estimated_aps(&mut bytes, &with).expect("written");
        let read = read_estimated_aps(bytes.as_slice()).expect("read");
        assert_eq!(read[0].covariance(), Some(c));
        let old = read_estimated_aps("name,x_m,y_m,z_m\nap0,1,2,3\n".as_bytes()).expect("read");
        assert_eq!(old[0].covariance(), None);
        assert_eq!(old[0].position(), Vector3::new(1.0, 2.0, 3.0));

        let bad = "name,x_m,y_m,z_m\nap0,1,2,3\nap1,1,x,3\n";
        assert!(matches!(
            read_estimated_aps(bad.as_bytes()),
            Err(EvalError::ApCsv { row: 2, .. })
        ));
        let nan = "name,x_m,y_m,z_m\nap0,NaN,2,3\n";
        assert!(matches!(
            read_estimated_aps(nan.as_bytes()),
            Err(EvalError::ApCsv { row: 1, .. })
        ));
    }

    #[test]
    fn ap_error_is_measured_after_the_alignment() {
        // The estimate's world is the truth's moved by `est_from_truth`; the estimate of ap0 is
        // exact, that of ap1 is 0.3 m off along the truth's z.
        let est_from_truth = Isometry3::from_parts(
            Vector3::new(4.0, -1.0, 0.5).into(),
            UnitQuaternion::from_euler_angles(0.1, -0.2, 2.0),
        );
        let alignment = Alignment::from_isometry(&est_from_truth.inverse());
        let truth = [
            truth_ap("ap0", [6.0, 0.0, 2.0]),
            truth_ap("ap1", [6.0, 3.0, 1.0]),
        ];
        let est = |name: &str, p: Vector3<f64>| {
            let q = est_from_truth.transform_point(&p.into());
            EstimatedAp {
                name: name.into(),
                x_m: q.x,
                y_m: q.y,
                z_m: q.z,
                ..Default::default()
            }
        };
        let aps = [
            est("ap1", Vector3::new(6.0, 3.0, 1.3)),
            est("ap0", Vector3::new(6.0, 0.0, 2.0)),
        ];
        let errors = ap_errors(&aps, &truth, &alignment).expect("errors");
        assert_eq!(errors.len(), 2);
        assert!(errors["ap0"] < 1e-12, "{errors:?}");
        assert!((errors["ap1"] - 0.3).abs() < 1e-12, "{errors:?}");
        // Without the alignment the error would be that of the frames.
        let raw = ap_errors(&aps, &truth, &Alignment::identity()).expect("errors");
        assert!(raw["ap0"] > 1.0);

        assert!(matches!(
            ap_errors(&[est("ap9", Vector3::zeros())], &truth, &alignment),
            Err(EvalError::ApNotInTruth { name }) if name == "ap9"
        ));
        let twice = [aps[1].clone(), aps[1].clone()];
        assert!(matches!(
            ap_errors(&twice, &truth, &alignment),
            Err(EvalError::DuplicateAp { .. })
        ));
        assert!(ap_errors(&[], &truth, &alignment).expect("none").is_empty());
    }
}
