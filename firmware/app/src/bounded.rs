//! Bounded waits for the fault paths (panic, HardFault): every poll of a peripheral
//! there gives up after a fixed number of reads, so a peripheral that never becomes
//! ready (not clocked yet, wedged, misconfigured) cannot keep the path from its end (a
//! reset). Board-independent and tested on the host; the boards pass their register
//! reads and writes as closures.
//!
//! The bound is a count of polls, not a time: it needs no timer (a fault may come before
//! any timer runs, or from one). A poll is at least one core cycle, so a bound of
//! [`polls_per_char`] polls lasts at least two character times of the UART at the core
//! clock it is computed from: a working UART is never given up on early.

/// Polls `ready` until it returns `true`, at most `limit` times; `true` if it did.
/// `limit` 0 polls nothing and gives `false`.
pub fn poll_until(limit: u32, mut ready: impl FnMut() -> bool) -> bool {
    (0..limit).any(|_| ready())
}

/// Writes `bytes` one at a time with `write`, each after `ready` said the transmitter
/// can take it (polled at most `polls_per_byte` times per byte). Stops at the first byte
/// the transmitter did not take within its bound; returns the bytes written.
pub fn write_polled(
    bytes: &[u8],
    polls_per_byte: u32,
    mut ready: impl FnMut() -> bool,
    mut write: impl FnMut(u8),
) -> usize {
    let mut written = 0;
    for &b in bytes {
        if !poll_until(polls_per_byte, &mut ready) {
            break;
        }
        write(b);
        written += 1;
    }
    written
}

/// Polls of a UART's "transmit data register empty" flag that last at least two
/// character times (10 bits each: 8N1) at `baud` on a core clocked at `core_hz`
/// (a poll takes at least one core cycle), saturating; at least 1.
pub const fn polls_per_char(core_hz: u32, baud: u32) -> u32 {
    let cycles = match (core_hz as u64 * 10).checked_div(baud as u64) {
        Some(c) => c,
        None => 0,
    };
    let polls = cycles.saturating_mul(2);
    if polls == 0 {
        1
    } else if polls > u32::MAX as u64 {
        u32::MAX
    } else {
        polls as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flag_that_never_sets_is_polled_exactly_the_limit() {
        let mut polls = 0u32;
        assert!(!poll_until(1000, || {
            polls += 1;
            false
        }));
        assert_eq!(polls, 1000);
        assert!(!poll_until(0, || unreachable!(
            "a zero bound polls nothing"
        )));
    }

    #[test]
    fn a_flag_that_sets_ends_the_wait_at_once() {
        let mut polls = 0u32;
        assert!(poll_until(1000, || {
            polls += 1;
            polls == 7
        }));
        assert_eq!(polls, 7);
    }

    /// A transmitter whose "ready" flag sets after `delay` polls following each write,
    /// or never once `dead_after` bytes went out.
    struct Uart {
        delay: u32,
        dead_after: usize,
        since_write: u32,
        out: Vec<u8>,
        polls: u32,
    }

    impl Uart {
        fn new(delay: u32, dead_after: usize) -> Self {
            Self {
                delay,
                dead_after,
                since_write: 0,
                out: Vec::new(),
                polls: 0,
            }
        }
    }

    fn send(u: &mut Uart, bytes: &[u8], limit: u32) -> usize {
        let u = core::cell::RefCell::new(u);
        write_polled(
            bytes,
            limit,
            || {
                let mut u = u.borrow_mut();
                u.polls += 1;
                u.since_write += 1;
                u.out.len() < u.dead_after && u.since_write > u.delay
            },
            |b| {
                let mut u = u.borrow_mut();
                u.out.push(b);
                u.since_write = 0;
            },
        )
    }

    #[test]
    fn a_working_uart_gets_every_byte() {
        let frame = [0u8, 1, 2, 3, 0x55, 0xAA];
        let mut u = Uart::new(40, usize::MAX);
        assert_eq!(send(&mut u, &frame, 100), frame.len());
        assert_eq!(u.out, frame);
    }

    #[test]
    fn a_dead_uart_ends_the_frame_after_one_bound() {
        // Never ready: the first byte's bound, then nothing more is polled.
        let mut u = Uart::new(0, 0);
        assert_eq!(send(&mut u, &[1, 2, 3, 4], 500), 0);
        assert_eq!(u.polls, 500);
        assert!(u.out.is_empty());
    }

    #[test]
    fn a_uart_that_wedges_mid_frame_stops_there() {
        let mut u = Uart::new(3, 2);
        assert_eq!(send(&mut u, &[9, 8, 7, 6], 50), 2);
        assert_eq!(u.out, [9, 8]);
        // Two bytes at 4 polls each, then one full bound on the third.
        assert_eq!(u.polls, 4 + 4 + 50);
    }

    #[test]
    fn a_uart_slower_than_the_bound_is_given_up() {
        let mut u = Uart::new(60, usize::MAX);
        assert_eq!(send(&mut u, &[1, 2], 60), 0);
        assert_eq!(u.polls, 60);
    }

    #[test]
    fn polls_per_char_is_two_characters_of_core_cycles() {
        // 168 MHz core, 921 600 baud: 10 bits are 1 822.9 cycles; twice that, floored.
        assert_eq!(polls_per_char(168_000_000, 921_600), 3_644);
        // 5.25 Mbaud: 320 cycles per character.
        assert_eq!(polls_per_char(168_000_000, 5_250_000), 640);
        // At least one poll, whatever the figures.
        assert_eq!(polls_per_char(0, 9_600), 1);
        assert_eq!(polls_per_char(168_000_000, 0), 1);
        assert_eq!(polls_per_char(u32::MAX, 1), u32::MAX);
    }

    #[test]
    fn the_bound_covers_a_character_at_one_poll_per_cycle() {
        // A UART that needs exactly a character time (in cycles, one poll each) per byte
        // gets every byte within the bound.
        let core_hz = 168_000_000;
        let baud = 921_600;
        let char_cycles = core_hz * 10 / baud;
        let mut u = Uart::new(char_cycles, usize::MAX);
        let frame = [0x11u8; 8];
        assert_eq!(
            send(&mut u, &frame, polls_per_char(core_hz, baud)),
            frame.len()
        );
    }
}
