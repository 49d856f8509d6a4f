//! Sanitization (SpotFi Algorithm 1) on simulated and real packets.

use num_complex::Complex64;
use wins::csi::intel5300::{CsiRecord, read_log};
use wins::csi::sanitize::sanitize;
use wins::sim::{Scenario, simulate};

fn rows(record: &CsiRecord) -> Vec<Complex64> {
    let nrx = usize::from(record.header.nrx);
    (0..nrx)
        .flat_map(|rx| (0..30).map(move |k| (rx, k)))
        .map(|(rx, k)| {
            let c = record.csi_at(0, rx, k).expect("in range");
            Complex64::new(f64::from(c.re), f64::from(c.im))
        })
        .collect()
}

#[test]
fn single_path_packets_give_back_time_of_flight_plus_sampling_offset() {
    let mut s = Scenario::built_in("paper-circle").unwrap().airborne();
    s.duration_s = 5.0;
    s.room.max_order = 0;
    s.radio.bandwidth = wins::csi::Bandwidth::Ht40;
    let out = simulate(&s, &mut |_| {}).unwrap();
    let offsets = s.radio.bandwidth.subcarrier_offsets_hz();
    let mut n = 0;
    for (p, record) in out.aps[0].received() {
        let mut csi = rows(record);
        let line = sanitize(&mut csi, 3, &offsets).unwrap();
        let want = p.truth.tof_s + p.truth.sto_s;
        // 30 dB SNR and 8-bit quantization over a 73 MHz span: well under a nanosecond.
        assert!(
            (line.delay_s() - want).abs() < 0.5e-9,
            "{} vs {want}",
            line.delay_s()
        );
        n += 1;
    }
    assert!(n > 200);
}

#[test]
fn real_packets_keep_magnitudes_and_inter_antenna_phase() {
    for name in ["csikit_example.dat", "csikit_log.all_csi.6.7.6.dat"] {
        let log = read_log(crate::data::repo_data().join("intel5300").join(name)).unwrap();
        for record in &log.records {
            let offsets = record.header.rate.bandwidth().subcarrier_offsets_hz();
            let raw = rows(record);
            let mut csi = raw.clone();
            let nrx = usize::from(record.header.nrx);
            let line = sanitize(&mut csi, nrx, &offsets).unwrap();
            assert!(line.slope_rad_per_hz.is_finite() && line.offset_rad.is_finite());
            // Only a per-subcarrier phase common to all antennas is removed. (Not idempotent on
            // real data: noisy phase can unwrap differently once the slope is gone.)
            for k in 0..30 {
                for m in 0..nrx {
                    let (r, c) = (raw[m * 30 + k], csi[m * 30 + k]);
                    assert!((r.norm() - c.norm()).abs() < 1e-9);
                    let before = r * raw[k].conj();
                    let after = c * csi[k].conj();
                    assert!((before - after).norm() < 1e-9 * (1.0 + before.norm()));
                }
            }
        }
    }
}
