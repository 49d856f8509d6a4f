//! Tests of `room`.

use super::*;

const TOL: f64 = 1e-9;

fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
    Vector3::new(x, y, z)
}

fn room(max_order: u8) -> RoomConfig {
    RoomConfig {
        size_m: [12.0, 8.0, 4.0],
        wall_reflection: 0.4,
        floor_reflection: 0.5,
        ceiling_reflection: -0.3,
        max_order,
    }
}

/// A deterministic spread of interior points, including ones near faces, edges and corners.
fn interior_points() -> Vec<Vector3<f64>> {
    let mut points = vec![
        v(1.0, 2.0, 1.5),
        v(10.0, 6.5, 3.0),
        v(6.0, 4.0, 2.0),
        v(0.01, 0.01, 0.01),
        v(11.99, 7.99, 3.99),
        v(0.05, 7.9, 2.0),
    ];
    // A simple LCG: seeded, no dependency.
    let mut state: u64 = 0x5EED_1234;
    let mut next = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((state >> 11) as f64 / (1u64 << 53) as f64).clamp(0.001, 0.999)
    };
    for _ in 0..20 {
        points.push(v(12.0 * next(), 8.0 * next(), 4.0 * next()));
    }
    points
}

fn assert_close(a: f64, b: f64, what: &str) {
    assert!((a - b).abs() < TOL, "{what}: {a} vs {b}");
}

/// Finds the path arriving from `image`, by direction and length.
fn find<'a>(paths: &'a [Path], rx: &Vector3<f64>, image: &Vector3<f64>) -> Option<&'a Path> {
    let d = image - rx;
    paths.iter().find(|p| {
        (p.length_m - d.norm()).abs() < TOL && (p.toward_source_in_w - d / d.norm()).norm() < TOL
    })
}

#[test]
fn direct_path_matches_geometry() {
    let (tx, rx) = (v(2.0, 3.0, 1.0), v(8.0, 5.0, 2.5));
    let mut out = Vec::new();
    paths_into(&room(0), &[], &tx, &rx, &mut out);
    assert_eq!(out.len(), 1);
    let p = out[0];
    let d = tx - rx;
    assert_close(p.length_m, d.norm(), "length");
    assert!((p.toward_source_in_w - d / d.norm()).norm() < TOL);
    assert_close(p.toward_source_in_w.norm(), 1.0, "unit");
    assert_eq!((p.order, p.obstructed, p.gain), (0, false, 1.0));
}

#[test]
fn coincident_points_give_zero_length_direct_path() {
    let tx = v(2.0, 3.0, 1.0);
    let mut out = Vec::new();
    paths_into(&room(1), &[], &tx, &tx, &mut out);
    assert_eq!(out[0].length_m, 0.0);
    assert_eq!(out[0].toward_source_in_w, Vector3::zeros());
    assert_eq!(out.len(), 7);
}

