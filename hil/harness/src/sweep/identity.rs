//! What a campaign ran with, by content: the build of the harness, the firmware under
//! QEMU and the input files. Every shard's header carries it, so `hil sweep merge`
//! refuses a shard run by another build or from edited files even when the paths and
//! flags are the same. Digests are SHA-256 in lower-case hex, as `sha256sum` prints them.

use std::io::{self, Read};
use std::path::Path;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

/// The identity of a campaign's build and inputs (the header's `identity`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Identity {
    /// The harness's version (its crate's).
    pub hil_version: String,
    /// SHA-256 of the `hil` binary that ran the points: the exact build, commit and
    /// compiler and profile included.
    pub hil_sha256: String,
    /// SHA-256 of the firmware ELF (`--target qemu`; None in process, where the control
    /// core is part of the `hil` binary).
    pub elf_sha256: Option<String>,
    /// SHA-256 of the scenario file (None: a built-in scenario, part of the binary).
    pub scenario_sha256: Option<String>,
    /// SHA-256 of `--params FILE` (None: the paper's parameters).
    pub params_sha256: Option<String>,
    /// SHA-256 of `--budget FILE` (None: the default budgets).
    pub budget_sha256: Option<String>,
}

/// SHA-256 of what `r` yields, in hex.
pub fn sha256_of(mut r: impl Read) -> io::Result<String> {
    let mut h = Sha256::new();
    io::copy(&mut r, &mut h)?;
    Ok(h.finalize()
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect::<String>())
}

/// SHA-256 of the file at `path`; the error names the file.
pub fn file_sha256(path: &Path) -> Result<String, String> {
    std::fs::File::open(path)
        .and_then(sha256_of)
        .map_err(|e| format!("{}: cannot read: {e}", path.display()))
}

/// SHA-256 of the running executable: `/proc/self/exe` where there is one (the file this
/// process runs, even if its path was rebuilt since), else the path it was started from.
pub fn exe_sha256() -> Result<String, String> {
    if let Ok(f) = std::fs::File::open("/proc/self/exe") {
        return sha256_of(f).map_err(|e| format!("/proc/self/exe: cannot read: {e}"));
    }
    let exe = std::env::current_exe()
        .map_err(|e| format!("cannot find the running hil binary to identify the build: {e}"))?;
    file_sha256(&exe)
}
