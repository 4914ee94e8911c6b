//! The QEMU launcher: runs the firmware on `qemu-system-arm` ([`crate::qemu::cmd`]) and
//! connects its UART0 over TCP. Each QEMU is pinned to one core: the UART's one-byte
//! register hands every byte between QEMU's threads, cheaper on one core.

use std::fmt;
use std::fs::File;
use std::io::{self, Read, Write};
use std::net::{Ipv4Addr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

pub use crate::qemu::machine::Machine;

use crate::qemu::cmd::{qemu_args, without_icount, SerialTo};

mod bulk;
pub mod cmd;
pub mod machine;
mod pin;
pub mod target;

pub use crate::qemu::cmd::{ICOUNT_SHIFT, QEMU_BIN};

/// Budget of the firmware tick's mean, in QEMU instructions (`exec`; `cargo xtask fw-bench`).
pub const TICK_MEAN_BUDGET_INSTRUCTIONS: u64 = 2_500;
/// Budget of the tick's maximum over the 20 s `curve` under QEMU (test `qemu_curve`).
pub const TICK_MAX_BUDGET_INSTRUCTIONS: u64 = 4_000;
use crate::realtime::os::HeldOn;
use crate::realtime::poll_readable;
use pin::next_core;

/// Largest frame [`Qemu::recv_frame`] accepts, delimiter excluded.
pub const MAX_FRAME: usize = 256;

/// Bytes one read of the link asks for: every answer already there in one system call.
const RX_CHUNK: usize = 4096;

/// Why the emulated device could not be started or talked to.
#[derive(Debug)]
pub enum QemuError {
    /// `qemu-system-arm` is not installed (or not runnable).
    QemuMissing(io::Error),
    /// The firmware ELF does not exist.
    ElfMissing(PathBuf),
    /// The firmware file is not an ELF for the target ([`crate::elf`]).
    NotElf(PathBuf, String),
    /// QEMU started but could not be connected to.
    Connect {
        /// The TCP port of the serial chardev.
        port: u16,
        /// QEMU's stderr, if it exited.
        stderr: String,
    },
    /// QEMU exited while the link was in use.
    Exited(String),
    /// Reading or writing the serial link failed (a timeout included).
    Link(io::Error),
    /// A frame longer than [`MAX_FRAME`] arrived.
    FrameTooLong,
    /// A file or process could not be set up.
    Io(io::Error),
}

impl fmt::Display for QemuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            QemuError::QemuMissing(e) => write!(
                f,
                "{QEMU_BIN} not found ({e}): install it with `apt-get install qemu-system-arm`"
            ),
            QemuError::ElfMissing(p) => write!(
                f,
                "firmware ELF {} not found: build it with `cargo fw`",
                p.display()
            ),
            QemuError::NotElf(p, why) => write!(f, "firmware image {}: {why}", p.display()),
            QemuError::Connect { port, stderr } => write!(
                f,
                "cannot connect to QEMU's serial port 127.0.0.1:{port}: {stderr}"
            ),
            QemuError::Exited(stderr) => write!(f, "QEMU exited: {stderr}"),
            QemuError::Link(e) => write!(f, "serial link to QEMU: {e}"),
            QemuError::FrameTooLong => write!(f, "frame longer than {MAX_FRAME} bytes"),
            QemuError::Io(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for QemuError {}

/// How to start the emulated device.
#[derive(Debug, Clone)]
pub struct QemuConfig {
    /// The firmware (`target/fw/wheelset-qemu.elf`, built by `cargo fw`).
    pub elf: PathBuf,
    /// Where QEMU's stdout (the defmt log) goes; `None` discards it.
    pub log: Option<PathBuf>,
    /// Read timeout of the serial link (a guest that stops answering).
    pub timeout: Duration,
    /// The emulated board (`-machine`, `-cpu`): mps2-an386 (Cortex-M4F) by default.
    pub machine: Machine,
    /// How the frames travel: UART0 over TCP (default) or the semihosting bulk channel.
    pub channel: Channel,
    /// QEMU without `-icount`, for the free-running firmware ([`QemuConfig::free_running`]).
    pub free_run: bool,
    /// A free-running QEMU at `SCHED_RR` where permitted. Not at 5 kHz: the busy vCPU
    /// thread would starve the I/O thread that moves the UART's bytes.
    pub realtime: bool,
}

/// The link between the harness and the emulated device.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Channel {
    /// UART0 over a TCP chardev, byte by byte with interrupts, as on a board.
    #[default]
    Uart,
    /// Semihosting file I/O on two FIFOs: one trap per frame, the same frames bit for bit.
    Bulk,
}

impl QemuConfig {
    /// The default ELF: `$WHEELSET_QEMU_ELF`, else `target/fw/wheelset-qemu.elf`.
    pub fn default_elf() -> PathBuf {
        std::env::var_os("WHEELSET_QEMU_ELF")
            .map_or_else(|| Self::built_elf(Machine::An386), PathBuf::from)
    }

    /// The ELF `cargo fw` builds for `machine`'s core.
    pub fn built_elf(machine: Machine) -> PathBuf {
        let target = std::env::var_os("CARGO_TARGET_DIR")
            .map(PathBuf::from)
            .unwrap_or_else(|| {
                // The workspace's target directory, spelled without `..`.
                Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("../..")
                    .join("target")
            });
        target.join("fw").join(machine.elf_name())
    }

    /// The default configuration on `machine`: its ELF, no log, a 10 s timeout.
    pub fn on(machine: Machine) -> Self {
        Self {
            elf: if machine == Machine::default() {
                Self::default_elf()
            } else {
                Self::built_elf(machine)
            },
            log: None,
            timeout: Duration::from_secs(10),
            machine,
            channel: Channel::Uart,
            free_run: false,
            realtime: false,
        }
    }

    /// [`Self::on`] the default machine.
    pub fn new() -> Self {
        Self::on(Machine::default())
    }

    /// The free-running firmware on mps2-an386 without `-icount` (TIMER0 on the host's clock).
    pub fn free_running() -> Self {
        let elf = std::env::var_os("WHEELSET_QEMU_FREE_ELF")
            .map(PathBuf::from)
            .unwrap_or_else(|| {
                Self::built_elf(Machine::An386).with_file_name("wheelset-qemu-free.elf")
            });
        Self {
            elf,
            free_run: true,
            ..Self::new()
        }
    }

    /// Checks that QEMU and the ELF are there, with a message saying how to get them.
    pub fn check(&self) -> Result<(), QemuError> {
        Command::new(QEMU_BIN)
            .arg("--version")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .map_err(QemuError::QemuMissing)?;
        if !self.elf.is_file() {
            return Err(QemuError::ElfMissing(self.elf.clone()));
        }
        crate::elf::check_target_elf(&self.elf)
            .map_err(|why| QemuError::NotElf(self.elf.clone(), why))?;
        Ok(())
    }
}

impl Default for QemuConfig {
    fn default() -> Self {
        Self::new()
    }
}

/// A running emulated device; dropping it kills a QEMU that [`Qemu::start`] started.
#[derive(Debug)]
pub struct Qemu {
    /// The QEMU [`Qemu::start`] started (none when started by hand).
    guard: Guard,
    link: Link,
    stderr_path: PathBuf,
    /// Bytes received and not yet taken; frames start at `rx_at`.
    rx: Vec<u8>,
    rx_at: usize,
    pending: Vec<u8>,
    timeout: Duration,
}

/// The open link ([`Channel`]).
#[derive(Debug)]
enum Link {
    Tcp(TcpStream),
    Bulk {
        /// Host -> device (`DIR/rx`, written).
        tx: File,
        /// Device -> host (`DIR/tx`, read, non-blocking: waited for with `poll`).
        rx: File,
        /// The directory of the two FIFOs (removed on drop).
        dir: PathBuf,
    },
}

/// A free loopback TCP port (bound and released; QEMU binds it right after).
fn free_port() -> io::Result<u16> {
    let l = TcpListener::bind((Ipv4Addr::LOCALHOST, 0))?;
    Ok(l.local_addr()?.port())
}

impl Qemu {
    fn args(machine: Machine, elf: &Path, to: SerialTo) -> Vec<String> {
        qemu_args(machine.name(), machine.cpu(), &elf.to_string_lossy(), to)
    }

    /// Launches QEMU as `cfg` says with the frames on `to`, pinned to [`next_core`]; the
    /// [`Guard`] kills it on every early return.
    fn spawn(cfg: &QemuConfig, to: SerialTo, stderr_path: &Path) -> Result<Guard, QemuError> {
        let stderr = File::create(stderr_path).map_err(QemuError::Io)?;
        let stdout = match &cfg.log {
            Some(p) => Stdio::from(File::create(p).map_err(QemuError::Io)?),
            None => Stdio::null(),
        };
        let mut args = Self::args(cfg.machine, &cfg.elf, to);
        if cfg.free_run {
            args = without_icount(args);
        }
        let mut cmd = Command::new(QEMU_BIN);
        cmd.args(args);
        let core = if cfg.free_run {
            pin::free_run_core()
        } else {
            next_core()
        };
        let mut launch = Launch {
            pinned_cpu: core,
            ..Launch::default()
        };
        let held = core
            .filter(|_| !cfg.free_run && pin::beside())
            .and_then(crate::realtime::os::hold_on);
        let wrap = |prog: &str, args: [String; 2], cmd: &Command| {
            let mut w = Command::new(prog);
            w.args(args).arg(cmd.get_program()).args(cmd.get_args());
            w
        };
        if let Some(core) = core {
            cmd = wrap("taskset", ["-c".into(), core.to_string()], &cmd);
        }
        if cfg.free_run && cfg.realtime && pin::free_run_rr() {
            launch.sched_rr = Some(pin::FREE_RUN_RR);
            cmd = wrap("chrt", ["-r".into(), pin::FREE_RUN_RR.to_string()], &cmd);
        }
        let child = cmd
            .stdin(Stdio::null())
            .stdout(stdout)
            .stderr(stderr)
            .spawn()
            .map_err(QemuError::QemuMissing)?;
        launch.harness_beside = held.is_some();
        Ok(Guard {
            child: Some(child),
            launch,
            _held: held,
        })
    }

    fn on_link(link: Link, guard: Guard, stderr_path: PathBuf, timeout: Duration) -> Self {
        Self {
            guard,
            link,
            stderr_path,
            rx: Vec::with_capacity(RX_CHUNK + MAX_FRAME),
            rx_at: 0,
            pending: Vec::new(),
            timeout,
        }
    }

    /// How this QEMU was started (its core and real-time priority).
    #[must_use]
    pub fn launch(&self) -> Launch {
        self.guard.launch
    }

    /// Starts QEMU and connects to the firmware's UART0 (or [`QemuConfig::channel`]).
    pub fn start(cfg: &QemuConfig) -> Result<Self, QemuError> {
        cfg.check()?;
        if cfg.channel == Channel::Bulk {
            return Self::start_bulk(cfg);
        }
        let port = free_port().map_err(QemuError::Io)?;
        let stderr_path =
            std::env::temp_dir().join(format!("wheelset-qemu-{}-{port}.err", std::process::id()));
        let mut guard = Self::spawn(cfg, SerialTo::Tcp(port), &stderr_path)?;
        let stream = retry(
            Duration::from_secs(10),
            Duration::from_millis(10),
            || TcpStream::connect((Ipv4Addr::LOCALHOST, port)),
            || {
                guard.exited().map(|_| QemuError::Connect {
                    port,
                    stderr: read_to_string(&stderr_path),
                })
            },
            |e| QemuError::Connect {
                port,
                stderr: format!("{e}; {}", read_to_string(&stderr_path)),
            },
        )?;
        let link = tcp_link(stream, cfg.timeout)?;
        Ok(Self::on_link(link, guard, stderr_path, cfg.timeout))
    }

    /// Connects to a QEMU started by hand with UART0 on `127.0.0.1:port`, trying for
    /// `timeout`, which also bounds each read.
    pub fn connect(port: u16, timeout: Duration) -> Result<Self, QemuError> {
        let stream = retry(
            timeout,
            Duration::from_millis(50),
            || TcpStream::connect((Ipv4Addr::LOCALHOST, port)),
            || None,
            |e| QemuError::Connect {
                port,
                stderr: format!(
                    "{e} (is QEMU running with -serial tcp:127.0.0.1:{port},server=on? \
                     `cargo xtask qemu-cmd target/fw/wheelset-qemu.elf --tcp {port}` \
                     prints its command line)"
                ),
            },
        )?;
        let link = tcp_link(stream, timeout)?;
        let by_hand = Guard::default();
        Ok(Self::on_link(link, by_hand, PathBuf::new(), timeout))
    }

    /// A second handle on the TCP link to UART0; an error on the bulk channel.
    pub fn tcp_stream(&self) -> Result<TcpStream, QemuError> {
        match &self.link {
            Link::Tcp(s) => s.try_clone().map_err(QemuError::Io),
            Link::Bulk { .. } => Err(QemuError::Io(io::Error::other(
                "the bulk channel has no TCP stream",
            ))),
        }
    }

    /// Sends raw bytes to the firmware's UART0 (after any bytes [`Self::queue`]d).
    pub fn send(&mut self, bytes: &[u8]) -> Result<(), QemuError> {
        self.queue(bytes);
        self.flush()
    }

    /// Queues bytes for the device, written (after any queued before) when the host next
    /// waits for the device ([`Self::recv_frame`] with nothing left to take) or sends.
    pub fn queue(&mut self, bytes: &[u8]) {
        self.pending.extend_from_slice(bytes);
    }

    fn flush(&mut self) -> Result<(), QemuError> {
        if self.pending.is_empty() {
            return Ok(());
        }
        let r = match &mut self.link {
            Link::Tcp(s) => s.write_all(&self.pending),
            Link::Bulk { tx, .. } => tx.write_all(&self.pending),
        };
        self.pending.clear();
        r.map_err(|e| self.link_error(e))
    }

    /// Reads at least one byte, or an error (end of stream, or nothing within the timeout).
    fn read_some(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match &mut self.link {
            Link::Tcp(s) => s.read(buf),
            Link::Bulk { rx, .. } => {
                let deadline = Instant::now() + self.timeout;
                loop {
                    let left = deadline.saturating_duration_since(Instant::now());
                    if left.is_zero() || !poll_readable(rx, left)? {
                        return Err(io::Error::new(
                            io::ErrorKind::TimedOut,
                            "no answer from the device within the timeout",
                        ));
                    }
                    match rx.read(buf) {
                        Ok(0) if self.guard.child.is_some() && self.guard.exited().is_none() => {
                            // No writer yet (the firmware opens `tx` after `rx`).
                            std::thread::sleep(Duration::from_millis(1));
                        }
                        Err(e) if e.kind() == io::ErrorKind::WouldBlock => {}
                        r => return r,
                    }
                }
            }
        }
    }

    /// Receives up to the next 0x00 delimiter; returns the COBS frame without it.
    pub fn recv_frame(&mut self) -> Result<Vec<u8>, QemuError> {
        self.with_frame(|f| f.get(..f.len() - 1).unwrap_or(&[]).to_vec())
    }

    /// The next frame, its 0x00 delimiter included, to `f` (no copy): taken from what an
    /// earlier read brought if it is there, else read (queued bytes written first).
    pub fn with_frame<R>(&mut self, f: impl FnOnce(&[u8]) -> R) -> Result<R, QemuError> {
        let mut scanned = self.rx_at;
        loop {
            let held = self.rx.get(scanned..).unwrap_or(&[]);
            if let Some(i) = held.iter().position(|&b| b == 0) {
                let (start, end) = (self.rx_at, scanned + i + 1);
                self.rx_at = end;
                let r = f(self.rx.get(start..end).unwrap_or(&[]));
                if self.rx_at == self.rx.len() {
                    self.rx.clear();
                    self.rx_at = 0;
                }
                return Ok(r);
            }
            if self.rx.len() - self.rx_at > MAX_FRAME {
                return Err(QemuError::FrameTooLong);
            }
            // Nothing whole held: what the device needs first, then wait for it.
            self.flush()?;
            if self.rx_at > 0 {
                self.rx.drain(..self.rx_at);
                self.rx_at = 0;
            }
            scanned = self.rx.len();
            self.rx.resize(scanned + RX_CHUNK, 0);
            let r = {
                let mut buf = std::mem::take(&mut self.rx);
                let r = self.read_some(buf.get_mut(scanned..).unwrap_or(&mut []));
                self.rx = buf;
                r
            };
            let n = match r {
                Ok(0) => {
                    self.rx.truncate(scanned);
                    let e = io::Error::new(io::ErrorKind::UnexpectedEof, "QEMU closed the link");
                    return Err(self.link_error(e));
                }
                Ok(n) => n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => 0,
                Err(e) => {
                    self.rx.truncate(scanned);
                    return Err(self.link_error(e));
                }
            };
            self.rx.truncate(scanned + n);
        }
    }

    /// A link error, or QEMU's exit with its stderr if it is gone.
    fn link_error(&mut self, e: io::Error) -> QemuError {
        match self.guard.exited() {
            Some(status) => {
                QemuError::Exited(format!("{status}; {}", read_to_string(&self.stderr_path)))
            }
            None => QemuError::Link(e),
        }
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        if self.guard.kill() {
            let _ = std::fs::remove_file(&self.stderr_path);
        }
        if let Link::Bulk { dir, .. } = &self.link {
            let _ = std::fs::remove_dir_all(dir);
        }
    }
}

/// A QEMU child, killed on drop.
#[derive(Debug, Default)]
struct Guard {
    child: Option<Child>,
    launch: Launch,
    /// The starting thread held on QEMU's core, released on drop.
    _held: Option<HeldOn>,
}

/// How a QEMU was started: its pinned core and real-time priority, if any.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct Launch {
    /// The core of `taskset -c`, if pinned.
    pub pinned_cpu: Option<usize>,
    /// The `SCHED_RR` priority of `chrt -r`, if set.
    pub sched_rr: Option<u8>,
    /// The starting thread is held on its core (lock-step; not with `WHEELSET_QEMU_PIN=qemu`).
    pub harness_beside: bool,
}