#[test]
fn first_order_paths_match_hand_images_and_reflection_points() {
    let r = room(1);
    let (tx, rx) = (v(2.0, 3.0, 1.0), v(9.0, 6.0, 2.5));
    let mut out = Vec::new();
    paths_into(&r, &[], &tx, &rx, &mut out);
    assert_eq!(out.len(), 7);
    // (axis, plane coordinate, hand-mirrored image, expected Γ), in output order.
    let cases = [
        (0, 0.0, v(-2.0, 3.0, 1.0), 0.4),
        (0, 12.0, v(22.0, 3.0, 1.0), 0.4),
        (1, 0.0, v(2.0, -3.0, 1.0), 0.4),
        (1, 8.0, v(2.0, 13.0, 1.0), 0.4),
        (2, 0.0, v(2.0, 3.0, -1.0), 0.5),
        (2, 4.0, v(2.0, 3.0, 7.0), -0.3),
    ];
    for (i, (axis, c, image, gamma)) in cases.into_iter().enumerate() {
        let p = out[1 + i];
        assert_eq!(p.order, 1);
        assert_close(p.gain, gamma, "gain");
        assert_close(p.length_m, (rx - image).norm(), "image length");
        let d = image - rx;
        assert!(
            (p.toward_source_in_w - d / d.norm()).norm() < TOL,
            "direction"
        );
        // Reflection point by similar triangles, independent of the image.
        let (dt, dr) = ((tx[axis] - c).abs(), (rx[axis] - c).abs());
        let mut refl = tx + (rx - tx) * (dt / (dt + dr));
        refl[axis] = c;
        assert_close(
            p.length_m,
            (tx - refl).norm() + (refl - rx).norm(),
            "unfolded",
        );
        // Law of reflection: equal angles to the normal.
        let mut normal = Vector3::zeros();
        normal[axis] = 1.0;
        let (inc, outg) = ((tx - refl).normalize(), (rx - refl).normalize());
        assert_close(inc.dot(&normal).abs(), outg.dot(&normal).abs(), "angles");
        assert!(
            (0..3).all(|k| refl[k] >= 0.0 && refl[k] <= r.size_m[k]),
            "on face"
        );
    }
}

#[test]
fn every_path_points_toward_its_image_and_count_is_25() {
    let r = room(2);
    let l = r.size_m;
    let mut out = Vec::new();
    let points = interior_points();
    for (tx, rx) in points.iter().zip(points.iter().rev()) {
        paths_into(&r, &[], tx, rx, &mut out);
        assert_eq!(out.len(), 25, "tx {tx:?} rx {rx:?}");
        // Hand-computed images with their orders: 1 + 6 + 18, all distinct, so finding each
        // one among the 25 paths is a one-to-one match.
        let mut images = vec![(*tx, 0)];
        for k in 0..3 {
            for x in [-tx[k], 2.0 * l[k] - tx[k]] {
                let mut im = *tx;
                im[k] = x;
                images.push((im, 1));
            }
            // Same-axis pairs: near face first gives 2L + x, far face first gives x − 2L.
            for x in [2.0 * l[k] + tx[k], tx[k] - 2.0 * l[k]] {
                let mut im = *tx;
                im[k] = x;
                images.push((im, 2));
            }
        }
        for (a, b) in [(0, 1), (0, 2), (1, 2)] {
            for ca in [-tx[a], 2.0 * l[a] - tx[a]] {
                for cb in [-tx[b], 2.0 * l[b] - tx[b]] {
                    let mut im = *tx;
                    im[a] = ca;
                    im[b] = cb;
                    images.push((im, 2));
                }
            }
        }
        assert_eq!(images.len(), 25);
        for (im, order) in &images {
            let p = find(&out, rx, im).unwrap_or_else(|| panic!("no path from {im:?}"));
            assert_eq!(p.order, *order);
        }
        assert_eq!(out[0].order, 0);
        assert_eq!(out.iter().filter(|p| p.order == 2).count(), 18);
        for p in &out {
            assert_close(p.toward_source_in_w.norm(), 1.0, "unit direction");
        }
    }
}

