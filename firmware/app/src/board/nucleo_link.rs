//! The arithmetic of the Nucleo's USART2 + DMA driver (`board::nucleo_usart`): pure
//! functions, tested on the host.
//!
//! **Baud rate** (RM0390 25.4.4, "Fractional baud rate generation"): the baud is
//! `f_PCLK / (8 * (2 - OVER8) * USARTDIV)`. With `d = round(f_PCLK / baud)`, oversampling
//! by 16 takes `BRR = d` (12-bit mantissa, 4-bit fraction of USARTDIV in sixteenths),
//! oversampling by 8 takes `BRR = (d / 8) << 4 | d % 8` (3-bit fraction, bit 3 clear).
//! [`brr`] takes oversampling by 16 when `d >= 16` (better noise immunity), by 8 down to
//! `d = 8` (USARTDIV 1: the highest baud, `f_PCLK / 8`).
//!
//! **Receive ring** (DMA1 stream 5 in circular mode over a [`RING`]-byte buffer): the
//! DMA's write index is `RING - NDTR`; its half-transfer and transfer-complete
//! interrupts count the halves it has filled (`halves`). The total written, modulo
//! 2^32, is
//!
//! `written = halves * RING/2 + (index XOR (halves & 1) * RING/2)`,
//!
//! the scheme of the time driver (`board::nucleo_time`): an even count expects the
//! index in the first half, an odd one in the second, so an index just past a half not
//! yet counted (its interrupt pending) still gives the right total ([`rx_written`]). A
//! reader that has taken `read` bytes has `written - read` new ones; more than [`RING`]
//! means the DMA overwrote bytes not read ([`rx_take`]).

/// The receive ring's size, bytes (a power of two: the index arithmetic masks).
pub const RING: usize = 256;
const HALF: u32 = (RING / 2) as u32;

/// USART_BRR and whether to oversample by 8 (CR1 OVER8) for `baud` from `pclk_hz`;
/// `None` if `baud` is 0 or above `pclk_hz / 8`, or the divider exceeds BRR's 12-bit
/// mantissa.
pub const fn brr(pclk_hz: u32, baud: u32) -> Option<(u16, bool)> {
    if baud == 0 {
        return None;
    }
    let d = (pclk_hz + baud / 2) / baud;
    if d >= 16 {
        if d > 0xFFFF {
            None
        } else {
            Some((d as u16, false))
        }
    } else if d >= 8 {
        Some(((((d / 8) << 4) | (d % 8)) as u16, true))
    } else {
        None
    }
}

/// The baud that `brr`'s result gives from `pclk_hz` (RM0390 25.4.4).
pub const fn baud_of(pclk_hz: u32, brr: u16, over8: bool) -> u32 {
    let brr = brr as u32;
    let d = if over8 {
        (brr >> 4) * 8 + (brr & 7)
    } else {
        brr
    };
    match pclk_hz.checked_div(d) {
        Some(b) => b,
        None => 0,
    }
}

/// The DMA's write index in the ring from its NDTR (remaining transfers, `RING` down to
/// 1; a reload in progress may read 0, which is index 0).
pub const fn rx_index(ndtr: u32) -> u32 {
    (RING as u32).wrapping_sub(ndtr) % RING as u32
}

/// Bytes the DMA has written since start, modulo 2^32, from the halves counted and its
/// write index (see the module docs).
pub const fn rx_written(halves: u32, index: u32) -> u32 {
    halves
        .wrapping_mul(HALF)
        .wrapping_add(index ^ ((halves & 1) * HALF))
}

