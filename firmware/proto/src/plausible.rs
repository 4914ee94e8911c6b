//! What a Config may ask of the device: every field's plausible range and why, as data
//! ([`PLAUSIBLE`]), and the [`RefuseReason`] codes; rates only as the device's own designs.

/// The board's ticker resolution, Hz: a base period must be a whole number of its ticks.
pub const TICKER_HZ: u32 = 1_000_000;

/// Lowest plausible base rate, Hz: [`LOOP_RATE_MIN_HZ`] (both loops at divisor 1).
pub const BASE_RATE_MIN_HZ: u32 = LOOP_RATE_MIN_HZ;
/// Highest plausible base rate, Hz.
pub const BASE_RATE_MAX_HZ: u32 = 20_000;
/// Lowest plausible yaw and traction loop rate (`base_rate_hz / divisor`), Hz.
pub const LOOP_RATE_MIN_HZ: u32 = 500;
/// Longest plausible hold on a stale sample, `hold_ticks / base_rate_hz`, us (a fifth of the ~10 Hz kinematic period).
pub const HOLD_MAX_US: u32 = 20_000;
/// Largest plausible `predict_half` (`alpha/2`) as `num/2^2`: 3/4 (at most 1.5 ticks).
pub const PREDICT_HALF_MAX_QUARTERS: u32 = 3;

/// Why the latest Config or Command was refused: the field to blame (0 = none).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum RefuseReason {
    /// Nothing refused.
    None = 0,
    /// An unknown request: a Command variant or Config `mode` this version does not define.
    UnknownRequest = 1,
    /// `rates.numeric` is not the device's sample type.
    Numeric = 2,
    /// `rates.fingerprint` is not the device's core.
    Fingerprint = 3,
    /// `rates.base_rate_hz`: no design for it, or above the board's link.
    BaseRate = 4,
    /// The base period is not a whole number of ticker ticks (us).
    Period = 5,
    /// `rates.yaw_div`: not 1 (the designs run the yaw loop every tick).
    YawDiv = 6,
    /// `rates.traction_div`: not 1 (the designs run the traction loop every tick).
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
    /// A bit pattern not valid for the sample type (the core's format check, after the ranges).
    Bits = 17,
    /// A request this build does not honour: a test-only fault injection on a build without it.
    Unsupported = 18,
    /// `rates.delay_ticks`: the rate has no design for this delay.
    Delay = 19,
    /// `rates.kp`: not the traction loop's design for the rate and delay.
    Kp = 20,
    /// `rates.lead_k_hf`: not the yaw loop's design for the rate and delay.
    LeadKhf = 21,
    /// `rates.wsp_lead_k_hf`: not the wheel-slip protection's lead for the design.
    WspLead = 22,
    /// `mode`: an active yaw law at rates where only the traction loop is designed.
    YawNotDesigned = 23,
}

impl RefuseReason {
    /// Every reason, in code order: `None`, then the [`PLAUSIBLE`] table's (in code order).
    pub const ALL: [Self; 24] = {
        let mut all = [Self::None; 24];
        let mut k = 1;
        while k < all.len() {
            all[k] = PLAUSIBLE[k - 1].reason;
            k += 1;
        }
        all
    };

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
            Self::Delay => "rates.delay_ticks",
            Self::Kp => "rates.kp",
            Self::LeadKhf => "rates.lead_k_hf",
            Self::WspLead => "rates.wsp_lead_k_hf",
            Self::YawNotDesigned => "mode (no yaw design at these rates)",
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

const TRACTION: &str = "the traction loop's design for the rate and delay, bit for bit: \
                        another leaves the current loop unstable or not shown stable";
const YAW: &str = "the yaw loop's design for the rate and delay, bit for bit: another \
                   leaves the yaw loop unstable or not shown stable";
const AT_RATE: &str = "the runtime's value at the designed rate, bit for bit";
const DESIGN: &str = "the design's";
use RefuseReason as R;

/// The plausibility table (module docs), one row per [`RefuseReason`] but `None`, in code order.
pub const PLAUSIBLE: [Plausible; 23] = [
    row(
        R::UnknownRequest,
        "-",
        "a Command variant or Config mode this protocol version does not define",
    ),
    row(
        R::Numeric,
        "code",
        "must be the device's sample type (0 fixed point, 1 f32)",
    ),
    row(
        R::Fingerprint,
        "hash",
        "must be the device's core (gains, limits, scales)",
    ),
    Plausible {
        reason: R::BaseRate,
        min: BASE_RATE_MIN_HZ as f64,
        max: BASE_RATE_MAX_HZ as f64,
        unit: "Hz",
        why: "a rate of the device's design table (`sim-host rates` lists each refused one with the criterion it fails), within the board's link",
    },
    row(
        R::Period,
        "us",
        "the period must be a whole number of the board ticker's 1 us ticks",
    ),
    Plausible {
        reason: R::YawDiv,
        min: 1.0,
        max: 1.0,
        unit: "-",
        why: "the designs run the yaw loop every tick",
    },
    Plausible {
        reason: R::TractionDiv,
        min: 1.0,
        max: 1.0,
        unit: "-",
        why: "the designs run the traction loop every tick",
    },
    Plausible {
        reason: R::HoldTicks,
        min: 0.0,
        max: HOLD_MAX_US as f64,
        unit: "us (hold_ticks / base_rate_hz)",
        why: "a fifth of the ~10 Hz kinematic period: an older y' is off by > 70 degrees",
    },
    row(R::Kappa, DESIGN, YAW),
    row(R::Ki, DESIGN, TRACTION),
    Plausible {
        reason: R::PredictHalf,
        min: 0.0,
        max: PREDICT_HALF_MAX_QUARTERS as f64 / 4.0,
        unit: "coefficient",
        why: YAW,
    },
    row(R::IrefStep, DESIGN, TRACTION),
    row(R::IrefSafeStep, DESIGN, TRACTION),
    row(R::TorqueStep, DESIGN, YAW),
    row(R::AccGain, DESIGN, AT_RATE),
    row(R::AccLeak, DESIGN, AT_RATE),
    row(
        R::Bits,
        "-",
        "every value must be a valid bit pattern of the device's sample type",
    ),
    row(
        R::Unsupported,
        "-",
        "a test-only fault injection on a build that does not honour it",
    ),
    Plausible {
        reason: R::Delay,
        min: 1.0,
        max: f64::NAN,
        unit: "ticks",
        why: "a delay the rate has a design for",
    },
    row(R::Kp, DESIGN, TRACTION),
    row(R::LeadKhf, DESIGN, YAW),
    row(R::WspLead, DESIGN, YAW),
    row(
        R::YawNotDesigned,
        "-",
        "no lead or gain holds the yaw loop at these rates and delay: the passive law only",
    ),
];

/// A row without bounds beyond the format (`min` and `max` NaN).
const fn row(reason: RefuseReason, unit: &'static str, why: &'static str) -> Plausible {
    let (min, max) = (f64::NAN, f64::NAN);
    Plausible {
        reason,
        min,
        max,
        unit,
        why,
    }
}

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
