use super::*;

#[test]
fn a_pose_time_out_of_range_is_refused_with_its_line() {
    let ok = read_tum("# t x y z qx qy qz qw\n1.5 0 0 0 0 0 0 1\n".as_bytes()).unwrap();
    assert_eq!(ok[0].t, Timestamp(1_500_000_000));
    // 1e300 s would saturate to i64::MAX ns and overflow the association's differences.
    let e = read_tum("1.5 0 0 0 0 0 0 1\n1e300 0 0 0 0 0 0 1\n".as_bytes()).unwrap_err();
    assert!(e.contains("line 2") && e.contains("146 years"), "{e}");
}

#[test]
fn a_truth_loaded_near_some_times_keeps_the_nearest_pose_of_each() {
    let dir = std::env::temp_dir().join(format!("wins-truth-near-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let pose = |ns: i64| Pose {
        t: Timestamp(ns),
        p_b_in_w: Vector3::new(ns as f64 * 1e-9, 0.0, 0.0),
        world_from_body: UnitQuaternion::identity(),
    };
    // 10 s at 200 Hz; the estimate every 20 ms, 2 ms late, and twice beyond the end.
    let all: Vec<Pose> = (0..2000).map(|i| pose(i * 5_000_000)).collect();
    let mut tum = Vec::new();
    write_tum(&mut tum, &all).unwrap();
    std::fs::write(dir.join("poses.tum"), tum).unwrap();
    let mut near: Vec<Timestamp> = (0..500)
        .map(|i| Timestamp(i * 20_000_000 + 2_000_000))
        .collect();
    near.extend([Timestamp(10_500_000_000), Timestamp(11_000_000_000)]);
    let t = Truth::load_dir_near(&dir, &near, 100_000_000).unwrap();
    assert!(t.poses.windows(2).all(|w| w[0].t < w[1].t));
    let nearest = |poses: &[Pose], at: Timestamp| {
        poses
            .iter()
            .min_by_key(|p| ((p.t.0 - at.0).abs(), p.t.0))
            .map(|p| p.t)
    };
    for &at in &near {
        assert_eq!(nearest(&t.poses, at), nearest(&all, at), "{at:?}");
    }
    // One every 100 ms besides: 100 of them, and the 502 nearest (2 ms late: the pose
    // 2 ms before, two of them the last pose).
    assert!(t.poses.len() <= 100 + 502, "{}", t.poses.len());
    assert!(t.poses.len() < all.len() / 3);
    assert!(t.imu_biases.is_empty() && t.aps.is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}
