//! The bulk channel: frames over semihosting file I/O on two host FIFOs (`bulk:DIR`)
//! instead of UART0, for runs faster than real time; otherwise the UART build's path, so
//! the same frames bit for bit. One `SYS_READ` takes whatever the host has sent, one
//! `SYS_WRITE` sends the answers of the whole read ([`Bulk::run`]).

use core::cell::RefCell;
use core::sync::atomic::{AtomicI32, Ordering};

use critical_section::Mutex;

use cortex_m_semihosting::nr;

/// The TX FIFO's semihosting handle, or -1 (the UART is the channel).
static TX: AtomicI32 = AtomicI32::new(-1);

/// The opened bulk channel's receive side.
pub struct Bulk {
    rx: usize,
}

/// `SYS_OPEN` of the NUL-terminated `path` (`len` without the NUL) in `mode`; the handle.
fn open_file(path: &[u8], mode: usize) -> Option<usize> {
    let len = path.iter().position(|&b| b == 0)?;
    // SAFETY: the block names a NUL-terminated string live for the call; QEMU only reads it.
    let h = unsafe { cortex_m_semihosting::syscall!(OPEN, path.as_ptr(), mode, len) } as isize;
    (h >= 0).then_some(h as usize)
}

/// The bulk channel if the command line asks for it, opened (blocks for the host).
pub fn open() -> Option<Bulk> {
    let mut cmd = [0u8; 256];
    let mut block = [cmd.as_mut_ptr() as usize, cmd.len() - 1];
    // SAFETY: `SYS_GET_CMDLINE` writes at most `block[1]` bytes into `cmd`, both mutably borrowed.
    let r = unsafe { cortex_m_semihosting::syscall1(nr::GET_CMDLINE, block.as_mut_ptr() as usize) };
    if r != 0 {
        return None;
    }
    let line = cmd.get(..block[1].min(cmd.len() - 1))?;
    let dir = line
        .split(|&b| b == b' ')
        .find_map(|arg| arg.strip_prefix(b"bulk:"))?;
    let mut path = [0u8; 200];
    let name = |path: &mut [u8; 200], leaf: &[u8]| -> Option<()> {
        let n = dir.len();
        path.get_mut(..n)?.copy_from_slice(dir);
        path.get_mut(n..n + leaf.len())?.copy_from_slice(leaf);
        *path.get_mut(n + leaf.len())? = 0;
        Some(())
    };
    name(&mut path, b"/rx")?;
    let rx = open_file(&path, nr::open::R_BINARY)?;
    name(&mut path, b"/tx")?;
    let tx = open_file(&path, nr::open::W_TRUNC_BINARY)?;
    TX.store(tx as i32, Ordering::Relaxed);
    Some(Bulk { rx })
}

/// Whether the frames go over the bulk channel.
pub fn active() -> bool {
    TX.load(Ordering::Relaxed) >= 0
}

/// Writes `bytes` to the TX FIFO (blocking); a failed write loses the frame.
pub fn write_all(bytes: &[u8]) {
    let h = TX.load(Ordering::Relaxed) as usize;
    let mut rest = bytes;
    while !rest.is_empty() {
        // SAFETY: the block names `rest`, live for the call; QEMU only reads it.
        let left = unsafe { cortex_m_semihosting::syscall!(WRITE, h, rest.as_ptr(), rest.len()) };
        if left >= rest.len() {
            return;
        }
        rest = rest.get(rest.len() - left..).unwrap_or(&[]);
    }
}

/// Room for the answers of one read: two ticks' worth at least ([`crate::settings::TX_PIPE`]
/// each), flushed early when the next would not fit.
const BATCH: usize = 2 * crate::settings::TX_PIPE;

/// The answers of the frames read so far, in order, not yet written.
struct Batch {
    buf: [u8; BATCH],
    len: usize,
}

static BATCH_OUT: Mutex<RefCell<Batch>> = Mutex::new(RefCell::new(Batch {
    buf: [0; BATCH],
    len: 0,
}));

impl Batch {
    /// Appends `bytes`, writing out what is held first if they would not fit.
    fn push(&mut self, bytes: &[u8]) {
        if self.len + bytes.len() > BATCH {
            self.flush();
        }
        match self.buf.get_mut(self.len..self.len + bytes.len()) {
            Some(room) => {
                room.copy_from_slice(bytes);
                self.len += bytes.len();
            }
            None => write_all(bytes),
        }
    }

    /// Writes what is held (one `SYS_WRITE`).
    fn flush(&mut self) {
        if self.len > 0 {
            write_all(self.buf.get(..self.len).unwrap_or(&[]));
            self.len = 0;
        }
    }
}

/// Moves the TX pipe's frames (the tick's answer) into the batch: each tick starts it empty.
fn take_answers() {
    critical_section::with(|cs| {
        let mut b = BATCH_OUT.borrow_ref_mut(cs);
        while crate::app::TX.read_in_place(|run| b.push(run)).is_ok() {}
    });
}

/// Writes the answers held (the end of a read, or before the safe frame, which follows them).
pub fn flush_answers() {
    critical_section::with(|cs| {
        if let Ok(mut b) = BATCH_OUT.borrow(cs).try_borrow_mut() {
            b.flush();
        }
    });
}

impl Bulk {
    /// Reads what the host wrote (blocking for a byte); 0 at the end of the stream.
    fn read(&self, buf: &mut [u8]) -> usize {
        // SAFETY: QEMU writes at most `buf.len()` bytes into `buf`, exclusively borrowed.
        let left =
            unsafe { cortex_m_semihosting::syscall!(READ, self.rx, buf.as_mut_ptr(), buf.len()) };
        buf.len().saturating_sub(left)
    }

    /// The receiver, in thread mode: each frame of a read into the RX pipe, then its
    /// frame edge and tick; the read's answers in one write.
    pub fn run(self) -> ! {
        let mut buf = [0u8; 256];
        loop {
            let n = self.read(&mut buf);
            if n == 0 {
                loop {
                    cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_SUCCESS);
                }
            }
            let mut rest = buf.get(..n).unwrap_or(&[]);
            while !rest.is_empty() {
                let end = rest
                    .iter()
                    .position(|&b| b == 0)
                    .map_or(rest.len(), |i| i + 1);
                let (part, more) = rest.split_at(end);
                let mut left = part;
                while !left.is_empty() {
                    match crate::app::RX.try_write(left) {
                        Ok(k) => left = left.get(k..).unwrap_or(&[]),
                        Err(_) => {
                            crate::app::RX_OVERRUN.fetch_add(left.len() as u32, Ordering::Relaxed);
                            break;
                        }
                    }
                }
                crate::watchdog::rx_ran();
                if part.last() == Some(&0) {
                    super::clock::frame_edge();
                    // SAFETY: SWI0, the executor's interrupt, is masked on the bulk channel
                    // (`super::run`): this is the only place it is polled, in thread mode.
                    unsafe { super::EXEC_CONTROL.on_interrupt() };
                    take_answers();
                }
                if crate::watchdog::take_both() {
                    super::wdog::feed();
                }
                rest = more;
            }
            flush_answers();
        }
    }
}
