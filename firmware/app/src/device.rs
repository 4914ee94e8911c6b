//! What the control task drives: bytes in, one encoded actuation frame out per tick.
//!
//! The board binaries call this interface only; it is the shape of the board-independent
//! runtime's API (`receive(&bytes)`, `tick(last_exec) -> &[u8]`).

/// The device side of the control loop, as the control task sees it.
pub trait Device {
    /// Feeds bytes received from the UART since the previous call (any split).
    fn receive(&mut self, bytes: &[u8]);
    /// Runs one control tick; `last_exec` is the execution time of the previous tick
    /// (cycles on the board, instructions under QEMU). Returns the encoded frame to
    /// transmit (empty when there is nothing to send).
    fn tick(&mut self, last_exec: u32) -> &[u8];
}

/// Largest frame, encoded with its delimiter, that the firmware buffers.
pub const MAX_FRAME: usize = 64;

/// Byte-level COBS encoder (delimiter 0x00), used by [`EchoStub`] only: the real wire
/// format lives in `wheelset-proto`.
fn cobs_encode(data: &[u8], out: &mut heapless::Vec<u8, MAX_FRAME>) -> Result<(), ()> {
    out.clear();
    let mut code_at = out.len();
    out.push(0).map_err(|_| ())?;
    let mut code: u8 = 1;
    for &b in data {
        if b == 0 {
            *out.get_mut(code_at).ok_or(())? = code;
            code_at = out.len();
            out.push(0).map_err(|_| ())?;
            code = 1;
        } else {
            out.push(b).map_err(|_| ())?;
            code += 1;
            if code == 0xFF {
                *out.get_mut(code_at).ok_or(())? = code;
                code_at = out.len();
                out.push(0).map_err(|_| ())?;
                code = 1;
            }
        }
    }
    *out.get_mut(code_at).ok_or(())? = code;
    out.push(0).map_err(|_| ())
}

/// A link test stub, NOT the controller: it proves the board layer (UART, clock, tasks,
/// timing) without the control core. Each tick it answers with one COBS frame
/// `[tick u32 LE][last_exec u32 LE][frames u32 LE][last frame's raw bytes]`, where the
/// last frame is the most recent delimiter-terminated byte run received.
#[derive(Debug, Default)]
pub struct EchoStub {
    ticks: u32,
    frames: u32,
    partial: heapless::Vec<u8, MAX_FRAME>,
    last: heapless::Vec<u8, MAX_FRAME>,
    out: heapless::Vec<u8, MAX_FRAME>,
    overflows: u32,
}

impl EchoStub {
    /// Frames longer than the buffer, dropped.
    pub fn overflows(&self) -> u32 {
        self.overflows
    }
}

impl Device for EchoStub {
    fn receive(&mut self, bytes: &[u8]) {
        for &b in bytes {
            if b == 0 {
                if !self.partial.is_empty() {
                    core::mem::swap(&mut self.last, &mut self.partial);
                    self.partial.clear();
                    self.frames = self.frames.wrapping_add(1);
                }
            } else if self.partial.push(b).is_err() {
                self.overflows = self.overflows.wrapping_add(1);
                self.partial.clear();
            }
        }
    }

    fn tick(&mut self, last_exec: u32) -> &[u8] {
        self.ticks = self.ticks.wrapping_add(1);
        let mut raw: heapless::Vec<u8, MAX_FRAME> = heapless::Vec::new();
        let header = [self.ticks, last_exec, self.frames];
        let fits = header
            .iter()
            .all(|v| raw.extend_from_slice(&v.to_le_bytes()).is_ok())
            && raw.extend_from_slice(&self.last).is_ok();
        if !fits || cobs_encode(&raw, &mut self.out).is_err() {
            self.overflows = self.overflows.wrapping_add(1);
            self.out.clear();
        }
        &self.out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cobs_decode(frame: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut i = 0;
        while i < frame.len() && frame[i] != 0 {
            let code = frame[i] as usize;
            out.extend_from_slice(&frame[i + 1..i + code]);
            i += code;
            if code < 0xFF && frame[i] != 0 {
                out.push(0);
            }
        }
        out
    }

    #[test]
    fn cobs_round_trip_with_zeros() {
        let data = [0u8, 1, 0, 0, 2, 3, 0];
        let mut enc = heapless::Vec::new();
        cobs_encode(&data, &mut enc).unwrap();
        assert_eq!(enc.last(), Some(&0));
        assert!(!enc[..enc.len() - 1].contains(&0));
        assert_eq!(cobs_decode(&enc), data);
    }

    #[test]
    fn echo_reports_tick_exec_and_the_last_whole_frame() {
        let mut d = EchoStub::default();
        d.receive(&[7, 8]);
        d.receive(&[9, 0, 5]); // frame [7 8 9] complete, [5] partial
        let out = cobs_decode(d.tick(1234));
        assert_eq!(&out[0..4], &1u32.to_le_bytes());
        assert_eq!(&out[4..8], &1234u32.to_le_bytes());
        assert_eq!(&out[8..12], &1u32.to_le_bytes());
        assert_eq!(&out[12..], &[7, 8, 9]);
    }

    #[test]
    fn an_oversized_frame_is_dropped_and_counted() {
        let mut d = EchoStub::default();
        d.receive(&[1u8; MAX_FRAME + 1]);
        d.receive(&[0]);
        assert_eq!(d.overflows(), 1);
        let out = cobs_decode(d.tick(0));
        assert_eq!(&out[8..12], &0u32.to_le_bytes());
    }
}
