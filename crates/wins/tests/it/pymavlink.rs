//! Our MAVLink bytes against pymavlink, the reference implementation
//! (`scripts/pymavlink_check.py`): pymavlink's IMU and pressure messages through our inbound
//! decoder, and our ODOMETRY / VISION_POSITION_ESTIMATE through pymavlink's parser; with MAVLink 2
//! signing, our signed messages through pymavlink's check and pymavlink's through ours.
//!
//! The Python is `$WINS_PYTHON` (then any failure fails the test, as in CI); without it, `python3`
//! when it has pymavlink, else the test says it is skipped.

use std::path::{Path, PathBuf};
use std::process::Command;

use mavlink::dialects::common::{MavMessage, ODOMETRY_DATA};
use mavlink::{MAVLinkMessageRaw, MavHeader, MavlinkReader, MavlinkVersion};
use nalgebra::{Matrix3, Matrix6, UnitQuaternion, Vector3};
use serde_json::Value;
use wins::fusion::pose::PoseEstimate;
use wins::live::mavlink::inbound::{
    InboundDecoder, STANDARD_GRAVITY_M_S2, STANDARD_SEA_LEVEL_PA, pressure_altitude_m,
};
use wins::live::mavlink::link::DEFAULT_COMPONENT_ID;
use wins::live::mavlink::outbound::{OdometryExtras, odometry, vision_position_estimate};
use wins::live::mavlink::signing::{MavlinkKey, Refusal, Signer};
use wins::time::Timestamp;

fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts/pymavlink_check.py")
}

/// The Python to run, or `None` (with the skip line printed) when none has pymavlink.
fn python() -> Option<String> {
    if let Ok(python) = std::env::var("WINS_PYTHON") {
        return Some(python);
    }
    let has_pymavlink = Command::new("python3")
        .args(["-c", "import pymavlink"])
        .output()
        .is_ok_and(|out| out.status.success());
    if has_pymavlink {
        Some("python3".to_string())
    } else {
        println!("skipped: pymavlink not installed (see scripts/pymavlink_check.py)");
        None
    }
}

