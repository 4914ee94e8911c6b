//! What the STM32 board builds assume of their clock trees, as pure functions checked at
//! start-up against the clocks embassy-stm32 configured (`embassy_stm32::rcc::clocks`)
//! and tested on the host.
//!
//! **USART baud rate** (the F446's USART2; RM0390 25.4.4, "Fractional baud rate
//! generation"): USART2 runs on
//! PCLK1 and makes `f_PCLK / (8 * (2 - OVER8) * USARTDIV)`. embassy-stm32's driver takes
//! `d = round(f_PCLK / baud)` (`usart::find_and_set_brr`): oversampling by 16 with
//! `BRR = d` (12-bit mantissa, 4-bit fraction of USARTDIV in sixteenths) when `d >= 16`,
//! by 8 with `BRR = (d / 8) << 4 | d % 8` (3-bit fraction) down to `d = 8` (USARTDIV 1:
//! the highest baud, `f_PCLK / 8`). [`brr`] and [`baud_of`] model that choice, so
//! [`baud_fits`] says which baud the HAL's USART2 really makes from a PCLK1.
//!
//! **LPUART baud rate** (the G474's LPUART1; RM0440, "LPUART baud rate
//! generation"): `baud = 256 * f_ck / LPUARTDIV`, with LPUARTDIV (BRR, 20 bits) at least
//! 0x300. embassy-stm32 takes `LPUARTDIV = round(256 * f_ck / baud)` with the kernel
//! clock undivided when that is below 2^20 (`usart::calculate_brr`), else a prescaler;
//! [`lpuart_made_baud`] models the undivided case, which every baud above
//! `f_ck / 4096` is.
//!
//! **Time base**: embassy-stm32's time driver sets its timer's prescaler to
//! `f_TIM / TICK_HZ - 1` (integer division, `time_driver/gp16.rs`): the ticks are exact
//! only if the timer clock is a whole multiple of the tick rate within the 16-bit
//! prescaler's range ([`timer_divides`]).

/// USART_BRR and whether to oversample by 8 (CR1 OVER8) for `baud` from `pclk_hz`, as
/// embassy-stm32 chooses them; `None` if `baud` is 0 or above `pclk_hz / 8`, or the
/// divider exceeds BRR's 16 bits.
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

/// Whether USART2 on `pclk_hz` makes `baud` within `tolerance_permille` parts per
/// thousand (0: exactly).
pub const fn baud_fits(pclk_hz: u32, baud: u32, tolerance_permille: u32) -> bool {
    within(made_baud(pclk_hz, baud), baud, tolerance_permille)
}

/// Whether the baud a UART `made` (`None`: it cannot make it) is `baud` within
/// `tolerance_permille` parts per thousand (0: exactly).
pub const fn within(made: Option<u32>, baud: u32, tolerance_permille: u32) -> bool {
    match made {
        Some(made) => made.abs_diff(baud) as u64 * 1000 <= baud as u64 * tolerance_permille as u64,
        None => false,
    }
}

/// The baud an LPUART on kernel clock `ck_hz` makes for `baud` (`None`: above `ck_hz / 3`,
/// or so low that it needs the prescaler, which this model leaves out).
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

/// Whether a timer clocked at `timer_hz` counts exactly `tick_hz` through a 16-bit
/// prescaler (PSC = `timer_hz / tick_hz - 1`, RM0390 18.4.11): `timer_hz` a whole
/// multiple of `tick_hz`, the ratio from 1 to 65 536.
pub const fn timer_divides(timer_hz: u32, tick_hz: u32) -> bool {
    match timer_hz.checked_div(tick_hz) {
        Some(div) => div >= 1 && div <= 65_536 && timer_hz.is_multiple_of(tick_hz),
        None => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
