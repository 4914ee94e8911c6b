//! The bulk channel's start: two FIFOs in a fresh directory, QEMU told where, the
//! host's ends opened once the firmware has opened its own.

use std::io;
use std::process::Command;
use std::time::Duration;

use super::{read_to_string, retry, Link, Qemu, QemuConfig, QemuError};
use crate::qemu::cmd::SerialTo;

const O_NONBLOCK: i32 = libc::O_NONBLOCK;

impl Qemu {
    /// [`Self::start`] over the bulk channel (module docs): a non-blocking open of a FIFO's
    /// write end fails until it has a reader.
    pub(super) fn start_bulk(cfg: &QemuConfig) -> Result<Self, QemuError> {
        use std::os::unix::fs::OpenOptionsExt;
        static SEQ: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let k = SEQ.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("wheelset-bulk-{}-{k}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).map_err(QemuError::Io)?;
        let (rx_path, tx_path) = (dir.join("rx"), dir.join("tx"));
        let made = Command::new("mkfifo")
            .arg(&rx_path)
            .arg(&tx_path)
            .status()
            .map_err(QemuError::Io)?;
        if !made.success() {
            return Err(QemuError::Io(io::Error::other(format!(
                "mkfifo {} {} failed",
                rx_path.display(),
                tx_path.display()
            ))));
        }
        let stderr_path = dir.join("qemu.err");
        let to = SerialTo::Bulk(dir.to_string_lossy().into_owned());
        let mut guard = Self::spawn(cfg, to, &stderr_path)?;
        // Our reading end first (a non-blocking open for reading never waits), so the
        // firmware's open of `tx` for writing finds a reader.
        let rx = std::fs::OpenOptions::new()
            .read(true)
            .custom_flags(O_NONBLOCK)
            .open(&tx_path)
            .map_err(QemuError::Io)?;
        let opened = retry(
            Duration::from_secs(10),
            Duration::from_millis(5),
            || {
                std::fs::OpenOptions::new()
                    .write(true)
                    .custom_flags(O_NONBLOCK)
                    .open(&rx_path)
            },
            || {
                guard
                    .exited()
                    .map(|_| QemuError::Exited(read_to_string(&stderr_path)))
            },
            |e| {
                QemuError::Exited(format!(
                    "the firmware did not open its bulk channel ({e}); {}",
                    read_to_string(&stderr_path)
                ))
            },
        );
        // The firmware has it open for reading: writes block from here on (the same
        // descriptor, so the firmware never sees the FIFO without a writer).
        let tx = opened?;
        crate::realtime::os::set_blocking(&tx).map_err(QemuError::Io)?;
        let link = Link::Bulk { tx, rx, dir };
        Ok(Self::on_link(link, guard, stderr_path, cfg.timeout))
    }
}
