//! The `y''` integrator's Q32 factors, `v[n] = v[n-1] (1 - T/tau) + a[n] T`.

use wheelset_control::BitsError;

use crate::{RuntimeConfig, RuntimeError};

/// `T` (um/s per 0.1 mm/s^2 code per tick) and `T/tau`, in Q32.
pub(crate) fn acc_factors(cfg: &RuntimeConfig) -> Result<AccBits, RuntimeError> {
    let t = 1.0 / f64::from(cfg.control.base_rate_hz.max(1));
    let q32 = 4_294_967_296.0;
    // 1 code = 1e-4 m/s^2 = 100 um/s^2.
    let gain = 100.0 * t * q32;
    let tau = cfg.acc_washout_s;
    let leak = if tau == 0.0 {
        0.0
    } else if tau.is_finite() && tau >= t {
        t / tau * q32
    } else {
        return Err(RuntimeError::Washout);
    };
    Ok(AccBits {
        gain_q32: round_q(gain),
        leak_q32: round_q(leak),
    })
}

fn round_q(x: f64) -> u64 {
    // x >= 0 here; no libm in no_std: round half up by hand.
    (x + 0.5) as u64
}

/// The `y''` integrator's factors in Q32 (see [`RuntimeConfig::acc_washout_s`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AccBits {
    /// `T` in Q32: um/s per 0.1 mm/s^2 code per tick, in `[1, 2^32]`.
    pub gain_q32: u64,
    /// Wash-out `T/tau` in Q32, in `[0, 2^32]` (0: a pure integrator).
    pub leak_q32: u64,
}

impl AccBits {
    /// Validated (positive gain, both at most `2^32`: `T <= 1 s`, `tau >= T`) as signed Q32.
    pub(crate) fn check(&self) -> Result<(i64, i64), RuntimeError> {
        const ONE: u64 = 1 << 32;
        if !(1..=ONE).contains(&self.gain_q32) {
            return Err(BitsError {
                field: "acc_gain_q32",
            }
            .into());
        }
        if self.leak_q32 > ONE {
            return Err(BitsError {
                field: "acc_leak_q32",
            }
            .into());
        }
        Ok((self.gain_q32 as i64, self.leak_q32 as i64))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_factors_are_t_and_t_over_tau_in_q32_rounded_to_nearest() {
        // 5 kHz, tau = 2 s: T = 200 us per 100 um/s^2 code, 0.02 * 2^32 = 85 899 345.92;
        // T/tau = 1e-4, 1e-4 * 2^32 = 429 496.73.
        let b = acc_factors(&RuntimeConfig::default()).expect("the default");
        assert_eq!(b.gain_q32, 85_899_346);
        assert_eq!(b.leak_q32, 429_497);
        // No wash-out: a pure integrator.
        let pure = RuntimeConfig {
            acc_washout_s: 0.0,
            ..RuntimeConfig::default()
        };
        assert_eq!(acc_factors(&pure).expect("valid").leak_q32, 0);
    }

    #[test]
    fn the_check_takes_its_bounds_and_refuses_beyond_them() {
        const ONE: u64 = 1 << 32;
        let ok = |gain_q32, leak_q32| AccBits { gain_q32, leak_q32 }.check().is_ok();
        assert!(ok(1, 0) && ok(ONE, ONE));
        assert!(!ok(0, 0), "a zero gain");
        assert!(!ok(ONE + 1, 0), "a gain above 1");
        assert!(!ok(1, ONE + 1), "a leak above 1");
    }
}
