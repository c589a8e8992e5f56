//! What every benchmark shares: the peer (its scripts and their Python) and the peer's time
//! beside ours, and where the shared data is.

use serde::Serialize;
use std::path::{Path, PathBuf};

/// The peer's time for the same work beside ours, in every benchmark's JSON (flattened) and table.
#[derive(Debug, Serialize)]
pub struct VsPeer {
    /// The peer's own timing of the same work, milliseconds, when the peer ran.
    pub peer_ms: Option<f64>,
    /// What the peer is.
    pub peer: &'static str,
    /// `peer_ms / ms`: how many times faster indoorloc is (below 1: slower).
    pub ratio_vs_peer: Option<f64>,
    /// Why the peer did not run, when it did not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub peer_note: Option<String>,
}

impl VsPeer {
    /// Our `ms` beside the peer's outcome.
    pub fn new(
        peer: &'static str,
        ms: f64,
        peer_ms: Option<f64>,
        peer_note: Option<String>,
    ) -> VsPeer {
        VsPeer {
            ratio_vs_peer: peer_ms.map(|p| p / ms),
            peer_ms,
            peer,
            peer_note,
        }
    }
}

/// `rel` under the shared folder (`$INDOORLOC_SHARED`, `../shared` or `shared`, first found)
/// when `is_there` holds for its `marker` (the file or folder that says the data is there).
pub(crate) fn shared_data(rel: &str, marker: &str, is_there: fn(&Path) -> bool) -> Option<PathBuf> {
    [
        std::env::var_os("INDOORLOC_SHARED").map(|d| Path::new(&d).join(rel)),
        Some(Path::new("../shared").join(rel)),
        Some(Path::new("shared").join(rel)),
    ]
    .into_iter()
    .flatten()
    .find(|p| is_there(&p.join(marker)))
}

/// The peer scripts and the Python of their venv.
pub struct Peer {
    /// Folder of the peer scripts.
    pub dir: PathBuf,
    /// `bin/python` of the peers' venv.
    pub python: PathBuf,
}
