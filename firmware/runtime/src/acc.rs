//! The acceleration integrator's factors: `y''` frames integrated into `y'` with a
//! wash-out, `v[n] = v[n-1] (1 - T/tau) + a[n] T`, as Q32 integers fixed at build time.

use wheelset_control::BitsError;

use crate::{RuntimeConfig, RuntimeError};

/// The `y''` integrator's factors in Q32: `T` (um/s per 0.1 mm/s^2 code per tick) and
/// `T/tau`. Computed once here (f64), so the tick has no division.
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
    /// Validated (positive gain, both at most `2^32`, i.e. `T <= 1 s` per 100 um/s^2 and
    /// `tau >= T`) as signed Q32 factors.
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
