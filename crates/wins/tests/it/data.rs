//! Where test data lives: the repository's own samples, and `../shared/data` beside the checkout.

use std::io::Write as _;
use std::path::PathBuf;

/// The repository's `data/` folder.
pub fn repo_data() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data")
}

/// The shared data folder (`$WINS_SHARED_DATA`, else `../shared/data` beside the checkout), or
/// `None` when absent. Under CI (`CI` set) its absence fails the test instead of skipping it.
pub fn shared_data() -> Option<PathBuf> {
    let dir = std::env::var_os("WINS_SHARED_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    if dir.is_dir() {
        return Some(dir);
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "CI is set but the shared data folder {} is missing",
        dir.display()
    );
    // Straight to the terminal: the test harness hides what a passing test prints.
    let _ = writeln!(
        std::io::stderr(),
        "SKIPPED: the shared data folder {} is not present (set WINS_SHARED_DATA)",
        dir.display()
    );
    None
}

/// `copies` copies of `bytes`, each with `flips` bytes at or after `from` flipped (xorshift from
/// `seed`, so every run damages the same bytes).
pub fn flipped_copies(
    bytes: &[u8],
    seed: u64,
    copies: usize,
    flips: usize,
    from: usize,
) -> Vec<Vec<u8>> {
    let mut state = seed;
    (0..copies)
        .map(|_| {
            let mut copy = bytes.to_vec();
            for _ in 0..flips {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let at = from + (state as usize) % (copy.len() - from);
                copy[at] ^= (state >> 40) as u8 | 1;
            }
            copy
        })
        .collect()
}
