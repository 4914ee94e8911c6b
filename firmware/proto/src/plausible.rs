//! What a [`crate::Config`] may ask of the device: the plausible range of every field,
//! stated once ([`PLAUSIBLE`]), and the [`RefuseReason`] codes the device reports in
//! [`crate::Status`] `refuse_reason` when it refuses one (counted in `cmd_refused`,
//! flagged [`crate::Flags::CMD_REFUSED`], the old configuration kept).
//!
//! A Config can change the rates, the yaw law, traction, the output enable, the hold
//! time and the switches; the coefficients in [`crate::Rates`] are not free parameters:
//! each must be what the device's own control core yields for the requested rates, within
//! [`RATE_TOLERANCE`] (relative) plus one LSB of a fixed-point format. The device checks
//! that without discretising (it has no float maths): every rate-dependent coefficient is
//! a known function of its loop period `T`, so it compares the received value with the
//! one its start-up core has at its own period `T0`:
//!
//! ```text
//! linear in T (ki, iref_step, iref_safe_step, torque_step, acc_gain, acc_leak):
//!     x(T) = x(T0) T/T0
//! the lead's kappa = 2c/(1 + c) with c = w2 T/2 (Tustin, no pre-warping):
//!     c(T) = c(T0) T/T0,  c = kappa/(2 - kappa)
//! T = yaw_div/base_rate (kappa, predict, torque_step), traction_div/base_rate (ki,
//!     iref steps), 1/base_rate (the y'' integrator's acc_gain, acc_leak)
//! ```
//!
//! | field | min | max | unit | why |
//! |---|---|---|---|---|
//! | `rates.numeric` | the device's | the device's | code | the coefficients' bit format |
//! | `rates.fingerprint` | the device's | the device's | hash | computed against this core's gains, limits, scales |
//! | `rates.base_rate_hz` | 500 | 20 000 | Hz | the slowest loop rate below (a base rate under it leaves no valid divisor); at 20 kHz the tick's budget (`cargo xtask fw-bench`: 1 500 instructions mean, 3 000 at most) is under 40 % of the 8 400-cycle period of the board's 168 MHz core. The low end is about what a device can run, not stability: the rate analysis (`sim-host rates`) finds the current loop unstable below 2.5 kHz with one period of delay. 500 Hz is the free-running QEMU's rate (its UART's byte rate, README "QEMU free-running") |
//! | period `1/base_rate_hz` | - | - | us | a whole number of microseconds: the board's ticker counts 1 us ([`TICKER_HZ`]) |
//! | yaw loop rate `base_rate_hz/yaw_div` | 500 | - | Hz | the slowest yaw rate the rate analysis evaluates (the lead's `w2 T/2` = 0.27) |
//! | traction loop rate `base_rate_hz/traction_div` | 500 | - | Hz | 5 samples per `L_a/R_a` = 10 ms armature time constant at least |
//! | `hold_ticks x T` | 0 | 20 000 | us | a fifth of the ~10 Hz kinematic mode's period: an older `y'` is off by more than 70 degrees of phase |
//! | `kappa`, `ki`, `iref_step`, `iref_safe_step`, `torque_step`, `acc_gain_q32`, `acc_leak_q32` | `1 - 2^-10` | `1 + 2^-10` | x the device's own value at the requested rates (+ 1 LSB fixed point) | only the rates may change them |
//! | `predict_half` | 0 | 0.75 | coefficient | `alpha/2`, `alpha = tau/T_yaw`; the matched compensation (zero-order hold + one tick = `1 + yaw_div/2` ticks) is at most 1.5 |
//! | f32 coefficients | - | - | - | normal numbers only (no subnormal, infinite, NaN or negative bit pattern) |
//!
//! [`PLAUSIBLE`] is this table as data (for tools and reports); the device uses the
//! constants it is built from.

/// The board's ticker resolution, Hz: a base period must be a whole number of its ticks
/// (embassy-time with `tick-hz-1_000_000`: 1 us).
pub const TICKER_HZ: u32 = 1_000_000;

/// Lowest plausible base rate, Hz: [`LOOP_RATE_MIN_HZ`], the slowest loop (both loops at
/// divisor 1).
pub const BASE_RATE_MIN_HZ: u32 = LOOP_RATE_MIN_HZ;
/// Highest plausible base rate, Hz.
pub const BASE_RATE_MAX_HZ: u32 = 20_000;
/// Lowest plausible yaw and traction loop rate (`base_rate_hz / divisor`), Hz.
pub const LOOP_RATE_MIN_HZ: u32 = 500;
/// Longest plausible hold on a stale sample, `hold_ticks / base_rate_hz`, us.
pub const HOLD_MAX_US: u32 = 20_000;
/// Largest plausible `predict_half` (`alpha/2`), as a fraction `num/2^2`: 3/4.
pub const PREDICT_HALF_MAX_QUARTERS: u32 = 3;
/// Relative tolerance of a rate-dependent coefficient against the device's own value:
/// `2^-RATE_TOLERANCE_LOG2` (~0.1 %, far above the quantisation of every format at
/// 1-20 kHz, far below a change of a design parameter).
pub const RATE_TOLERANCE_LOG2: u32 = 10;
/// [`RATE_TOLERANCE_LOG2`] as a fraction.
pub const RATE_TOLERANCE: f64 = 1.0 / (1u32 << RATE_TOLERANCE_LOG2) as f64;

