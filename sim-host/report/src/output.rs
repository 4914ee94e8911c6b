//! Output paths checked before any work: a command that writes a file or a directory
//! (`--csv`, `--json`, `--plot`, `--report`) finds out that it cannot before it
//! simulates (exit code 2, naming the flag and the path). The checks create only the
//! missing directories; a new file is created and removed again, an existing regular one
//! opened without truncating, and non-regular files (a FIFO would block) left to the write.

use std::fs::OpenOptions;
use std::path::Path;

/// Checks that `path` can be written as a file; the error says why not.
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

/// Checks that `dir` is (or can be created as) a directory whose files can be written.
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
