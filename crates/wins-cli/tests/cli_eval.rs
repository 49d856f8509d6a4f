//! `wins eval` end to end: a truth and a rigidly moved, noisy, subsampled estimate on disk.

// Tests, benchmarks and examples stop at the line that failed and print what they measure.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::print_stdout,
    clippy::print_stderr
)]

use std::path::PathBuf;

use wins::dataset::truth::Truth;

mod common;
use common::{s, stderr, wins};

fn temp_dir(name: &str) -> PathBuf {
    common::fresh_dir("eval", name)
}

/// A pose as TUM numbers: t [s], p [m], q = [x, y, z, w].
#[derive(Clone, Copy)]
struct Row {
    t: f64,
    p: [f64; 3],
    q: [f64; 4],
}

/// Hamilton product `a ⊗ b` of [x, y, z, w] quaternions.
fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    let ([ax, ay, az, aw], [bx, by, bz, bw]) = (a, b);
    [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]
}

/// `q ⊗ (0, v) ⊗ q*`.
fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let conj = [-q[0], -q[1], -q[2], q[3]];
    let r = quat_mul(quat_mul(q, [v[0], v[1], v[2], 0.0]), conj);
    [r[0], r[1], r[2]]
}

/// The rigid transform `est_world_from_truth_world` of the tests: 0.8 rad about the vertical
/// (what an inertial estimate's world may differ by: its heading and origin).
fn est_from_truth() -> ([f64; 4], [f64; 3]) {
    let (s, c) = 0.4f64.sin_cos();
    ([0.0, 0.0, s, c], [3.0, -2.0, 0.7])
}

/// A tilted world: 0.8 rad about (1, 2, 3)/√14.
fn tilted() -> [f64; 4] {
    let (half, n) = (0.4f64, 14f64.sqrt());
    let (s, c) = half.sin_cos();
    [s / n, 2.0 * s / n, 3.0 * s / n, c]
}

/// Moves a truth pose into the estimate's world and adds a position offset there.
fn moved(row: &Row, noise: [f64; 3]) -> Row {
    let (q, t) = est_from_truth();
    let p = rotate(q, row.p);
    Row {
        t: row.t,
        p: [0, 1, 2].map(|k| p[k] + t[k] + noise[k]),
        q: quat_mul(q, row.q),
    }
}

fn tum(rows: &[Row]) -> String {
    let mut text = String::from("# timestamp tx ty tz qx qy qz qw\n");
    for r in rows {
        text += &format!(
            "{:.9} {} {} {} {} {} {} {}\n",
            r.t, r.p[0], r.p[1], r.p[2], r.q[0], r.q[1], r.q[2], r.q[3]
        );
    }
    text
}

/// Deterministic zero-mean noise in [−a, a] (a 64-bit LCG; no RNG crate in this test binary).
fn noise(state: &mut u64, a: f64) -> [f64; 3] {
    [0; 3].map(|_| {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * a
    })
}

/// 200 Hz truth: a 3 m circle with a height oscillation, yaw along the circle.
fn truth_rows(seconds: usize) -> Vec<Row> {
    (0..seconds * 200)
        .map(|k| {
            let t = k as f64 / 200.0;
            let a = 0.4 * t;
            let yaw = a + std::f64::consts::FRAC_PI_2;
            Row {
                t: 100.0 + t,
                p: [3.0 * a.cos(), 3.0 * a.sin(), 1.5 + 0.4 * (3.0 * a).sin()],
                q: [0.0, 0.0, (yaw / 2.0).sin(), (yaw / 2.0).cos()],
            }
        })
        .collect()
}

