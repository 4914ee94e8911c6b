//! Bookkeeping shared by the lock-step transports (QEMU, a frame-clocked serial device):
//! every 0x00 frame delimiter the host sends is one device tick, and each tick answers
//! with one Actuation frame, followed by a Status frame when the tick's input held a
//! `RequestStatus` command. [`Expect`] counts the frames the host must wait for.

use wheelset_proto::{Command, Decoder, Message};

/// Frames the device owes the host.
#[derive(Debug, Default)]
pub struct Expect {
    decoder: Decoder,
    owed: u64,
}

impl Expect {
    /// Nothing owed.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Accounts for bytes sent: one frame per delimiter, two for a status request.
    pub fn sent(&mut self, bytes: &[u8]) {
        for &b in bytes {
            let r = self.decoder.push(b);
            if b == 0 {
                self.owed += 1;
                if let Some(Ok(Message::Command(Command::RequestStatus))) = r {
                    self.owed += 1;
                }
            }
        }
    }

    /// Accounts for received bytes: one frame per delimiter.
    pub fn received(&mut self, bytes: &[u8]) {
        let n = bytes.iter().filter(|&&b| b == 0).count() as u64;
        self.owed = self.owed.saturating_sub(n);
    }

    /// Frames still owed.
    #[must_use]
    pub fn owed(&self) -> u64 {
        self.owed
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wheelset_proto::{encode_vec, Lateral, Sensor};

    #[test]
    fn a_frame_owes_one_a_status_request_two() {
        let mut e = Expect::new();
        let s = Sensor {
            seq: 1,
            t_us: 0,
            lateral: Lateral::Velocity(0),
            i_a_ma: 0,
            omega_m_mrad_s: 0,
            demand_nm: 0,
            v_ref_mm_s: 0,
        };
        e.sent(&encode_vec(&Message::Sensor(s)).unwrap_or_default());
        assert_eq!(e.owed(), 1);
        e.sent(&encode_vec(&Message::Command(Command::RequestStatus)).unwrap_or_default());
        assert_eq!(e.owed(), 3);
        e.sent(&[0]);
        assert_eq!(e.owed(), 4);
        e.received(&[1, 2, 0, 5, 0]);
        assert_eq!(e.owed(), 2);
    }
}
