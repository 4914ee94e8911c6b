//! The bounded transmit queue of a real-time loop (the harness's and `hil serve`'s): whole
//! frames queued or dropped, written out without blocking.

use std::collections::VecDeque;
use std::io::{self, Write};

/// Writes `bytes` to `port` without waiting: what does not fit now is kept in `queue`
/// (at most `cap` bytes; a frame that does not fit whole is dropped, returns false).
pub fn queue_frame(queue: &mut VecDeque<u8>, cap: usize, bytes: &[u8]) -> bool {
    if queue.len() + bytes.len() > cap {
        return false;
    }
    queue.extend(bytes);
    true
}

/// Writes as much of `queue` as `port` takes now.
pub fn flush_queue<W: Write + ?Sized>(port: &mut W, queue: &mut VecDeque<u8>) -> io::Result<()> {
    while !queue.is_empty() {
        let (a, _) = queue.as_slices();
        match port.write(a) {
            Ok(0) => return Ok(()),
            Ok(n) => {
                queue.drain(..n);
            }
            Err(e) if crate::serial::nothing_yet(&e) => return Ok(()),
            Err(e) => return Err(e),
        }
    }
    Ok(())
}