/// What a reader that has taken `read` bytes can take now that the DMA has written
/// `written`: `(new, 0)`, `new` bytes to copy from ring position `read % RING` on; or, if
/// the DMA lapped the reader (more than `RING` pending), `(0, pending)`: the ring's
/// order is broken, so the reader takes none of it, counts the `pending` bytes as lost
/// and resumes at `written` (the frame decoder resynchronises on the next delimiter).
pub const fn rx_take(read: u32, written: u32) -> (u32, u32) {
    let pending = written.wrapping_sub(read);
    if pending > RING as u32 {
        (0, pending)
    } else {
        (pending, 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn brr_of_the_nucleo_links() {
        // 5.25 Mbaud from 42 MHz: USARTDIV 1, oversampling by 8, exact.
        assert_eq!(brr(42_000_000, 5_250_000), Some((0x10, true)));
        assert_eq!(baud_of(42_000_000, 0x10, true), 5_250_000);
        // 921 600 baud: d = 46 (45.57), by 16; 913 043 baud, -0.93 %.
        assert_eq!(brr(42_000_000, 921_600), Some((46, false)));
        assert_eq!(baud_of(42_000_000, 46, false), 913_043);
        // by 8 with a fraction: d = 12 -> USARTDIV 1.5 -> mantissa 1, fraction 4.
        assert_eq!(brr(42_000_000, 3_500_000), Some((0x14, true)));
        assert_eq!(baud_of(42_000_000, 0x14, true), 3_500_000);
    }

    #[test]
    fn brr_refuses_what_the_usart_cannot_do() {
        assert_eq!(brr(42_000_000, 0), None);
        assert_eq!(brr(42_000_000, 6_000_000), None);
        assert_eq!(brr(42_000_000, 10), None);
    }

    #[test]
    fn brr_is_within_half_a_step_of_the_asked_baud() {
        for baud in [9_600u32, 115_200, 460_800, 921_600, 2_000_000, 4_000_000] {
            let (b, o8) = brr(42_000_000, baud).unwrap();
            let got = baud_of(42_000_000, b, o8);
            let d = (42_000_000 + baud / 2) / baud;
            // The divider is the nearest: off by half a step at most (plus the 1 Hz of
            // `baud_of`'s integer division).
            let err = f64::from(got) - f64::from(baud);
            assert!(
                err.abs() <= f64::from(baud) * 0.5 / f64::from(d) + 1.0,
                "{baud}: {got}"
            );
        }
    }

    #[test]
    fn index_from_ndtr() {
        assert_eq!(rx_index(256), 0);
        assert_eq!(rx_index(255), 1);
        assert_eq!(rx_index(1), 255);
        assert_eq!(rx_index(0), 0);
    }

    /// The DMA after `w` bytes: its index and the halves its interrupts counted, all or
    /// one behind (the interrupt of the half just ended pending).
    fn dma_at(w: u64) -> (u32, u32) {
        ((w % RING as u64) as u32, (w / u64::from(HALF)) as u32)
    }

    #[test]
    fn written_is_the_total_with_the_interrupts_up_to_date_or_one_behind() {
        for w in [
            0u64,
            1,
            127,
            128,
            129,
            255,
            256,
            257,
            1000,
            (1 << 32) - 3,
            (1 << 32) + 130,
        ] {
            let (index, halves) = dma_at(w);
            assert_eq!(rx_written(halves, index), w as u32, "w = {w}");
            // At or just past a half boundary, its interrupt not yet run.
            let at_boundary = w % u64::from(HALF) < 5;
            if at_boundary && halves > 0 {
                assert_eq!(rx_written(halves - 1, index), w as u32, "w = {w}, late");
            }
        }
    }

    #[test]
    fn a_reader_takes_what_is_new_and_counts_a_lap_as_lost() {
        assert_eq!(rx_take(0, 0), (0, 0));
        assert_eq!(rx_take(10, 40), (30, 0));
        assert_eq!(rx_take(0, 256), (256, 0));
        assert_eq!(rx_take(0, 257), (0, 257));
        // Across the u32 wrap of the totals.
        assert_eq!(rx_take(u32::MAX - 9, 20), (30, 0));
        assert_eq!(rx_take(u32::MAX - 299, 20), (0, 320));
    }
}