#[test]
fn corner_images_have_exactly_one_physical_order() {
    let r = room(2);
    let planes = r.planes();
    for tx in interior_points() {
        for rx in [v(3.17, 2.29, 1.13), v(10.93, 0.51, 3.37)] {
            for i in 0..6 {
                for j in 0..6 {
                    if planes[i].axis == planes[j].axis {
                        continue;
                    }
                    let image = planes[j].mirror(&planes[i].mirror(&tx));
                    let ij = trace(&r, &[], &tx, &rx, &[planes[i], planes[j]], &image);
                    let ji = trace(&r, &[], &tx, &rx, &[planes[j], planes[i]], &image);
                    assert!(ij.is_some() != ji.is_some(), "{i} {j} {tx:?} {rx:?}");
                }
            }
        }
    }
    // A tie: the line from rx to the (x = 12, ceiling) image (14, 6.5, 5) passes through the
    // room's edge (12, 2.5, 4), so both orders are valid; paths_into keeps one path.
    let (tx, rx) = (v(10.0, 6.5, 3.0), v(11.0, 0.5, 3.5));
    let image = v(14.0, 6.5, 5.0);
    let (x12, ceiling) = (planes[1], planes[5]);
    assert!(trace(&r, &[], &tx, &rx, &[x12, ceiling], &image).is_some());
    assert!(trace(&r, &[], &tx, &rx, &[ceiling, x12], &image).is_some());
    let mut out = Vec::new();
    paths_into(&r, &[], &tx, &rx, &mut out);
    assert_eq!(out.len(), 25);
    // Receiver close to x = 0 and far from y = 0: the line to the (x0, y0) corner image
    // crosses x = 0 first, so the wave reflects off y = 0 first and x = 0 last.
    let (tx, rx) = (v(3.0, 1.0, 2.0), v(0.5, 6.0, 2.0));
    let image = v(-3.0, -1.0, 2.0);
    let (x0, y0) = (planes[0], planes[2]);
    assert_eq!(
        trace(&r, &[], &tx, &rx, &[y0, x0], &image),
        Some((1.0, false))
    );
    assert_eq!(trace(&r, &[], &tx, &rx, &[x0, y0], &image), None);
}

#[test]
fn second_order_gains_multiply_and_lengths_match() {
    let r = room(2);
    let (tx, rx) = (v(2.0, 3.0, 1.0), v(9.0, 6.0, 2.5));
    let mut out = Vec::new();
    paths_into(&r, &[], &tx, &rx, &mut out);
    let cases = [
        (v(24.0 + 2.0, 3.0, 1.0), 0.16), // x = 0 then x = 12
        (v(2.0 - 24.0, 3.0, 1.0), 0.16), // x = 12 then x = 0
        (v(2.0, 3.0, 8.0 + 1.0), -0.15), // floor then ceiling: 2·4 + 1
        (v(2.0, 3.0, 1.0 - 8.0), -0.15), // ceiling then floor
        (v(-2.0, 3.0, -1.0), 0.2),       // x = 0 and floor
        (v(2.0, 13.0, 7.0), -0.12),      // y = 8 and ceiling
        (v(22.0, -3.0, 1.0), 0.16),      // x = 12 and y = 0
    ];
    for (image, gain) in cases {
        let p = find(&out, &rx, &image).unwrap_or_else(|| panic!("no path from {image:?}"));
        assert_close(p.gain, gain, "gain");
        assert_close(p.length_m, (image - rx).norm(), "length");
        assert_eq!(p.order, 2);
    }
}

fn board() -> ObstacleConfig {
    ObstacleConfig {
        min_m: [1.0, 1.0, 1.0],
        max_m: [2.0, 3.0, 4.0],
        attenuation_db: 6.0,
    }
}