/// Why the latest [`crate::Config`] or [`crate::Command`] was refused: the field to blame
/// ([`crate::Status`] `refuse_reason`; 0 = none since the counters were reset).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum RefuseReason {
    /// Nothing refused.
    None = 0,
    /// An unknown request: a Command variant or a Config `mode` this version does not
    /// define.
    UnknownRequest = 1,
    /// `rates.numeric` is not the device's sample type.
    Numeric = 2,
    /// `rates.fingerprint` is not the device's core.
    Fingerprint = 3,
    /// `rates.base_rate_hz` outside its range.
    BaseRate = 4,
    /// The base period is not a whole number of ticker ticks (us).
    Period = 5,
    /// `rates.yaw_div`: zero, or the yaw loop slower than [`LOOP_RATE_MIN_HZ`].
    YawDiv = 6,
    /// `rates.traction_div`: zero, or the traction loop slower than [`LOOP_RATE_MIN_HZ`].
    TractionDiv = 7,
    /// `hold_ticks`: longer than [`HOLD_MAX_US`] at the base rate.
    HoldTicks = 8,
    /// `rates.kappa`.
    Kappa = 9,
    /// `rates.ki`.
    Ki = 10,
    /// `rates.predict_half`.
    PredictHalf = 11,
    /// `rates.iref_step`.
    IrefStep = 12,
    /// `rates.iref_safe_step`.
    IrefSafeStep = 13,
    /// `rates.torque_step`.
    TorqueStep = 14,
    /// `rates.acc_gain_q32`.
    AccGain = 15,
    /// `rates.acc_leak_q32`.
    AccLeak = 16,
    /// A value's bit pattern is not valid for the sample type (the control core's format
    /// check, after every range above passed).
    Bits = 17,
    /// A request this build of the device does not honour: a test-only fault injection
    /// ([`crate::Command::InjectStall`], [`crate::Command::InjectHardFault`]) on a build
    /// without it. (Every build takes every Config switch: `wsp`, `monitor_safe`.)
    Unsupported = 18,
}

impl RefuseReason {
    /// Every reason, in code order.
    pub const ALL: [Self; 19] = [
        Self::None,
        Self::UnknownRequest,
        Self::Numeric,
        Self::Fingerprint,
        Self::BaseRate,
        Self::Period,
        Self::YawDiv,
        Self::TractionDiv,
        Self::HoldTicks,
        Self::Kappa,
        Self::Ki,
        Self::PredictHalf,
        Self::IrefStep,
        Self::IrefSafeStep,
        Self::TorqueStep,
        Self::AccGain,
        Self::AccLeak,
        Self::Bits,
        Self::Unsupported,
    ];

    /// The wire code.
    #[must_use]
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The reason of a wire code (`None` for a code this version does not define).
    #[must_use]
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.get(usize::from(code)).copied()
    }

    /// The field to blame, as the message spells it.
    #[must_use]
    pub const fn field(self) -> &'static str {
        match self {
            Self::None => "-",
            Self::UnknownRequest => "request",
            Self::Numeric => "rates.numeric",
            Self::Fingerprint => "rates.fingerprint",
            Self::BaseRate => "rates.base_rate_hz",
            Self::Period => "rates.base_rate_hz (period)",
            Self::YawDiv => "rates.yaw_div",
            Self::TractionDiv => "rates.traction_div",
            Self::HoldTicks => "hold_ticks",
            Self::Kappa => "rates.kappa",
            Self::Ki => "rates.ki",
            Self::PredictHalf => "rates.predict_half",
            Self::IrefStep => "rates.iref_step",
            Self::IrefSafeStep => "rates.iref_safe_step",
            Self::TorqueStep => "rates.torque_step",
            Self::AccGain => "rates.acc_gain_q32",
            Self::AccLeak => "rates.acc_leak_q32",
            Self::Bits => "rates (bit pattern)",
            Self::Unsupported => "request (not honoured by this build)",
        }
    }
}

impl core::fmt::Display for RefuseReason {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let why = PLAUSIBLE
            .iter()
            .find(|p| p.reason == *self)
            .map_or("", |p| p.why);
        write!(f, "refused: {} ({})", self.field(), why)
    }
}

/// One row of the plausibility table: a field's range and the reason for it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plausible {
    /// The field (its refusal code).
    pub reason: RefuseReason,
    /// Smallest plausible value, in `unit` (NaN: no lower bound beyond the format).
    pub min: f64,
    /// Largest plausible value, in `unit` (NaN: no upper bound beyond the format).
    pub max: f64,
    /// The unit of `min` and `max`.
    pub unit: &'static str,
    /// Why.
    pub why: &'static str,
}

