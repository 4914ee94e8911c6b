//! Output paths checked before any work: a command that writes a file or a directory of
//! files (`--csv`, `--json`, `--plot`, `--report`) finds out that it cannot before it
//! simulates, not after (bad input, exit code 2, naming the flag and the path).
//!
//! The checks create what the command would create anyway (the missing directories) and
//! nothing else: a file that does not exist yet is created and removed again, an
//! existing regular file is opened for writing without truncating it. Files that are not
//! regular (`/dev/null`, a FIFO someone reads) are left to the write itself: opening a
//! FIFO for writing would block until a reader comes.
//!
//! ```
//! use wheelset_report::output::{check_dir, check_file};
//! let dir = std::env::temp_dir().join(format!("sim-host-output-doc-{}", std::process::id()));
//! check_file(&dir.join("a/run.csv")).unwrap(); // creates a/, leaves no run.csv
//! assert!(dir.join("a").is_dir() && !dir.join("a/run.csv").exists());
//! let err = check_file(&dir.join("a")).unwrap_err();
//! assert!(err.contains("is a directory"), "{err}");
//! std::fs::write(dir.join("f"), "x").unwrap();
//! assert!(check_dir(&dir.join("f")).unwrap_err().contains("not a directory"));
//! assert!(check_file(&dir.join("f/run.csv")).is_err());
//! std::fs::remove_dir_all(&dir).unwrap();
//! ```

use std::fs::OpenOptions;
use std::path::Path;

/// Checks that `path` can be written as a file (see the module docs); the error says why
/// not, for a message that names the flag and the path.
pub fn check_file(path: &Path) -> Result<(), String> {
    if path.as_os_str().is_empty() {
        return Err("an empty path".into());
    }
    if path.is_dir() {
        return Err("is a directory".into());
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create its directory {}: {e}", dir.display()))?;
    }
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => OpenOptions::new()
            .write(true)
            .open(path)
            .map(drop)
            .map_err(|e| format!("cannot write: {e}")),
        Ok(_) => Ok(()),
        Err(_) => {
            OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(path)
                .map_err(|e| format!("cannot create: {e}"))?;
            std::fs::remove_file(path).map_err(|e| format!("cannot remove the probe: {e}"))
        }
    }
}

/// Checks that `dir` is (or can be created as) a directory whose files can be written
/// (creates it; see the module docs).
pub fn check_dir(dir: &Path) -> Result<(), String> {
    if dir.as_os_str().is_empty() {
        return Err("an empty path".into());
    }
    if dir.exists() && !dir.is_dir() {
        return Err("not a directory".into());
    }
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create: {e}"))?;
    let probe = dir.join(format!(".write-check-{}", std::process::id()));
    OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
        .map_err(|e| format!("cannot write files in it: {e}"))?;
    std::fs::remove_file(&probe).map_err(|e| format!("cannot remove the probe: {e}"))
}

/// [`check_file`] for `--flag PATH`, the message naming both.
pub fn check_file_flag(flag: &str, path: &Path) -> Result<(), String> {
    check_file(path).map_err(|why| format!("{flag} {}: {why}", path.display()))
}

/// [`check_dir`] for `--flag DIR`, the message naming both.
pub fn check_dir_flag(flag: &str, dir: &Path) -> Result<(), String> {
    check_dir(dir).map_err(|why| format!("{flag} {}: {why}", dir.display()))
}