#[test]
fn eval_of_a_moved_noisy_estimate() {
    let dir = temp_dir("tum");
    let truth = truth_rows(30);
    let mut state = 7;
    // 50 Hz from 2 s on, ±2 cm uniform noise, then two poses after the truth ends.
    let mut est: Vec<Row> = truth[400..].iter().step_by(4).copied().collect();
    let mut noise_sq = 0.0;
    for r in &mut est {
        let n = noise(&mut state, 0.02);
        noise_sq += n.iter().map(|x| x * x).sum::<f64>();
        *r = moved(r, n);
    }
    let rms = (noise_sq / est.len() as f64).sqrt();
    let evaluated = est.len();
    for dt in [0.5, 1.0] {
        let mut late = est[est.len() - 1];
        late.t += dt;
        est.push(late);
    }
    let (truth_path, est_path) = (dir.join("truth.tum"), dir.join("est.tum"));
    std::fs::write(&truth_path, tum(&truth)).expect("write truth");
    std::fs::write(&est_path, tum(&est)).expect("write est");
    let json_path = dir.join("metrics.json");

    let out = wins(&[
        "eval",
        s(&est_path),
        s(&truth_path),
        "--json",
        "--out",
        s(&json_path),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let m: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    let file: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json_path).expect("metrics.json")).expect("JSON");
    assert_eq!(m, file);

    assert_eq!(m["poses_evaluated"], evaluated);
    assert_eq!(m["poses_unmatched"], 2);
    // Alignment can only lower the error below the noise's RMS, and with 1400 poses by little.
    let ate = m["ate_rmse_m"].as_f64().expect("ate");
    assert!(ate <= rms && ate > 0.98 * rms, "ATE {ate}, noise RMS {rms}");
    assert_eq!(m["position_error_rmse_m"], m["ate_rmse_m"]);
    assert!(m["attitude_error_rmse_deg"].as_f64().expect("att") < 0.1);
    assert!((m["convergence_time_s"].as_f64().expect("conv") - 2.0).abs() < 1e-9);
    // |v| = 0.4·√(3² + 1.2²) m/s.
    let v = m["max_speed_m_s"].as_f64().expect("speed");
    assert!((v - 0.4 * (9.0f64 + 1.44).sqrt()).abs() < 1e-3, "{v}");
    assert!(m["packets_used"].is_null() && m["aoa_error_median_deg"].is_null());
    // The alignment is the inverse of the applied transform: it maps the estimate's origin to
    // −Rᵀt in the truth world.
    let (q, t) = est_from_truth();
    let q_inv = [-q[0], -q[1], -q[2], q[3]];
    let expected = rotate(q_inv, t.map(|x| -x));
    for k in 0..3 {
        let got = m["alignment"]["translation_m"][k].as_f64().expect("t");
        assert!((got - expected[k]).abs() < 5e-3, "{got} vs {}", expected[k]);
    }

    let out = wins(&["eval", s(&est_path), s(&truth_path), "--rpe-delta", "5"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8(out.stdout).expect("utf-8");
    assert!(
        text.contains("ATE") && text.contains("2 unmatched"),
        "{text}"
    );
    assert!(text.contains("Δ 5 frames"), "{text}");

    // The error from a time on, under the same alignment: the later half's poses (less the two
    // unmatched ones at the end), at about the noise's RMS.
    let from = est[est.len() / 2].t;
    let later = est.iter().filter(|r| r.t >= from - 1e-9).count() - 2;
    let from_arg = format!("{from}");
    let out = wins(&[
        "eval",
        s(&est_path),
        s(&truth_path),
        "--json",
        "--from",
        &from_arg,
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let m: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    assert_eq!(m["position_error_from"]["poses"], later);
    let late = m["position_error_from"]["rmse_m"].as_f64().expect("rmse");
    assert!(
        late > 0.8 * rms && late < 1.2 * rms,
        "{late} against noise RMS {rms}"
    );
    let out = wins(&["eval", s(&est_path), s(&truth_path), "--from", &from_arg]);
    let text = String::from_utf8(out.stdout).expect("utf-8");
    assert!(text.contains("position error from"), "{text}");
    let out = wins(&["eval", s(&est_path), s(&truth_path), "--from", "1e6"]);
    let text = String::from_utf8(out.stdout).expect("utf-8");
    assert!(text.contains("no pose"), "{text}");
    let out = wins(&["eval", s(&est_path), s(&truth_path), "--from", "NaN"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("--from"), "{}", stderr(&out));
}

#[test]
fn eval_errors_are_reported() {
    let dir = temp_dir("bad");
    // A straight level line: the rotation about it is undefined by the positions (any rotation
    // allowed), its heading is not; a climb straight up fixes no heading. Both take what the
    // positions leave from the attitudes, unless those disagree too (every other one a half turn
    // about the vertical off).
    let line = |p: fn(f64) -> [f64; 3], torn: bool| -> Vec<Row> {
        (0..100)
            .map(|k| Row {
                t: k as f64 * 0.01,
                p: p(k as f64 * 0.1),
                q: if torn && k % 2 == 1 {
                    [0.0, 0.0, 1.0, 0.0]
                } else {
                    [0.0, 0.0, 0.0, 1.0]
                },
            })
            .collect()
    };
    let path = dir.join("line.tum");
    std::fs::write(&path, tum(&line(|x| [x, 0.0, 1.0], false))).expect("write");
    assert!(
        wins(&["eval", s(&path), s(&path), "--align", "se3"])
            .status
            .success()
    );
    assert!(wins(&["eval", s(&path), s(&path)]).status.success());
    let torn = dir.join("line-torn.tum");
    std::fs::write(&torn, tum(&line(|x| [x, 0.0, 1.0], true))).expect("write");
    let out = wins(&["eval", s(&torn), s(&path), "--align", "se3"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("collinear"), "{}", stderr(&out));
    let climb = dir.join("climb.tum");
    std::fs::write(&climb, tum(&line(|z| [1.0, 2.0, z], false))).expect("write");
    assert!(wins(&["eval", s(&climb), s(&climb)]).status.success());
    let torn_climb = dir.join("climb-torn.tum");
    std::fs::write(&torn_climb, tum(&line(|z| [1.0, 2.0, z], true))).expect("write");
    let out = wins(&["eval", s(&torn_climb), s(&climb)]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("horizontally"), "{}", stderr(&out));

    let out = wins(&["eval", s(&path), s(&path), "--aps", s(&path)]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("dataset directory"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn eval_against_a_dataset_with_ap_estimates() {
    let dir = temp_dir("dataset");
    let ds = dir.join("ds");
    let out = wins(&[
        "simulate",
        "--scenario",
        "paper-circle",
        "--duration",
        "3",
        "--airborne",
        "--out",
        s(&ds),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let truth = Truth::load(&ds).expect("truth");
    let rows: Vec<Row> = truth
        .poses
        .iter()
        .step_by(4)
        .map(|p| {
            let q = p.world_from_body.quaternion();
            let row = Row {
                t: p.t.as_secs_f64(),
                p: [p.p_b_in_w.x, p.p_b_in_w.y, p.p_b_in_w.z],
                q: [q.i, q.j, q.k, q.w],
            };
            moved(&row, [0.0; 3])
        })
        .collect();
    let est_path = dir.join("est.tum");
    std::fs::write(&est_path, tum(&rows)).expect("write est");
    // The AP estimate is 0.25 m off along the truth's x, expressed in the estimate's world.
    let ap = &truth.aps[0];
    let (q, t) = est_from_truth();
    let p = rotate(q, [ap.x_m + 0.25, ap.y_m, ap.z_m]);
    let aps_path = dir.join("aps.csv");
    std::fs::write(
        &aps_path,
        format!(
            "name,x_m,y_m,z_m\n{},{},{},{}\n",
            ap.name,
            p[0] + t[0],
            p[1] + t[1],
            p[2] + t[2]
        ),
    )
    .expect("write aps");

    let out = wins(&[
        "eval",
        s(&est_path),
        s(&ds),
        "--aps",
        s(&aps_path),
        "--json",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let m: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert!(m["ate_rmse_m"].as_f64().expect("ate") < 1e-9, "{m}");
    let ap_error = m["ap_position_error_m"][&ap.name]
        .as_f64()
        .expect("AP error");
    assert!((ap_error - 0.25).abs() < 1e-9, "{ap_error}");
    // paper-circle flies at 1.27 m/s.
    let v = m["max_speed_m_s"].as_f64().expect("speed");
    assert!((v - 1.27).abs() < 0.05, "{v}");
    // The truth folder itself scores the same.
    let out = wins(&[
        "eval",
        s(&est_path),
        s(&ds.join("truth")),
        "--aps",
        s(&aps_path),
        "--json",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let folder: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(folder["ap_position_error_m"], m["ap_position_error_m"]);
    assert_eq!(folder["ate_rmse_m"], m["ate_rmse_m"]);
}

/// With the covariance reported beside the estimate (`covariance.csv`, as `wins run` writes it)
/// the position NEES is scored: noise uniform in ±a reported as a²/3 per axis gives about 3.
#[test]
fn eval_scores_the_nees_of_the_covariance_beside_the_estimate() {
    let dir = temp_dir("nees");
    let truth = truth_rows(60);
    let truth_path = dir.join("truth.tum");
    std::fs::write(&truth_path, tum(&truth)).expect("write truth");
    let mut state = 7;
    let a = 0.3;
    let est: Vec<Row> = truth
        .iter()
        .step_by(4)
        .map(|r| moved(r, noise(&mut state, a)))
        .collect();
    let est_path = dir.join("trajectory.tum");
    std::fs::write(&est_path, tum(&est)).expect("write est");
    let var = a * a / 3.0;
    let mut cov = String::from(
        "t_s,c_x_x,c_x_y,c_x_z,c_x_rx,c_x_ry,c_x_rz,c_y_y,c_y_z,c_y_rx,c_y_ry,c_y_rz,c_z_z,\
         c_z_rx,c_z_ry,c_z_rz,c_rx_rx,c_rx_ry,c_rx_rz,c_ry_ry,c_ry_rz,c_rz_rz\n",
    );
    for r in &est {
        cov += &format!(
            "{:.9},{var:e},0,0,0,0,0,{var:e},0,0,0,0,{var:e},0,0,0,1e-4,0,0,1e-4,0,1e-4\n",
            r.t
        );
    }
    std::fs::write(dir.join("covariance.csv"), &cov).expect("write covariance");
    let out = wins(&["eval", s(&est_path), s(&truth_path), "--json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let m: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let nees = m["position_nees_mean"].as_f64().expect("NEES");
    assert!((2.6..3.4).contains(&nees), "{nees}");
    // Four times the variance reported: a quarter of the NEES.
    let out = wins(&[
        "eval",
        s(&est_path),
        s(&truth_path),
        "--json",
        "--covariance",
        s(&dir.join("wide.csv")),
    ]);
    assert!(
        !out.status.success(),
        "a missing --covariance file is an error"
    );
    let wide = cov.replace(&format!("{var:e}"), &format!("{:e}", 4.0 * var));
    std::fs::write(dir.join("wide.csv"), wide).expect("write");
    let out = wins(&[
        "eval",
        s(&est_path),
        s(&truth_path),
        "--json",
        "--covariance",
        s(&dir.join("wide.csv")),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let m: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let quarter = m["position_nees_mean"].as_f64().expect("NEES");
    assert!(
        (quarter * 4.0 - nees).abs() < 1e-6 * nees,
        "{quarter} {nees}"
    );
    // The figures: with a covariance the σ band, without a run's aoa.csv no AoA figure.
    let figures = dir.join("figures");
    let out = wins(&[
        "eval",
        s(&est_path),
        s(&truth_path),
        "--figures",
        s(&figures),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    for f in [
        "trajectory.png",
        "height.png",
        "attitude.png",
        "sigma.png",
        "position_error.png",
    ] {
        assert!(figures.join(f).is_file(), "{f}");
    }
    assert!(!figures.join("aoa.png").exists());
    // A cell that is not a number is named.
    std::fs::write(
        dir.join("covariance.csv"),
        cov.replacen(&format!("{var:e}"), "x", 1),
    )
    .expect("write");
    let out = wins(&["eval", s(&est_path), s(&truth_path)]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("covariance, row 1"),
        "{}",
        stderr(&out)
    );
}

/// The default alignment turns the estimate about the vertical only: an estimate in a tilted
/// world (gravity misplaced) keeps its error, which `--align se3` (evo's `-a`) rotates away.
#[test]
fn the_default_alignment_turns_only_the_heading() {
    let dir = temp_dir("tilted");
    let truth = truth_rows(20);
    let est: Vec<Row> = truth
        .iter()
        .step_by(4)
        .map(|r| Row {
            t: r.t,
            p: rotate(tilted(), r.p),
            q: quat_mul(tilted(), r.q),
        })
        .collect();
    let (truth_path, est_path) = (dir.join("truth.tum"), dir.join("est.tum"));
    std::fs::write(&truth_path, tum(&truth)).expect("write truth");
    std::fs::write(&est_path, tum(&est)).expect("write est");
    let ate = |extra: &[&str]| {
        let mut args = vec!["eval", s(&est_path), s(&truth_path), "--json"];
        args.extend_from_slice(extra);
        let out = wins(&args);
        assert!(out.status.success(), "{}", stderr(&out));
        let m: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
        (
            m["ate_rmse_m"].as_f64().expect("ate"),
            m["attitude_error_rmse_deg"].as_f64().expect("attitude"),
        )
    };
    let (posyaw, posyaw_deg) = ate(&[]);
    assert_eq!((posyaw, posyaw_deg), ate(&["--align", "posyaw"]));
    assert!(
        posyaw > 0.5 && posyaw_deg > 20.0,
        "{posyaw} m, {posyaw_deg}°"
    );
    let (se3, se3_deg) = ate(&["--align", "se3"]);
    assert!(se3 < 1e-9 && se3_deg < 1e-6, "{se3} m, {se3_deg}°");
    let out = wins(&["eval", s(&est_path), s(&truth_path), "--align", "sim3"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("posyaw"), "{}", stderr(&out));
}

/// The bound in the CSV `wins bound --csv` wrote: its one row's `ate_bound_m`.
fn bound_of(path: &std::path::Path) -> f64 {
    let text = std::fs::read_to_string(path).expect("bound CSV");
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("dataset,ate_bound_m,last_sigma_m,worst_ap_sigma_m,bearings")
    );
    let row: Vec<&str> = lines.next().expect("a row").split(',').collect();
    assert_eq!(lines.next(), None);
    row[1].parse().expect("a number")
}

#[test]
fn bound_gives_each_flight_its_lowest_reachable_error() {
    let dir = temp_dir("bound");
    let ds = dir.join("ds");
    let out = wins(&[
        "simulate",
        "--scenario",
        "paper-circle",
        "--duration",
        "25",
        "--out",
        s(&ds),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let csv = dir.join("bound.csv");
    let out = wins(&["bound", s(&ds), "--csv", s(&csv)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(String::from_utf8_lossy(&out.stdout).contains("ATE bound (m)"));
    let sharp = bound_of(&csv);
    assert!(sharp > 0.0 && sharp < 0.5, "{sharp}");
    let out = wins(&[
        "bound",
        s(&ds),
        "--csv",
        s(&csv),
        "--bearing-sigma-deg",
        "3",
        "--bearing-correlation-s",
        "0.5",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        bound_of(&csv) > 1.3 * sharp,
        "{} vs {sharp}",
        bound_of(&csv)
    );

    // The CSV is never written over the dataset's own files.
    let manifest = ds.join("dataset.toml");
    let before = std::fs::read(&manifest).expect("manifest");
    let out = wins(&["bound", s(&ds), "--csv", s(&manifest)]);
    assert!(!out.status.success());
    assert_eq!(std::fs::read(&manifest).expect("manifest"), before);

    // No truth: refused by name.
    std::fs::remove_dir_all(ds.join("truth")).expect("remove truth");
    let out = wins(&["bound", s(&ds)]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("truth"), "{}", stderr(&out));
    let out = wins(&["bound", s(&ds), "--bearing-sigma-deg", "0"]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("--bearing-sigma-deg"),
        "{}",
        stderr(&out)
    );
}