impl Guard {
    /// The child's exit status once it has exited (QEMU gave up: its stderr says why).
    fn exited(&mut self) -> Option<ExitStatus> {
        self.child.as_mut()?.try_wait().ok().flatten()
    }

    /// Whether there was a child to kill (and reap).
    fn kill(&mut self) -> bool {
        let Some(mut c) = self.child.take() else {
            return false;
        };
        let _ = c.kill();
        let _ = c.wait();
        true
    }
}

impl Drop for Guard {
    fn drop(&mut self) {
        self.kill();
    }
}

/// `attempt` every `pause` until it succeeds, `gone` (QEMU exited) or `timeout` passes.
fn retry<T>(
    timeout: Duration,
    pause: Duration,
    mut attempt: impl FnMut() -> io::Result<T>,
    mut gone: impl FnMut() -> Option<QemuError>,
    timed_out: impl FnOnce(io::Error) -> QemuError,
) -> Result<T, QemuError> {
    let deadline = Instant::now() + timeout;
    loop {
        match attempt() {
            Ok(v) => return Ok(v),
            Err(e) if Instant::now() >= deadline => return Err(timed_out(e)),
            Err(_) => match gone() {
                Some(e) => return Err(e),
                None => std::thread::sleep(pause),
            },
        }
    }
}

fn tcp_link(stream: TcpStream, timeout: Duration) -> Result<Link, QemuError> {
    stream.set_nodelay(true).map_err(QemuError::Io)?;
    stream
        .set_read_timeout(Some(timeout))
        .map_err(QemuError::Io)?;
    Ok(Link::Tcp(stream))
}

fn read_to_string(p: &Path) -> String {
    std::fs::read_to_string(p)
        .map(|s| s.trim().to_string())
        .unwrap_or_default()
}
