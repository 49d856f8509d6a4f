//! Helpers shared by the renderers' tests: a temporary PNG path, and reading one back.

use std::path::{Path, PathBuf};

const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A];

/// A path under the temp dir unique to this process, the calling test module and `name`.
pub(crate) fn temp_png(module: &str, name: &str) -> PathBuf {
    std::env::temp_dir().join(format!(
        "wins-plot-{module}-{}-{name}.png",
        std::process::id()
    ))
}

/// Reads the PNG at `path`, deletes it, and asserts it is a PNG of `width` × `height` with more
/// than a header in it.
pub(crate) fn take_png(path: &Path, width: u32, height: u32) {
    let bytes = std::fs::read(path).unwrap();
    std::fs::remove_file(path).unwrap();
    assert!(bytes.len() > 1024, "PNG only {} bytes", bytes.len());
    assert_eq!(bytes[..8], PNG_SIGNATURE);
    // The IHDR chunk comes first: length, "IHDR", width and height big-endian.
    assert_eq!(&bytes[12..16], b"IHDR");
    assert_eq!(bytes[16..20], width.to_be_bytes());
    assert_eq!(bytes[20..24], height.to_be_bytes());
}
