//! Writing a document so that it is either whole or absent: a temporary file in the
//! same directory, flushed to disk, then renamed over the target (a rename within one
//! directory is atomic on POSIX file systems, shared ones included). A shard killed and
//! requeued by a scheduler therefore never leaves half a document where `hil sweep
//! merge` would read it; at worst a hidden `.NAME.PID.tmp` beside it, which no
//! `NAME`-pattern matches and the next run does not need.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Longest a writer waits on a hold file (see [`write_atomic`]).
pub const HOLD_LIMIT: Duration = Duration::from_secs(600);

/// The temporary file of `path` for this process: `.NAME.PID.tmp` in its directory.
#[must_use]
pub fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map_or_else(|| "document".into(), |n| n.to_string_lossy().into_owned());
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Writes `bytes` to `path` atomically (creating its directory). With `hold`, waits
/// between the temporary file and the rename while that file exists (at most
/// [`HOLD_LIMIT`]): a test hook (`HIL_SWEEP_TEST_HOLD`) holding a shard at the one moment
/// a kill must not matter. The error names the file.
pub fn write_atomic(path: &Path, bytes: &[u8], hold: Option<&Path>) -> Result<(), String> {
    if let Some(d) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d).map_err(|e| format!("{}: cannot create: {e}", d.display()))?;
    }
    let tmp = temp_path(path);
    let written = std::fs::File::create(&tmp).and_then(|mut f| {
        f.write_all(bytes)?;
        f.sync_all()
    });
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(format!("{}: cannot write: {e}", tmp.display()));
    }
    if let Some(h) = hold {
        let start = Instant::now();
        while h.exists() && start.elapsed() < HOLD_LIMIT {
            std::thread::sleep(Duration::from_millis(50));
        }
    }
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        format!(
            "{}: cannot write (rename from {}): {e}",
            path.display(),
            tmp.display()
        )
    })
}
