//! The STM32 clock-tree assumptions as pure functions, checked at start-up, tested on the host:
//! - USART (RM0390 25.4.4): `baud = f_PCLK / (8 * (2 - OVER8) * USARTDIV)`; embassy-stm32
//!   takes `d = round(f_PCLK / baud)`: by 16 with `BRR = d` for `d >= 16`, else by 8 with
//!   `BRR = (d / 8) << 4 | d % 8` down to `d = 8`.
//! - LPUART (RM0440): `baud = 256 * f_ck / LPUARTDIV`, LPUARTDIV >= 0x300.
//! - Time base: prescaler `f_TIM / TICK_HZ - 1`, exact only for a whole multiple.

/// USART_BRR and OVER8 for `baud` from `pclk_hz` as embassy-stm32 chooses them, if any.
pub const fn brr(pclk_hz: u32, baud: u32) -> Option<(u16, bool)> {
    if baud == 0 {
        return None;
    }
    let d = ((pclk_hz as u64 + baud as u64 / 2) / baud as u64) as u32;
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

/// The baud USART2 makes for `baud` from `pclk_hz` (`None`: it cannot make it).
pub const fn made_baud(pclk_hz: u32, baud: u32) -> Option<u32> {
    match brr(pclk_hz, baud) {
        Some((b, over8)) => Some(baud_of(pclk_hz, b, over8)),
        None => None,
    }
}

/// Whether the baud `made` (`None`: cannot) is `baud` within `tolerance_permille`.
pub const fn within(made: Option<u32>, baud: u32, tolerance_permille: u32) -> bool {
    match made {
        Some(made) => made.abs_diff(baud) as u64 * 1000 <= baud as u64 * tolerance_permille as u64,
        None => false,
    }
}

/// The baud an LPUART on `ck_hz` makes for `baud` (`None`: above `ck_hz / 3`, or prescaled).
pub const fn lpuart_made_baud(ck_hz: u32, baud: u32) -> Option<u32> {
    if baud == 0 {
        return None;
    }
    let (ck, b) = (ck_hz as u64, baud as u64);
    let div = (256 * ck + b / 2) / b;
    if div < 0x300 || div >= 0x10_0000 {
        None
    } else {
        Some((256 * ck / div) as u32)
    }
}

/// Whether a timer at `timer_hz` counts exactly `tick_hz` through a 16-bit prescaler.
pub const fn timer_divides(timer_hz: u32, tick_hz: u32) -> bool {
    match timer_hz.checked_div(tick_hz) {
        Some(div) => div >= 1 && div <= 65_536 && timer_hz.is_multiple_of(tick_hz),
        None => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether USART2 on `pclk_hz` makes `baud` within `tolerance_permille` (0: exactly).
    fn baud_fits(pclk_hz: u32, baud: u32, tolerance_permille: u32) -> bool {
        within(made_baud(pclk_hz, baud), baud, tolerance_permille)
    }

    #[test]
    fn brr_of_the_nucleo_links() {
        // 5.25 Mbaud from 42 MHz: USARTDIV 1, oversampling by 8, exact.
        assert_eq!(brr(42_000_000, 5_250_000), Some((0x10, true)));
        assert_eq!(made_baud(42_000_000, 5_250_000), Some(5_250_000));
        // 921 600 baud: d = 46 (45.57), by 16; 913 043 baud, -0.93 %.
        assert_eq!(brr(42_000_000, 921_600), Some((46, false)));
        assert_eq!(made_baud(42_000_000, 921_600), Some(913_043));
        // by 8 with a fraction: d = 12 -> USARTDIV 1.5 -> mantissa 1, fraction 4.
        assert_eq!(brr(42_000_000, 3_500_000), Some((0x14, true)));
        assert_eq!(baud_of(42_000_000, 0x14, true), 3_500_000);
    }

    #[test]
    fn brr_refuses_what_the_usart_cannot_do() {
        assert_eq!(brr(42_000_000, 0), None);
        assert_eq!(brr(42_000_000, 6_000_000), None);
        assert_eq!(brr(42_000_000, 10), None);
        assert_eq!(made_baud(42_000_000, 6_000_000), None);
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
    fn the_builds_bauds_fit_the_clock_tree_they_assume_and_not_another() {
        // Free-running: 5.25 Mbaud exactly from APB1 at 42 MHz (SYSCLK 168 MHz / 4) ...
        assert!(baud_fits(42_000_000, 5_250_000, 0));
        // ... not from 45 MHz (SYSCLK 180 MHz / 4: d = 8.57 rounds to 9, 5 Mbaud). The
        // check is on the baud made, not on the clock: 84 MHz makes it too (d = 16, by 16).
        assert!(!baud_fits(45_000_000, 5_250_000, 0));
        assert!(!baud_fits(45_000_000, 5_250_000, 10));
        assert!(baud_fits(84_000_000, 5_250_000, 0));
        // Frame-clocked: 921 600 baud within 1 % from 42 MHz (-0.93 %), not exactly.
        assert!(baud_fits(42_000_000, 921_600, 10));
        assert!(!baud_fits(42_000_000, 921_600, 9));
        // Nothing fits a baud the USART cannot make.
        assert!(!baud_fits(16_000_000, 5_250_000, 1000));
    }

    #[test]
    fn the_lpuart_makes_the_g474_link_exactly_and_refuses_what_it_cannot() {
        // 5.3125 Mbaud from 170 MHz: LPUARTDIV 8192, exact.
        assert_eq!(lpuart_made_baud(170_000_000, 5_312_500), Some(5_312_500));
        assert!(within(
            lpuart_made_baud(170_000_000, 5_312_500),
            5_312_500,
            0
        ));
        // Nearest divider otherwise: 921 600 baud is LPUARTDIV 47 222 (921 604 baud).
        assert_eq!(lpuart_made_baud(170_000_000, 921_600), Some(921_604));
        // Above f_ck / 3 (LPUARTDIV under 0x300), at 0, or needing the prescaler: none.
        assert_eq!(lpuart_made_baud(170_000_000, 60_000_000), None);
        assert_eq!(lpuart_made_baud(170_000_000, 0), None);
        assert_eq!(lpuart_made_baud(170_000_000, 9_600), None);
        assert!(!within(None, 9_600, 1000));
    }

    #[test]
    fn the_time_base_is_exact_only_on_a_whole_multiple_of_the_tick() {
        // APB1 42 MHz, timer clock doubled: 84 MHz to 1 MHz ticks, PSC 83.
        assert!(timer_divides(84_000_000, 1_000_000));
        assert!(timer_divides(1_000_000, 1_000_000));
        assert!(timer_divides(65_536 * 1000, 1000));
        assert!(!timer_divides(65_537 * 1000, 1000));
        assert!(!timer_divides(84_000_000, 999_999));
        assert!(!timer_divides(90_000_001, 1_000_000));
        assert!(!timer_divides(1_000, 1_000_000));
        assert!(!timer_divides(84_000_000, 0));
    }
}
