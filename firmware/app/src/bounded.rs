//! Bounded waits for the fault paths: every poll of a peripheral gives up after a fixed
//! count (no timer needed), so nothing keeps a fault path from its reset.

/// Polls `ready` until `true`, at most `limit` times (0: none, `false`); whether it was.
pub fn poll_until(limit: u32, mut ready: impl FnMut() -> bool) -> bool {
    (0..limit).any(|_| ready())
}

/// Writes `bytes`, each after `ready` (at most `polls_per_byte` polls), stopping at the
/// first byte not taken; the bytes written.
pub fn write_polled(
    bytes: &[u8],
    polls_per_byte: u32,
    mut ready: impl FnMut() -> bool,
    mut write: impl FnMut(u8),
) -> usize {
    bytes
        .iter()
        .take_while(|_| poll_until(polls_per_byte, &mut ready))
        .inspect(|&&b| write(b))
        .count()
}

/// Polls of a UART's TXE flag lasting at least two 8N1 character times (a poll >= 1 cycle).
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

    /// A transmitter ready `delay` polls after each write, dead after `dead_after` bytes.
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
