use super::*;
use ::mavlink::dialects::common::HEARTBEAT_DATA;

const ALL_IMU_BITS: u16 = 0b11_1111;
const PRESSURE_BIT: u16 = 1 << 9;

fn highres(bits: u16) -> MavMessage {
    MavMessage::HIGHRES_IMU(HIGHRES_IMU_DATA {
        time_usec: 12_345_678,
        xacc: 0.5,
        yacc: -0.25,
        zacc: -9.75,
        xgyro: 0.01,
        ygyro: -0.02,
        zgyro: 0.03,
        abs_pressure: 1013.25,
        fields_updated: HighresImuUpdatedFlags::from_bits_truncate(bits),
        ..Default::default()
    })
}

#[test]
fn highres_imu_passes_frd_specific_force_through() {
    let mut decoder = InboundDecoder::default();
    let out = decoder.decode(&highres(ALL_IMU_BITS | PRESSURE_BIT));
    let imu = out.imu.unwrap();
    assert_eq!(imu.t, Timestamp(12_345_678_000));
    assert_eq!(imu.accel_m_s2, Vector3::new(0.5, -0.25, -9.75));
    assert_eq!(
        imu.gyro_rad_s,
        Vector3::new(0.01, -0.02, 0.03).map(|v: f32| f64::from(v))
    );
    let baro = out.baro.unwrap();
    assert_eq!(baro.t, imu.t);
    assert!((baro.pressure_pa - 101_325.0).abs() < 1e-3);
    assert!(baro.altitude_m.abs() < 1e-3);
    assert_eq!(decoder.stats().imu, 1);
    assert_eq!(decoder.stats().baro, 1);
    assert_eq!(decoder.stats().refused.total(), 0);
}

#[test]
fn highres_imu_honours_fields_updated() {
    let mut decoder = InboundDecoder::default();
    // Pressure only: a baro reading, nothing refused.
    let out = decoder.decode(&highres(PRESSURE_BIT));
    assert!(out.imu.is_none() && out.baro.is_some());
    assert_eq!(decoder.stats().refused.incomplete, 0);
    // Accel without gyro: the IMU part is refused, the pressure taken.
    let out = decoder.decode(&highres(0b111 | PRESSURE_BIT));
    assert!(out.imu.is_none() && out.baro.is_some());
    assert_eq!(decoder.stats().refused.incomplete, 1);
    // IMU without the pressure bit: no baro.
    let out = decoder.decode(&highres(ALL_IMU_BITS));
    assert!(out.imu.is_some() && out.baro.is_none());
    // Nothing updated.
    let out = decoder.decode(&highres(0));
    assert_eq!(out, Inbound::default());
    assert_eq!(decoder.stats().refused.incomplete, 2);
    assert_eq!(decoder.stats().imu, 1);
    assert_eq!(decoder.stats().baro, 2);
}

#[test]
fn scaled_imu_and_pressure_are_converted_to_si() {
    let mut decoder = InboundDecoder::default();
    let imu = decoder
        .decode(&MavMessage::SCALED_IMU(SCALED_IMU_DATA {
            time_boot_ms: 4_000,
            xacc: 10,
            yacc: -20,
            zacc: -1000,
            xgyro: 100,
            ygyro: -200,
            zgyro: 5,
            ..Default::default()
        }))
        .imu
        .unwrap();
    assert_eq!(imu.t, Timestamp(4_000_000_000));
    let g = STANDARD_GRAVITY_M_S2;
    let expected = Vector3::new(0.01 * g, -0.02 * g, -g);
    assert!((imu.accel_m_s2 - expected).amax() < 1e-12);
    assert!((imu.gyro_rad_s - Vector3::new(0.1, -0.2, 0.005)).amax() < 1e-12);
    let baro = decoder
        .decode(&MavMessage::SCALED_PRESSURE(SCALED_PRESSURE_DATA {
            time_boot_ms: 4_010,
            press_abs: 898.746,
            ..Default::default()
        }))
        .baro
        .unwrap();
    assert_eq!(baro.t, Timestamp(4_010_000_000));
    assert!((baro.pressure_pa - 89_874.6).abs() < 0.01);
    assert!(
        (baro.altitude_m - 1000.0).abs() < 0.5,
        "{}",
        baro.altitude_m
    );
}

#[test]
fn standard_atmosphere_matches_its_table() {
    // ISA: 1000 m ↔ 89 874.6 Pa, 5000 m ↔ 54 019.9 Pa, 10 000 m ↔ 26 436 Pa.
    for (pressure_pa, altitude_m) in [(89_874.6, 1000.0), (54_019.9, 5000.0), (26_436.0, 10_000.0)]
    {
        let h = pressure_altitude_m(pressure_pa, STANDARD_SEA_LEVEL_PA);
        assert!((h - altitude_m).abs() < 2.0, "{pressure_pa} Pa: {h} m");
    }
    assert_eq!(
        pressure_altitude_m(STANDARD_SEA_LEVEL_PA, STANDARD_SEA_LEVEL_PA),
        0.0
    );
}

