//! The gains designed per (base rate, delay) point a device accepts ([`DESIGNED`]; a
//! point whose yaw loop fails takes the passive law only). Both loops every tick.
//!
//! ```text
//! tau = (d + 1/2) T,   T = 1/base_rate_hz;   tau_0 = 1.5/(5 kHz) = 300 us (the paper's point)
//! Kp  = Kp_0 min(1, tau_0/tau)      (crossover phase w_c tau kept: the paper's margins; Ti kept)
//! alpha = min(d + 1/2, 3/2) ticks   (the predictor over the delay, at most the wire's 3/2)
//! K   = lead_gain K_0               (the largest of LEAD_GAIN_STEPS within 1 dB / 5 deg of the paper's margins)
//! ```

use crate::config::{Config, ConfigError};

/// One accepted base rate and delay, with the lead's gain factor found for it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DesignPoint {
    /// Base rate, Hz (both loops every tick).
    pub base_rate_hz: u32,
    /// Ticks from sampling to actuation (1: the reply is back before the next tick).
    pub delay_ticks: u8,
    /// Factor on the lead's `K` (1: the paper's lead).
    pub lead_gain: f64,
    /// The yaw loop holds: lead and gain laws designed. `false`: passive only (`lead_gain` 1).
    pub yaw: bool,
}

/// The lead gain factors the design tries, largest (the paper's lead) first.
pub const LEAD_GAIN_STEPS: [f64; 6] = [1.0, 0.95, 0.9, 0.85, 0.8, 0.75];

/// The accepted rates and delays, held to the host's analysis by `wheelset_plant::sampled::design`'s test.
pub const DESIGNED: [DesignPoint; 18] = [
    at(500, 1, 1.0, false),
    at(500, 2, 1.0, false),
    at(500, 3, 1.0, false),
    at(1_000, 1, 0.95, true),
    at(1_000, 2, 1.0, false),
    at(1_000, 3, 1.0, false),
    at(2_000, 1, 1.0, true),
    at(2_000, 2, 0.9, true),
    at(2_000, 3, 1.0, false),
    at(2_500, 1, 1.0, true),
    at(2_500, 2, 0.9, true),
    at(2_500, 3, 1.0, false),
    at(5_000, 1, 1.0, true),
    at(5_000, 2, 0.95, true),
    at(5_000, 3, 0.9, true),
    at(10_000, 1, 1.0, true),
    at(10_000, 2, 1.0, true),
    at(10_000, 3, 0.95, true),
];

/// A row of [`DESIGNED`].
const fn at(base_rate_hz: u32, delay_ticks: u8, lead_gain: f64, yaw: bool) -> DesignPoint {
    DesignPoint {
        base_rate_hz,
        delay_ticks,
        lead_gain,
        yaw,
    }
}

/// The paper's effective delay `tau_0`, s: 1.5 ticks at 5 kHz.
pub const TAU_0_S: f64 = 1.5 / 5_000.0;

/// The effective delay `tau = (d + 1/2)/base_rate_hz`, s.
pub fn effective_delay_s(base_rate_hz: u32, delay_ticks: u8) -> f64 {
    (f64::from(delay_ticks) + 0.5) / f64::from(base_rate_hz)
}

/// The design point of a rate and delay, if designed.
pub fn point(base_rate_hz: u32, delay_ticks: u8) -> Option<DesignPoint> {
    DESIGNED
        .iter()
        .find(|p| p.base_rate_hz == base_rate_hz && p.delay_ticks == delay_ticks)
        .copied()
}

impl Config {
    /// This configuration redesigned for the rate, delay and `lead_gain` ([`Config::designed`]):
    /// `Kp`, `alpha` and `K` as the module docs give them.
    pub fn with_design(&self, base_rate_hz: u32, delay_ticks: u8, lead_gain: f64) -> Self {
        let tau = effective_delay_s(base_rate_hz, delay_ticks);
        let mut c = *self;
        c.base_rate_hz = base_rate_hz;
        c.yaw_divisor = 1;
        c.traction_divisor = 1;
        c.delay_ticks = delay_ticks;
        c.yaw_predict_ticks = (f64::from(delay_ticks) + 0.5).min(1.5);
        c.pi.kp = self.pi.kp * (TAU_0_S / tau).min(1.0);
        c.lead.k = self.lead.k * lead_gain;
        c
    }

    /// [`Config::with_design`] at an accepted point of [`DESIGNED`]; else `Range` on `base_rate_hz`.
    pub fn designed(&self, base_rate_hz: u32, delay_ticks: u8) -> Result<Self, ConfigError> {
        let p = point(base_rate_hz, delay_ticks).ok_or(ConfigError::Range {
            field: "base_rate_hz",
            value: f64::from(base_rate_hz),
            reason:
                "no design for this rate and delay (accepted: wheelset_control::design::DESIGNED)",
        })?;
        Ok(self.with_design(base_rate_hz, delay_ticks, p.lead_gain))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_paper_point_is_the_paper() {
        let c = Config::default();
        assert_eq!(c.designed(5_000, 1).expect("designed"), c);
    }

    #[test]
    fn kp_keeps_the_crossover_delay_product() {
        let base = Config::default();
        for p in DESIGNED {
            let c = base
                .designed(p.base_rate_hz, p.delay_ticks)
                .expect("designed");
            let tau = effective_delay_s(p.base_rate_hz, p.delay_ticks);
            // w_c tau = (Kp/L_a) tau never above the paper's.
            assert!(
                c.pi.kp * tau <= base.pi.kp * TAU_0_S * (1.0 + 1e-12),
                "{p:?}"
            );
            assert_eq!(c.pi.ti, base.pi.ti);
            assert_eq!(c.lead.k, base.lead.k * p.lead_gain);
            assert!(c.validate().is_ok(), "{p:?}");
        }
        let c = base.designed(1_000, 1).expect("designed");
        assert!((c.pi.kp - 0.2 * base.pi.kp).abs() < 1e-12, "{}", c.pi.kp);
        assert_eq!(c.yaw_predict_ticks, 1.5);
        assert_eq!(base.with_design(5_000, 2, 1.0).yaw_predict_ticks, 1.5);
        assert_eq!(base.with_design(5_000, 0, 1.0).yaw_predict_ticks, 0.5);
    }

    #[test]
    fn undesigned_points_are_errors() {
        assert!(point(500, 1).is_some_and(|p| !p.yaw), "passive yaw only");
        assert!(point(5_000, 1).is_some_and(|p| p.yaw));
        assert!(Config::default().designed(5_000, 9).is_err());
        assert!(Config::default().designed(4_000, 1).is_err());
    }
}