#[test]
fn obstacle_slab_test_is_closed() {
    let b = board();
    // Through the middle, and beside it.
    assert!(b.blocks_segment(&v(0.0, 2.0, 2.0), &v(3.0, 2.0, 2.0)));
    assert!(!b.blocks_segment(&v(0.0, 3.5, 2.0), &v(3.0, 3.5, 2.0)));
    // Diagonal through, and a diagonal that passes a corner outside.
    assert!(b.blocks_segment(&v(0.0, 0.0, 0.0), &v(3.0, 4.0, 5.0)));
    assert!(!b.blocks_segment(&v(0.0, 2.5, 2.0), &v(1.4, 4.0, 2.0)));
    // Ends before the box; starts inside it; a point inside and outside.
    assert!(!b.blocks_segment(&v(0.0, 2.0, 2.0), &v(0.99, 2.0, 2.0)));
    assert!(b.blocks_segment(&v(1.5, 2.0, 2.0), &v(5.0, 5.0, 5.0)));
    assert!(b.blocks_segment(&v(1.5, 2.0, 2.0), &v(1.5, 2.0, 2.0)));
    assert!(!b.blocks_segment(&v(0.5, 2.0, 2.0), &v(0.5, 2.0, 2.0)));
    // Parallel to the x = 1 face: in the face plane (closed) crosses; just outside does not.
    assert!(b.blocks_segment(&v(1.0, 0.0, 2.0), &v(1.0, 5.0, 2.0)));
    assert!(!b.blocks_segment(&v(0.999, 0.0, 2.0), &v(0.999, 5.0, 2.0)));
    assert!(b.blocks_segment(&v(2.0, 2.0, 0.0), &v(2.0, 2.0, 9.0)));
    // Along an edge, touching an edge at one point, touching a corner at one point.
    assert!(b.blocks_segment(&v(1.0, 1.0, 0.0), &v(1.0, 1.0, 9.0)));
    assert!(b.blocks_segment(&v(0.0, 0.0, 2.0), &v(2.0, 2.0, 2.0)));
    assert!(b.blocks_segment(&v(0.0, 2.0, 2.0), &v(1.0, 1.0, 2.0)));
    assert!(b.blocks_segment(&v(0.0, 0.0, 0.0), &v(1.0, 1.0, 1.0)));
    assert!(!b.blocks_segment(&v(0.0, 0.0, 0.0), &v(0.999, 0.999, 0.999)));
    // Endpoint exactly on a face.
    assert!(b.blocks_segment(&v(0.0, 2.0, 2.0), &v(1.0, 2.0, 2.0)));
    // Direction does not matter.
    assert!(b.blocks_segment(&v(3.0, 4.0, 5.0), &v(0.0, 0.0, 0.0)));
}

#[test]
fn obstructed_paths_are_attenuated() {
    let r = room(1);
    let ob = ObstacleConfig {
        min_m: [4.0, 0.0, 0.0],
        max_m: [4.1, 8.0, 4.0],
        attenuation_db: 10.0,
    };
    let (tx, rx) = (v(2.0, 4.0, 2.0), v(8.0, 4.0, 2.0));
    let mut out = Vec::new();
    paths_into(&r, std::slice::from_ref(&ob), &tx, &rx, &mut out);
    let a = 10f64.powf(-10.0 / 20.0);
    assert!(out[0].obstructed);
    assert_close(out[0].gain, a, "direct");
    // Wall x = 0: the path tx → (0, 4, 2) → rx crosses the board once (on the way back).
    assert!(out[1].obstructed);
    assert_close(out[1].gain, 0.4 * a, "x0");
    // Wall x = 12: tx → (12, 4, 2) → rx crosses once (first segment).
    assert_close(out[2].gain, 0.4 * a, "x12");
    // Floor: crosses once.
    assert_close(out[5].gain, 0.5 * a, "floor");
    // A small board on the direct line only.
    let (tx2, rx2) = (v(2.0, 3.0, 1.5), v(8.0, 5.0, 2.5));
    let hit = tx2 + (rx2 - tx2) / 3.0; // (4, 3.667, 1.833)
    let small = ObstacleConfig {
        min_m: [hit.x - 0.05, hit.y - 0.1, hit.z - 0.1],
        max_m: [hit.x + 0.05, hit.y + 0.1, hit.z + 0.1],
        attenuation_db: 10.0,
    };
    paths_into(&r, std::slice::from_ref(&small), &tx2, &rx2, &mut out);
    assert_eq!(out.len(), 7);
    assert!(out[0].obstructed && out[1..].iter().all(|p| !p.obstructed));
    assert_close(out[0].gain, a, "direct only");
    assert_close(out[3].gain, 0.4, "y0 unobstructed");
    // A board enclosing tx and the x = 0 reflection point is crossed by both real segments.
    let wide = ObstacleConfig {
        min_m: [0.0, 3.0, 1.0],
        max_m: [3.0, 5.0, 3.0],
        attenuation_db: 10.0,
    };
    paths_into(&r, std::slice::from_ref(&wide), &tx, &rx, &mut out);
    assert_close(out[1].gain, 0.4 * a * a, "two crossings");
    // Two boards on the direct line, 10 dB and 6 dB: their factors multiply; a third board off
    // every path changes nothing.
    let second = ObstacleConfig {
        min_m: [6.0, 0.0, 0.0],
        max_m: [6.1, 8.0, 4.0],
        attenuation_db: 6.0,
    };
    let aside = ObstacleConfig {
        min_m: [10.0, 7.0, 3.5],
        max_m: [10.5, 7.5, 3.9],
        attenuation_db: 30.0,
    };
    paths_into(&r, &[ob.clone(), second.clone(), aside], &tx, &rx, &mut out);
    let b = 10f64.powf(-6.0 / 20.0);
    assert_close(out[0].gain, a * b, "direct through both boards");
    assert_close(out[5].gain, 0.5 * a * b, "floor through both boards");
    // Wall x = 12: tx → (12, 4, 2) crosses both boards, the way back to rx neither.
    assert_close(out[2].gain, 0.4 * a * b, "x12");
}

