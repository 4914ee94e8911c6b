//! The monitor as exact bits, and the `const` constructor of the firmware's boot monitor.

use super::{divisor_for, Monitor, MonitorBits};
use crate::compiled::{f32_value, fx_coeff, fx_signal};
use crate::sample::{Fx, SampleBits};

impl<T: SampleBits> Monitor<T> {
    /// The exact bits.
    pub fn to_bits(&self) -> MonitorBits {
        let c = |v: T::Coeff| T::coeff_to_bits64(v);
        MonitorBits {
            rate_hz: self.rate_hz,
            k_lo: c(self.k_lo),
            k_hi: c(self.k_hi),
            k_ms: c(self.k_ms),
            levels: [
                self.on.to_bits64(),
                self.off.to_bits64(),
                self.floor.to_bits64(),
            ],
            shrink: c(self.shrink),
            block: self.block,
            blocks: self.blocks,
            drift: self.drift.to_bits64(),
            traction_change: self.traction_change.to_bits64(),
            drive_k: c(self.drive_k),
            drive_levels: [self.drive_on.to_bits64(), self.drive_off.to_bits64()],
            drive_persist: self.drive_persist,
        }
    }

    /// From exact bits for `base_rate_hz`, validated (integer work); rate 0 never runs.
    pub fn from_bits(b: &MonitorBits, base_rate_hz: u32) -> Result<Self, crate::BitsError> {
        let err = |field| crate::BitsError { field };
        let coef = |field, v: u64| {
            T::coeff_from_bits64(v)
                .filter(|c| T::coeff_in_unit(*c, false))
                .ok_or(err(field))
        };
        let sig = |field, v: u64| T::from_bits64(v).ok_or(err(field));
        let [on, off, floor] = b.levels;
        let (on, off, floor) = (
            sig("monitor.levels", on)?,
            sig("monitor.levels", off)?,
            sig("monitor.levels", floor)?,
        );
        if !(T::ZERO < off && off < on && T::ZERO < floor) {
            return Err(err("monitor.levels"));
        }
        if b.block == 0 || b.blocks == 0 {
            return Err(err("monitor.block"));
        }
        let positive = |field, v: u64| T::from_bits64(v).filter(|x| *x > T::ZERO).ok_or(err(field));
        let drift = positive("monitor.drift", b.drift)?;
        let traction_change = positive("monitor.traction_change", b.traction_change)?;
        let [d_on, d_off] = b.drive_levels;
        let (drive_on, drive_off) = (
            sig("monitor.drive_levels", d_on)?,
            sig("monitor.drive_levels", d_off)?,
        );
        if !(T::ZERO < drive_off && drive_off < drive_on) {
            return Err(err("monitor.drive_levels"));
        }
        if b.drive_persist == 0 {
            return Err(err("monitor.drive_persist"));
        }
        Ok(Self {
            rate_hz: b.rate_hz,
            div: divisor_for(b.rate_hz, base_rate_hz),
            k_lo: coef("monitor.k_lo", b.k_lo)?,
            k_hi: coef("monitor.k_hi", b.k_hi)?,
            k_ms: coef("monitor.k_ms", b.k_ms)?,
            on,
            off,
            floor,
            shrink: coef("monitor.shrink", b.shrink)?,
            block: b.block,
            blocks: b.blocks,
            drift,
            traction_change,
            drive_k: coef("monitor.drive_k", b.drive_k)?,
            drive_on,
            drive_off,
            drive_persist: b.drive_persist,
        })
    }
}

macro_rules! from_valid_bits {
    ($t:ty, $signal:expr, $coeff:expr) => {
        impl Monitor<$t> {
            /// [`Monitor::from_bits`] without validation, `const`, for bits known valid.
            pub const fn from_valid_bits(b: &MonitorBits, base_rate_hz: u32) -> Self {
                let (s, c) = ($signal, $coeff);
                Self {
                    rate_hz: b.rate_hz,
                    div: divisor_for(b.rate_hz, base_rate_hz),
                    k_lo: c(b.k_lo),
                    k_hi: c(b.k_hi),
                    k_ms: c(b.k_ms),
                    on: s(b.levels[0]),
                    off: s(b.levels[1]),
                    floor: s(b.levels[2]),
                    shrink: c(b.shrink),
                    block: b.block,
                    blocks: b.blocks,
                    drift: s(b.drift),
                    traction_change: s(b.traction_change),
                    drive_k: c(b.drive_k),
                    drive_on: s(b.drive_levels[0]),
                    drive_off: s(b.drive_levels[1]),
                    drive_persist: b.drive_persist,
                }
            }
        }
    };
}

from_valid_bits!(Fx, fx_signal, fx_coeff);
from_valid_bits!(f32, f32_value, f32_value);
