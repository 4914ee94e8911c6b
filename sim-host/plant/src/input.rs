//! The one way the tools read an input file: a regular file of at most
//! [`MAX_INPUT_BYTES`], as UTF-8. FIFOs, devices, sockets and directories are refused
//! before anything is read (they may block or never end), as is a file over the limit
//! (one that grows while read is cut at the limit and refused).

use crate::error::ConfigError;
use std::io::Read;
use std::path::Path;

/// Largest input file any tool reads: 1 MiB (the shipped ones are under 4 KiB).
pub const MAX_INPUT_BYTES: u64 = 1 << 20;

fn kind(ft: std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if ft.is_dir() {
        "a directory"
    } else if ft.is_fifo() {
        "a FIFO (named pipe)"
    } else if ft.is_char_device() {
        "a character device"
    } else if ft.is_block_device() {
        "a block device"
    } else if ft.is_socket() {
        "a socket"
    } else {
        "not a regular file"
    }
}

fn io(path: &Path, reason: impl Into<String>) -> ConfigError {
    ConfigError::Io {
        file: path.display().to_string(),
        reason: reason.into(),
    }
}

/// Reads `path` as bytes: a regular file (symbolic links followed) of at most `max`
/// bytes, else a [`ConfigError::Io`] naming the file and why.
pub fn read_bytes(path: &Path, max: u64) -> Result<Vec<u8>, ConfigError> {
    // `metadata` does not open the file: a FIFO is refused without blocking on it.
    let meta = std::fs::metadata(path).map_err(|e| io(path, e.to_string()))?;
    let ft = meta.file_type();
    if !ft.is_file() {
        return Err(io(
            path,
            format!(
                "{}, not a regular file: input files must be regular files of at most {} bytes",
                kind(ft),
                max
            ),
        ));
    }
    if meta.len() > max {
        return Err(io(
            path,
            format!(
                "{} bytes is above the input file limit of {max} bytes (1 MiB)",
                meta.len()
            ),
        ));
    }
    let f = std::fs::File::open(path).map_err(|e| io(path, e.to_string()))?;
    let mut buf = Vec::with_capacity(meta.len() as usize);
    f.take(max + 1)
        .read_to_end(&mut buf)
        .map_err(|e| io(path, e.to_string()))?;
    if buf.len() as u64 > max {
        return Err(io(
            path,
            format!("grew past the input file limit of {max} bytes while it was read"),
        ));
    }
    Ok(buf)
}

/// [`read_bytes`] as UTF-8 text.
pub fn read_text(path: &Path, max: u64) -> Result<String, ConfigError> {
    let bytes = read_bytes(path, max)?;
    String::from_utf8(bytes).map_err(|e| {
        io(
            path,
            format!(
                "not UTF-8 text (invalid byte at offset {})",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

/// [`read_text`] with the default limit [`MAX_INPUT_BYTES`].
pub fn read_input(path: &Path) -> Result<String, ConfigError> {
    read_text(path, MAX_INPUT_BYTES)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn regular_small_file_is_read_and_others_refused() {
        let dir = std::env::temp_dir().join(format!("sim-host-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let ok = dir.join("ok.toml");
        std::fs::write(&ok, "a = 1\n").unwrap();
        assert_eq!(read_input(&ok).unwrap(), "a = 1\n");
        let big = dir.join("big.toml");
        std::fs::write(&big, vec![b'#'; 101]).unwrap();
        let e = read_text(&big, 100).unwrap_err().to_string();
        assert!(e.contains("101 bytes is above"), "{e}");
        let e = read_input(&dir).unwrap_err().to_string();
        assert!(e.contains("a directory"), "{e}");
        let bin = dir.join("bin");
        std::fs::write(&bin, [0xff, 0xfe, 0x00]).unwrap();
        let e = read_input(&bin).unwrap_err().to_string();
        assert!(e.contains("not UTF-8"), "{e}");
        let e = read_input(Path::new("/dev/null")).unwrap_err().to_string();
        assert!(e.contains("character device"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