#[test]
fn raw_imu_needs_scales() {
    let raw = MavMessage::RAW_IMU(RAW_IMU_DATA {
        time_usec: 1_000,
        xacc: 100,
        yacc: 0,
        zacc: -2048,
        xgyro: 10,
        ygyro: 0,
        zgyro: -10,
        ..Default::default()
    });
    let mut decoder = InboundDecoder::default();
    assert_eq!(decoder.decode(&raw), Inbound::default());
    assert_eq!(decoder.stats().refused.raw_imu_without_scale, 1);
    let mut decoder = InboundDecoder::new(InboundConfig {
        raw_imu_scale: Some(RawImuScale {
            accel_m_s2_per_count: STANDARD_GRAVITY_M_S2 / 2048.0,
            gyro_rad_s_per_count: 0.001,
        }),
        ..InboundConfig::default()
    });
    let imu = decoder.decode(&raw).imu.unwrap();
    assert_eq!(imu.t, Timestamp(1_000_000));
    assert!((imu.accel_m_s2.z + STANDARD_GRAVITY_M_S2).abs() < 1e-12);
    assert!((imu.gyro_rad_s - Vector3::new(0.01, 0.0, -0.01)).amax() < 1e-15);
}

#[test]
fn bad_values_are_refused_and_counted() {
    let mut decoder = InboundDecoder::default();
    let mut bad = |edit: fn(&mut HIGHRES_IMU_DATA)| {
        let MavMessage::HIGHRES_IMU(mut m) = highres(ALL_IMU_BITS | PRESSURE_BIT) else {
            unreachable!()
        };
        edit(&mut m);
        decoder.decode(&MavMessage::HIGHRES_IMU(m))
    };
    let out = bad(|m| m.ygyro = f32::NAN);
    assert!(out.imu.is_none() && out.baro.is_some());
    let out = bad(|m| m.xacc = 1e6);
    assert!(out.imu.is_none());
    let out = bad(|m| m.abs_pressure = f32::INFINITY);
    assert!(out.baro.is_none() && out.imu.is_some());
    let out = bad(|m| m.abs_pressure = 0.0);
    assert!(out.baro.is_none());
    let out = bad(|m| m.time_usec = u64::MAX);
    assert_eq!(out, Inbound::default());
    let stats = *decoder.stats();
    assert_eq!(stats.refused.non_finite, 2);
    assert_eq!(stats.refused.out_of_range, 4);
    assert_eq!(stats.imu, 2);
    assert_eq!(stats.baro, 2);
}

#[test]
fn other_messages_are_counted_and_stats_serialize() {
    let mut decoder = InboundDecoder::default();
    let out = decoder.decode(&MavMessage::HEARTBEAT(HEARTBEAT_DATA::default()));
    assert_eq!(out, Inbound::default());
    assert_eq!(decoder.stats().other, 1);
    let json = serde_json::to_string(decoder.stats()).unwrap();
    assert!(json.contains("\"other\":1"), "{json}");
    assert!(json.contains("\"raw_imu_without_scale\":0"), "{json}");
}

#[test]
fn only_the_flight_controller_moves_the_inputs() {
    let from = |system_id: u32, component_id: u8| MavHeader {
        system_id,
        component_id,
        sequence: 0,
    };
    let mut decoder = InboundDecoder::default();
    let m = highres(0x3F);
    assert!(decoder.decode_from(&from(1, 1), &m).imu.is_some());
    // Another vehicle, a companion's component, a ground station: counted, left out.
    for (system, component) in [(2, 1), (1, 190), (255, 190)] {
        let got = decoder.decode_from(&from(system, component), &m);
        assert_eq!(got, Inbound::default(), "{system}/{component}");
    }
    assert_eq!(decoder.stats().other_sender, 3);
    assert_eq!(decoder.stats().imu, 1);
    // Any component of the vehicle, when asked.
    let mut any = InboundDecoder::new(InboundConfig {
        fc_system_id: 7,
        fc_component_id: 0,
        ..InboundConfig::default()
    });
    assert!(any.decode_from(&from(7, 190), &m).imu.is_some());
    assert!(any.decode_from(&from(1, 1), &m).imu.is_none());
    assert_eq!(any.stats().other_sender, 1);
}

#[test]
fn a_sample_at_the_rigs_full_scale_is_refused_as_wins_run_drops_it() {
    let mut decoder = InboundDecoder::new(InboundConfig {
        max_accel_m_s2: 16.0,
        max_gyro_rad_s: 2.0,
        ..InboundConfig::default()
    });
    let with = |xacc: f32, zgyro: f32| {
        MavMessage::HIGHRES_IMU(HIGHRES_IMU_DATA {
            time_usec: 1_000,
            xacc,
            zgyro,
            fields_updated: HighresImuUpdatedFlags::from_bits_truncate(ALL_IMU_BITS),
            ..Default::default()
        })
    };
    assert!(decoder.decode(&with(15.9, 0.0)).imu.is_some());
    assert!(decoder.decode(&with(16.0, 0.0)).imu.is_none());
    assert!(decoder.decode(&with(0.0, -2.0)).imu.is_none());
    assert_eq!(decoder.stats().refused.out_of_range, 2);
}
