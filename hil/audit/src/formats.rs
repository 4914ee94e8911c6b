//! The word-length bisection over the signal format (the recommended formats per signal
//! come from the proofs, [`super::bounds::prove`]).

use wheelset_control::Config;

use super::checks::all_checks;
use super::core_dyn;
use super::model::{ControllerAudit, Sweep};
use super::per_controller::NAMED_HZ;
use super::qdyn::{Formats, QFormat};
use super::ranges;
use super::tolerances::{Status, Tolerances};

/// Bisection over the signal fraction bits (integer bits as audited) for the smallest
/// format passing every accuracy check on the synthetic scenarios and the named
/// frequencies.
pub(crate) fn sweep(
    cfg: &Config,
    tol: &Tolerances,
    fmt: &Formats,
    controllers: &[ControllerAudit],
) -> Sweep {
    let scen = ranges::synthetic(cfg);
    let named = |fs: f64| -> Vec<(f64, bool)> {
        NAMED_HZ
            .iter()
            .filter(|f| **f < tol.frac_fs * fs)
            .map(|f| (*f, true))
            .collect()
    };
    let max_f = 32 - fmt.signal.int_bits;
    let mut tried = Vec::new();
    let mut eval = |f: u32| -> bool {
        let mut fm = *fmt;
        fm.signal = QFormat::new(fmt.signal.int_bits, f);
        let why = match core_dyn(cfg, tol, fm, &scen, &named) {
            Ok(c) => all_checks(&c, tol, cfg)
                .into_iter()
                .find(|c| c.status == Status::Fail)
                .map(|c| format!("{}: {}", c.controller, c.reason)),
            Err(e) => Some(e.to_string()),
        };
        tried.push((f, why.is_none(), why.clone().unwrap_or_default()));
        why.is_none()
    };
    let (mut lo, mut hi) = (4u32, max_f);
    let min = if !eval(hi) {
        None
    } else {
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if eval(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Some(hi)
    };
    tried.sort_by_key(|t| t.0);
    // Coefficients: a relative error <= warn needs 2^-(F+1) <= warn |c_pu|.
    let min_coef = controllers
        .iter()
        .flat_map(|c| &c.coefficients)
        .filter(|c| c.ideal_pu != 0.0)
        .map(|c| {
            (-(tol.coef_rel.0 * c.ideal_pu.abs()).log2() - 1.0)
                .ceil()
                .max(0.0) as u32
        })
        .max()
        .unwrap_or(0);
    Sweep {
        min_signal_frac_bits: min,
        tried,
        min_coef_frac_bits: min_coef,
    }
}