/// Runs the script; its stdout as JSON.
fn run(python: &str, args: &[&str]) -> Value {
    let out = Command::new(python)
        .arg(script())
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {python}: {e}"));
    assert!(
        out.status.success(),
        "{python} {} {args:?} failed: {}",
        script().display(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wins-pymavlink-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn f(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} missing in {v}"))
}

#[test]
fn pymavlink_imu_and_pressure_decode_with_our_decoder() {
    let Some(python) = python() else { return };
    let dir = scratch("imu");
    let bin = dir.join("imu.bin");
    let expected = run(&python, &["encode-imu", bin.to_str().unwrap()]);
    let expected = expected.as_array().unwrap();
    let bytes = std::fs::read(&bin).unwrap();
    let mut reader = MavlinkReader::new(bytes.as_slice());
    let mut decoder = InboundDecoder::default();
    let g = STANDARD_GRAVITY_M_S2;
    for want in expected {
        let (header, message) = reader
            .read_message::<MavMessage>(MavlinkVersion::V2)
            .unwrap();
        assert_eq!((header.system_id, header.component_id), (1, 1));
        let out = decoder.decode(&message);
        let kind = want["type"].as_str().unwrap();
        match kind {
            "HIGHRES_IMU" => {
                let t = Timestamp(want["time_usec"].as_i64().unwrap() * 1000);
                let bits = want["fields_updated"].as_u64().unwrap();
                if bits & 0x3F == 0x3F {
                    let imu = out.imu.unwrap();
                    assert_eq!(imu.t, t);
                    let accel = Vector3::new(f(want, "xacc"), f(want, "yacc"), f(want, "zacc"));
                    let gyro = Vector3::new(f(want, "xgyro"), f(want, "ygyro"), f(want, "zgyro"));
                    assert_eq!(imu.accel_m_s2, accel);
                    assert_eq!(imu.gyro_rad_s, gyro);
                } else {
                    assert!(out.imu.is_none(), "{want}");
                }
                if bits & 0x200 != 0 {
                    let baro = out.baro.unwrap();
                    assert_eq!(baro.t, t);
                    let pressure_pa = f(want, "abs_pressure") * 100.0;
                    assert_eq!(baro.pressure_pa, pressure_pa);
                    let altitude = pressure_altitude_m(pressure_pa, STANDARD_SEA_LEVEL_PA);
                    assert_eq!(baro.altitude_m, altitude);
                } else {
                    assert!(out.baro.is_none(), "{want}");
                }
            }
            "SCALED_IMU" => {
                let imu = out.imu.unwrap();
                assert_eq!(
                    imu.t,
                    Timestamp(want["time_boot_ms"].as_i64().unwrap() * 1_000_000)
                );
                let mg = Vector3::new(f(want, "xacc"), f(want, "yacc"), f(want, "zacc"));
                let mrad = Vector3::new(f(want, "xgyro"), f(want, "ygyro"), f(want, "zgyro"));
                assert!((imu.accel_m_s2 - mg * g / 1000.0).amax() < 1e-12);
                assert!((imu.gyro_rad_s - mrad / 1000.0).amax() < 1e-12);
            }
            "SCALED_PRESSURE" => {
                let baro = out.baro.unwrap();
                assert_eq!(
                    baro.t,
                    Timestamp(want["time_boot_ms"].as_i64().unwrap() * 1_000_000)
                );
                assert_eq!(baro.pressure_pa, f(want, "press_abs") * 100.0);
            }
            other => panic!("unexpected {other}"),
        }
    }
    assert!(
        reader
            .read_message::<MavMessage>(MavlinkVersion::V2)
            .is_err(),
        "extra bytes"
    );
    let stats = decoder.stats();
    assert_eq!((stats.imu, stats.baro, stats.refused.incomplete), (2, 3, 1));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A pose with every field non-trivial.
fn pose() -> PoseEstimate {
    let world_from_body = UnitQuaternion::from_euler_angles(0.1, -0.2, 2.5)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI);
    let a = Matrix6::from_fn(|i, j| {
        ((i * 7 + j * 3) % 5) as f64 * 0.01 + if i == j { 0.1 } else { 0.0 }
    });
    PoseEstimate {
        t: Timestamp(5_000_000_000),
        p_b_in_w: Vector3::new(1.5, -2.25, 3.125),
        v_b_in_w: Vector3::new(0.5, 0.25, -0.125),
        world_from_body,
        p_b_in_b0: Vector3::zeros(),
        b0_from_body: UnitQuaternion::identity(),
        converged: true,
        covariance: Some(a * a.transpose()),
    }
}

/// Every float of ours equals pymavlink's (f32 both ways; NaN is null on the JSON side).
fn same_floats(ours: &[f32], theirs: &Value, what: &str) {
    let theirs = theirs
        .as_array()
        .unwrap_or_else(|| panic!("{what}: not an array"));
    assert_eq!(ours.len(), theirs.len(), "{what}");
    for (k, (o, t)) in ours.iter().zip(theirs).enumerate() {
        match t.as_f64() {
            Some(t) => assert_eq!(*o, t as f32, "{what}[{k}]"),
            None => assert!(o.is_nan() && t.is_null(), "{what}[{k}]: {o} vs {t}"),
        }
    }
}

fn check_odometry(ours: &ODOMETRY_DATA, theirs: &Value) {
    assert_eq!(theirs["type"], "ODOMETRY");
    assert_eq!(theirs["time_usec"].as_u64(), Some(ours.time_usec));
    let scalars = [
        ("x", ours.x),
        ("y", ours.y),
        ("z", ours.z),
        ("vx", ours.vx),
        ("vy", ours.vy),
        ("vz", ours.vz),
        ("rollspeed", ours.rollspeed),
        ("pitchspeed", ours.pitchspeed),
        ("yawspeed", ours.yawspeed),
    ];
    let (names, values): (Vec<&str>, Vec<f32>) = scalars.into_iter().unzip();
    let theirs_scalars = Value::Array(names.iter().map(|n| theirs[*n].clone()).collect());
    same_floats(&values, &theirs_scalars, "x, y, z, vx, vy, vz, rates");
    same_floats(&ours.q, &theirs["q"], "q");
    same_floats(
        &ours.pose_covariance,
        &theirs["pose_covariance"],
        "pose_covariance",
    );
    same_floats(
        &ours.velocity_covariance,
        &theirs["velocity_covariance"],
        "velocity_covariance",
    );
    assert_eq!(theirs["frame_id"].as_u64(), Some(20), "MAV_FRAME_LOCAL_FRD");
    assert_eq!(
        theirs["child_frame_id"].as_u64(),
        Some(12),
        "MAV_FRAME_BODY_FRD"
    );
    assert_eq!(
        theirs["estimator_type"].as_u64(),
        Some(3),
        "MAV_ESTIMATOR_TYPE_VIO"
    );
    assert_eq!(
        theirs["reset_counter"].as_u64(),
        Some(u64::from(ours.reset_counter))
    );
    assert_eq!(theirs["quality"].as_i64(), Some(i64::from(ours.quality)));
    assert_eq!(theirs["src_system"].as_u64(), Some(7));
    assert_eq!(
        theirs["src_component"].as_u64(),
        Some(u64::from(DEFAULT_COMPONENT_ID))
    );
    assert_eq!(theirs["mavlink_version"].as_u64(), Some(2));
}

#[test]
fn our_odometry_decodes_the_same_in_pymavlink() {
    let Some(python) = python() else { return };
    let dir = scratch("odometry");
    let full = OdometryExtras {
        time_usec: 98_765_432_100,
        reset_counter: 4,
        quality: 87,
        angular_velocity_rad_s: Some(Vector3::new(0.01, -0.02, 0.3)),
        velocity_covariance_in_w: Some(Matrix3::new(
            0.04, 0.01, 0.0, 0.01, 0.09, 0.002, 0.0, 0.002, 0.16,
        )),
    };
    let unknown = OdometryExtras {
        time_usec: 98_765_442_100,
        reset_counter: 5,
        quality: -1,
        ..OdometryExtras::default()
    };
    let mut no_covariance = pose();
    no_covariance.covariance = None;
    let sent = [
        odometry(&pose(), &full).unwrap(),
        odometry(&no_covariance, &unknown).unwrap(),
    ];
    let vpe = vision_position_estimate(&pose(), &full).unwrap();

    let header = MavHeader {
        system_id: 7,
        component_id: DEFAULT_COMPONENT_ID,
        sequence: 0,
    };
    let mut bytes = Vec::new();
    for odom in &sent {
        let message = MavMessage::ODOMETRY(odom.clone());
        mavlink::write_versioned_msg(&mut bytes, MavlinkVersion::V2, header, &message).unwrap();
    }
    let message = MavMessage::VISION_POSITION_ESTIMATE(vpe.clone());
    mavlink::write_versioned_msg(&mut bytes, MavlinkVersion::V2, header, &message).unwrap();
    let bin = dir.join("out.bin");
    std::fs::write(&bin, &bytes).unwrap();

    let decoded = run(&python, &["decode", bin.to_str().unwrap()]);
    let decoded = decoded.as_array().unwrap();
    assert_eq!(decoded.len(), 3, "{decoded:?}");
    check_odometry(&sent[0], &decoded[0]);
    check_odometry(&sent[1], &decoded[1]);
    assert!(
        decoded[1]["pose_covariance"][0].is_null(),
        "NaN first when unknown"
    );
    assert!(decoded[1]["rollspeed"].is_null());

    let theirs = &decoded[2];
    assert_eq!(theirs["type"], "VISION_POSITION_ESTIMATE");
    assert_eq!(theirs["usec"].as_u64(), Some(vpe.usec));
    let ours = [vpe.x, vpe.y, vpe.z, vpe.roll, vpe.pitch, vpe.yaw];
    let names = ["x", "y", "z", "roll", "pitch", "yaw"];
    let theirs_values = Value::Array(names.iter().map(|n| theirs[*n].clone()).collect());
    same_floats(&ours, &theirs_values, "VISION_POSITION_ESTIMATE");
    same_floats(&vpe.covariance, &theirs["covariance"], "covariance");
    assert_eq!(theirs["reset_counter"].as_u64(), Some(4));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A key, and a file of its 64 hex digits in `dir`.
fn key_file(dir: &Path, name: &str, seed: u8) -> (MavlinkKey, PathBuf) {
    let bytes: [u8; 32] = std::array::from_fn(|i| seed.wrapping_mul(31).wrapping_add(i as u8 * 7));
    let path = dir.join(name);
    let hex: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
    std::fs::write(&path, format!("{hex}\n")).unwrap();
    let key = MavlinkKey::read(&path).unwrap();
    assert_eq!(key, MavlinkKey::from_bytes(bytes));
    (key, path)
}

#[test]
fn our_signed_messages_pass_pymavlink_with_the_key_and_fail_with_another() {
    let Some(python) = python() else { return };
    let dir = scratch("signed-out");
    let (key, key_path) = key_file(&dir, "fc.key", 1);
    let (_, other_path) = key_file(&dir, "other.key", 2);
    let signer = Signer::new(key);
    let header = MavHeader {
        system_id: 1,
        component_id: DEFAULT_COMPONENT_ID,
        sequence: 0,
    };
    let extras = OdometryExtras {
        time_usec: 98_765_432_100,
        reset_counter: 4,
        quality: 87,
        ..OdometryExtras::default()
    };
    let odom = odometry(&pose(), &extras).unwrap();
    let mut bytes = Vec::new();
    for sequence in 0..3 {
        let header = MavHeader { sequence, ..header };
        let frame = signer.sign(header, &MavMessage::ODOMETRY(odom.clone()));
        bytes.extend_from_slice(frame.raw_bytes());
    }
    // One unsigned message among them: pymavlink with a key refuses it too.
    let unsigned = MavMessage::ODOMETRY(odom.clone());
    mavlink::write_versioned_msg(&mut bytes, MavlinkVersion::V2, header, &unsigned).unwrap();
    let bin = dir.join("signed.bin");
    std::fs::write(&bin, &bytes).unwrap();

    let with_key = run(
        &python,
        &["verify", key_path.to_str().unwrap(), bin.to_str().unwrap()],
    );
    let taken = with_key["taken"].as_array().unwrap();
    assert_eq!(taken.len(), 3, "{with_key}");
    for (sequence, t) in taken.iter().enumerate() {
        assert_eq!(t["signed"], true);
        assert_eq!(t["seq"].as_u64(), Some(sequence as u64));
        check_odometry_ids(&odom, t);
    }
    assert_eq!(
        (with_key["goodsig"].as_u64(), with_key["badsig"].as_u64()),
        (Some(3), Some(0))
    );
    assert_eq!(with_key["refused"].as_u64(), Some(1), "the unsigned one");

    let other = run(
        &python,
        &[
            "verify",
            other_path.to_str().unwrap(),
            bin.to_str().unwrap(),
        ],
    );
    assert_eq!(other["taken"].as_array().map(Vec::len), Some(0), "{other}");
    assert_eq!(
        (other["badsig"].as_u64(), other["refused"].as_u64()),
        (Some(3), Some(4))
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The ODOMETRY pymavlink took is ours (its time, counter and quality) from our ids.
fn check_odometry_ids(ours: &ODOMETRY_DATA, theirs: &Value) {
    assert_eq!(theirs["type"], "ODOMETRY");
    assert_eq!(theirs["time_usec"].as_u64(), Some(ours.time_usec));
    assert_eq!(theirs["reset_counter"].as_u64(), Some(4));
    assert_eq!(theirs["quality"].as_i64(), Some(87));
    assert_eq!(theirs["src_system"].as_u64(), Some(1));
    assert_eq!(
        theirs["src_component"].as_u64(),
        Some(u64::from(DEFAULT_COMPONENT_ID))
    );
}

/// Every CRC-valid frame of `bytes`.
fn frames(bytes: &[u8]) -> Vec<MAVLinkMessageRaw> {
    let mut reader = MavlinkReader::new(bytes);
    std::iter::from_fn(|| reader.read_any_raw_message::<MavMessage>().ok()).collect()
}

#[test]
fn pymavlink_signed_messages_pass_our_check_once_and_only_with_the_key() {
    let Some(python) = python() else { return };
    let dir = scratch("signed-in");
    let (key, key_path) = key_file(&dir, "fc.key", 3);
    let (other, _) = key_file(&dir, "other.key", 4);
    let bin = dir.join("imu.bin");
    let expected = run(
        &python,
        &[
            "sign-imu",
            key_path.to_str().unwrap(),
            bin.to_str().unwrap(),
        ],
    );
    let expected = expected.as_array().unwrap();
    let bytes = std::fs::read(&bin).unwrap();
    let frames = frames(&bytes);
    assert_eq!(frames.len(), expected.len());

    let ours = Signer::new(key);
    let mut decoder = InboundDecoder::default();
    for (frame, want) in frames.iter().zip(expected) {
        let MAVLinkMessageRaw::V2(raw) = frame else {
            panic!("MAVLink 2")
        };
        assert_eq!(raw.signature_link_id(), 3);
        let (header, message) = ours.accept(frame).expect("taken").unwrap();
        assert_eq!((header.system_id, header.component_id), (1, 1));
        let kind = want["type"].as_str().unwrap();
        match (&message, kind) {
            (MavMessage::HIGHRES_IMU(m), "HIGHRES_IMU") => {
                assert_eq!(Some(m.time_usec), want["time_usec"].as_u64());
            }
            (MavMessage::SCALED_IMU(_), "SCALED_IMU")
            | (MavMessage::SCALED_PRESSURE(_), "SCALED_PRESSURE") => {}
            _ => panic!("{kind} decoded as {message:?}"),
        }
        decoder.decode_from(&header, &message);
    }
    let stats = decoder.stats();
    assert_eq!((stats.imu, stats.baro, stats.refused.incomplete), (2, 3, 1));
    // The same bytes again: replayed. Under another key: a bad signature.
    for frame in &frames {
        assert_eq!(ours.check(frame), Err(Refusal::Replayed));
    }
    let theirs_other = Signer::new(other);
    for frame in &frames {
        assert_eq!(theirs_other.check(frame), Err(Refusal::BadSignature));
    }
    let n = frames.len() as u64;
    let counts = ours.counts();
    assert_eq!((counts.accepted, counts.replayed), (n, n));
    std::fs::remove_dir_all(&dir).unwrap();
}
