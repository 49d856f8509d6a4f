//! Wi-Fi channel numbers of the 2.4 and 5 GHz bands (the Intel 5300's) and their centre
//! frequencies (IEEE 802.11-2020, §15.4.4.3 and §17.3.8.4.2), so that a user can give the channel
//! instead of a frequency in Hz.

/// The centre frequency of Wi-Fi channel `channel`, Hz: 1–13 at `2407 + 5·n` MHz, 14 at
/// 2484 MHz, 32–177 at `5000 + 5·n` MHz; `None` for any other number.
pub fn wifi_channel_hz(channel: u32) -> Option<f64> {
    let mhz = match channel {
        1..=13 => 2407 + 5 * channel,
        14 => 2484,
        32..=177 => 5000 + 5 * channel,
        _ => return None,
    };
    Some(f64::from(mhz) * 1e6)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_map_to_their_centres_and_others_are_refused() {
        assert_eq!(wifi_channel_hz(1), Some(2.412e9));
        assert_eq!(wifi_channel_hz(6), Some(2.437e9));
        assert_eq!(wifi_channel_hz(14), Some(2.484e9));
        assert_eq!(wifi_channel_hz(64), Some(5.32e9));
        assert_eq!(wifi_channel_hz(165), Some(5.825e9));
        for n in [0, 15, 31, 178, 1000] {
            assert_eq!(wifi_channel_hz(n), None, "{n}");
        }
    }
}