const RATED: &str = "x the device's own value at the requested rates";
const RATED_WHY: &str = "rate-dependent: only the rates may change it (within 2^-10, + 1 LSB \
                         fixed point)";
const LO: f64 = 1.0 - RATE_TOLERANCE;
const HI: f64 = 1.0 + RATE_TOLERANCE;

/// The plausibility table (see the module docs), one row per [`RefuseReason`] but
/// `None`.
pub const PLAUSIBLE: [Plausible; 18] = [
    Plausible {
        reason: RefuseReason::UnknownRequest,
        min: f64::NAN,
        max: f64::NAN,
        unit: "-",
        why: "a Command variant or Config mode this protocol version does not define",
    },
    Plausible {
        reason: RefuseReason::Numeric,
        min: f64::NAN,
        max: f64::NAN,
        unit: "code",
        why: "must be the device's sample type (0 fixed point, 1 f32)",
    },
    Plausible {
        reason: RefuseReason::Fingerprint,
        min: f64::NAN,
        max: f64::NAN,
        unit: "hash",
        why: "must be the device's core (gains, limits, scales)",
    },
    Plausible {
        reason: RefuseReason::BaseRate,
        min: BASE_RATE_MIN_HZ as f64,
        max: BASE_RATE_MAX_HZ as f64,
        unit: "Hz",
        why: "the slowest loop rate (divisor 1); 20 kHz leaves the tick a sixth of the period",
    },
    Plausible {
        reason: RefuseReason::Period,
        min: f64::NAN,
        max: f64::NAN,
        unit: "us",
        why: "the period must be a whole number of the board ticker's 1 us ticks",
    },
    Plausible {
        reason: RefuseReason::YawDiv,
        min: LOOP_RATE_MIN_HZ as f64,
        max: f64::NAN,
        unit: "Hz (base_rate_hz / yaw_div)",
        why: "the slowest yaw rate the rate analysis evaluates",
    },
    Plausible {
        reason: RefuseReason::TractionDiv,
        min: LOOP_RATE_MIN_HZ as f64,
        max: f64::NAN,
        unit: "Hz (base_rate_hz / traction_div)",
        why: "at least 5 samples per 10 ms armature time constant",
    },
    Plausible {
        reason: RefuseReason::HoldTicks,
        min: 0.0,
        max: HOLD_MAX_US as f64,
        unit: "us (hold_ticks / base_rate_hz)",
        why: "a fifth of the ~10 Hz kinematic period: an older y' is off by > 70 degrees",
    },
    Plausible {
        reason: RefuseReason::Kappa,
        min: LO,
        max: HI,
        unit: RATED,
        why: RATED_WHY,
    },
    Plausible {
        reason: RefuseReason::Ki,
        min: LO,
        max: HI,
        unit: RATED,
        why: RATED_WHY,
    },
    Plausible {
        reason: RefuseReason::PredictHalf,
        min: 0.0,
        max: PREDICT_HALF_MAX_QUARTERS as f64 / 4.0,
        unit: "coefficient",
        why: "alpha/2 of the matched delay compensation (1 + yaw_div/2 ticks) is <= 0.75",
    },
    Plausible {
        reason: RefuseReason::IrefStep,
        min: LO,
        max: HI,
        unit: RATED,
        why: RATED_WHY,
    },
    Plausible {
        reason: RefuseReason::IrefSafeStep,
        min: LO,
        max: HI,
        unit: RATED,
        why: RATED_WHY,
    },
    Plausible {
        reason: RefuseReason::TorqueStep,
        min: LO,
        max: HI,
        unit: RATED,
        why: RATED_WHY,
    },
    Plausible {
        reason: RefuseReason::AccGain,
        min: LO,
        max: HI,
        unit: RATED,
        why: RATED_WHY,
    },
    Plausible {
        reason: RefuseReason::AccLeak,
        min: LO,
        max: HI,
        unit: RATED,
        why: RATED_WHY,
    },
    Plausible {
        reason: RefuseReason::Bits,
        min: f64::NAN,
        max: f64::NAN,
        unit: "-",
        why: "every value must be a valid bit pattern of the device's sample type",
    },
    Plausible {
        reason: RefuseReason::Unsupported,
        min: f64::NAN,
        max: f64::NAN,
        unit: "-",
        why: "a test-only fault injection on a build that does not honour it",
    },
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip_and_every_reason_has_a_row() {
        for (k, r) in RefuseReason::ALL.iter().enumerate() {
            assert_eq!(usize::from(r.code()), k);
            assert_eq!(RefuseReason::from_code(r.code()), Some(*r));
            if *r != RefuseReason::None {
                assert_eq!(
                    PLAUSIBLE.iter().filter(|p| p.reason == *r).count(),
                    1,
                    "{r:?}"
                );
            }
        }
        assert_eq!(RefuseReason::from_code(RefuseReason::ALL.len() as u8), None);
    }
}
