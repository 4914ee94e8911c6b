//! Execution time of one tick: DWT `CYCCNT` on a board; under QEMU SysTick at 25 MHz of
//! virtual time, `instructions = counts * 40 ns / 2^N ns` with `-icount shift=N`.

/// Cycles between two reads of a 32-bit up-counter (DWT CYCCNT), across a wrap.
pub fn cyccnt_elapsed(start: u32, end: u32) -> u32 {
    end.wrapping_sub(start)
}

/// Counts between two reads of the 24-bit down-counting SysTick, across at most one wrap.
pub fn systick_elapsed(start: u32, end: u32) -> u32 {
    start.wrapping_sub(end) & 0x00FF_FFFF
}

/// SysTick period of the mps2 boards' 25 MHz core clock, in ns.
pub const MPS2_SYSTICK_NS: u32 = 40;

/// Instructions in `counts` SysTick counts: `counts * 40 / 2^shift`, rounded, saturating.
pub fn systick_to_instructions(counts: u32, shift: u32) -> u32 {
    let ns = u64::from(counts) * u64::from(MPS2_SYSTICK_NS);
    let half = (1u64 << shift) >> 1;
    u32::try_from((ns + half) >> shift).unwrap_or(u32::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cyccnt_wraps() {
        assert_eq!(cyccnt_elapsed(10, 25), 15);
        assert_eq!(cyccnt_elapsed(u32::MAX - 4, 5), 10);
    }

    #[test]
    fn systick_counts_down_and_wraps_at_24_bits() {
        assert_eq!(systick_elapsed(0x00FF_FFFF, 0x00FF_FF00), 0xFF);
        // Wrapped once: start 5, reload to 0xFF_FFFF, down to 0xFF_FFF0.
        assert_eq!(systick_elapsed(5, 0x00FF_FFF0), 5 + 1 + 0xF);
    }

    #[test]
    fn instruction_conversion_matches_the_clock_ratio() {
        // shift 0: 1 ns per instruction, 40 instructions per count.
        assert_eq!(systick_to_instructions(3, 0), 120);
        // shift 3: 8 ns per instruction, 5 per count.
        assert_eq!(systick_to_instructions(100, 3), 500);
        // shift 6: 64 ns per instruction; 8 counts = 320 ns = 5 instructions.
        assert_eq!(systick_to_instructions(8, 6), 5);
        assert_eq!(systick_to_instructions(u32::MAX, 0), u32::MAX);
    }
}