#[test]
fn output_buffer_is_reused() {
    let r = room(2);
    let mut out = Vec::new();
    paths_into(&r, &[], &v(1.0, 1.0, 1.0), &v(5.0, 5.0, 2.0), &mut out);
    let (ptr, cap) = (out.as_ptr(), out.capacity());
    for rx in interior_points() {
        paths_into(&r, &[], &v(1.0, 1.0, 1.0), &rx, &mut out);
        assert_eq!((out.as_ptr(), out.capacity()), (ptr, cap));
    }
    assert_eq!(out.len(), 25);
}

#[test]
fn validation_rejects_bad_values() {
    assert!(RoomConfig::default().validate("room").is_ok());
    let bad = RoomConfig {
        size_m: [12.0, 0.0, 4.0],
        ..RoomConfig::default()
    };
    assert_eq!(
        bad.validate("room").map_err(|e| e.field),
        Err("room.size_m".into())
    );
    let bad = RoomConfig {
        floor_reflection: -1.5,
        ..RoomConfig::default()
    };
    assert_eq!(
        bad.validate("r").map_err(|e| e.field),
        Err("r.floor_reflection".into())
    );
    let bad = RoomConfig {
        max_order: 3,
        ..RoomConfig::default()
    };
    assert_eq!(
        bad.validate("r").map_err(|e| e.field),
        Err("r.max_order".into())
    );
    assert!(board().validate("o").is_ok());
    let mut bad = board();
    bad.max_m[1] = 0.5;
    assert_eq!(
        bad.validate("o").map_err(|e| e.field),
        Err("o.max_m".into())
    );
    let mut bad = board();
    bad.attenuation_db = -1.0;
    assert_eq!(
        bad.validate("o").map_err(|e| e.field),
        Err("o.attenuation_db".into())
    );
}

#[test]
fn contains_is_strict_and_serde_defaults_apply() {
    let r = RoomConfig::default();
    assert!(r.contains(&v(6.0, 4.0, 2.0)));
    assert!(!r.contains(&v(0.0, 4.0, 2.0)));
    assert!(!r.contains(&v(6.0, 8.0, 2.0)));
    assert!(!r.contains(&v(6.0, 4.0, -0.1)));
    let parsed: RoomConfig = toml::from_str("max_order = 2").unwrap();
    assert_eq!(
        parsed,
        RoomConfig {
            max_order: 2,
            ..RoomConfig::default()
        }
    );
    assert!(toml::from_str::<RoomConfig>("walls = 0.3").is_err());
    assert!(toml::from_str::<ObstacleConfig>("min_m = [0.0, 0.0, 0.0]").is_err());
}
