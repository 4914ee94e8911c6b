//! The accumulator of one signal's error (fixed minus f64): its largest magnitude and
//! mean square, and the noise record made of them.

#[allow(clippy::wildcard_imports)]
use super::*;

#[derive(Default)]
pub(super) struct Acc {
    pub(super) max: f64,
    pub(super) sq: f64,
    pub(super) n: u64,
}

impl Acc {
    pub(super) fn add(&mut self, e: f64) {
        self.max = self.max.max(e.abs());
        self.sq += e * e;
        self.n += 1;
    }
    #[allow(clippy::too_many_arguments)]
    pub(super) fn noise(
        &self,
        out: &str,
        sc: &str,
        mode: &str,
        phase: Phase,
        lsb: f64,
        fs: f64,
        wire: f64,
        limit: f64,
        unit: &str,
    ) -> Noise {
        let rms = (self.sq / self.n.max(1) as f64).sqrt();
        Noise {
            output: out.to_string(),
            scenario: sc.to_string(),
            yaw_mode: mode.to_string(),
            phase,
            max_of_limit: self.max * fs / limit,
            max_lsb: self.max / lsb,
            rms_lsb: rms / lsb,
            max_si: self.max * fs,
            rms_si: rms * fs,
            max_wire_lsb: self.max * fs / wire,
            bits_lost: (self.max / lsb).max(1.0).log2(),
            unit: unit.to_string(),
            samples: self.n,
        }
    }
}
