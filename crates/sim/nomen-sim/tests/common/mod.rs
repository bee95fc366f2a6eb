//! Helpers shared by the simulator's integration tests.

use std::path::{Path, PathBuf};

/// The shared real recordings (`../shared/data` beside the repository), or `None` with a note
/// that the test is skipped when they are absent.
pub fn data_dir() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../../shared/data");
    if dir.join("mocap/cmu/02_01.bvh").is_file() {
        Some(dir)
    } else {
        eprintln!("skipping: shared data not found at {}", dir.display());
        None
    }
}
