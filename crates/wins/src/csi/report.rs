//! What the byte-walking readers (FeitCSI, PicoScenes, Atheros) share: the whole file read, the
//! unread tail in words, and the counts their summaries print.

use std::collections::BTreeMap;
use std::path::Path;

/// Where a reading stopped before the end of a file: the offset, the bytes left, and why.
pub type Tail = (u64, u64, String);

/// The tail in words (`None`: the whole file was read).
pub fn lost(tail: Option<&Tail>) -> Option<String> {
    tail.map(|(at, len, why)| format!("offset {at}: {len} bytes not read: {why}"))
}

/// The bytes of the regular file at `path`.
pub fn read_whole(path: &Path) -> std::io::Result<Vec<u8>> {
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(&mut crate::io_safety::open_regular(path)?, &mut bytes)?;
    Ok(bytes)
}

/// Counts as a summary prints them, `"key: n, key: n"` (`-` for none).
pub fn counts(map: &BTreeMap<String, u64>) -> String {
    if map.is_empty() {
        return "-".into();
    }
    let items: Vec<String> = map.iter().map(|(k, v)| format!("{k}: {v}")).collect();
    items.join(", ")
}

/// Adds one to `key`'s count.
pub fn count(map: &mut BTreeMap<String, u64>, key: String) {
    *map.entry(key).or_default() += 1;
}

/// A MAC address as `aa:bb:cc:dd:ee:ff`.
pub fn mac(m: &[u8; 6]) -> String {
    let parts: Vec<String> = m.iter().map(|b| format!("{b:02x}")).collect();
    parts.join(":")
}
