//! The audit's stability verdict (Nyquist: `Z = P - W`) against the sampled-data
//! eigenvalue analysis of `sim-host rates` (`wheelset_plant::sampled::closed_loop`), over
//! lead gains on both sides of the stability limits and over rates and delays; and
//! margins that are positive whenever the loop is stable.

use super::margins;
use crate::bounds::Quantised;
use wheelset_control::Config;
use wheelset_loop::device_loop::control_config;
use wheelset_plant::control::YawLaw;
use wheelset_plant::params::Params;
use wheelset_plant::sampled::{closed_loop, Model};

fn audit_and_eigen(p: &Params) -> (Vec<super::Margin>, bool) {
    audit_and_eigen_at(p, control_config(p, YawLaw::Lead, true))
}

fn audit_and_eigen_at(p: &Params, cfg: Config) -> (Vec<super::Margin>, bool) {
    let q = Quantised::of::<wheelset_control::Fx>(&cfg).expect("quantised");
    let m = margins(&cfg, &q, p).expect("margins");
    let plant = Model::Full.plant(p, p.f11, p.lambda, false);
    let d = usize::from(cfg.delay_ticks.max(1));
    let eig = closed_loop(&plant, &cfg, d).expect("closed loop").stable();
    (m, eig)
}

#[test]
fn the_nyquist_verdict_agrees_with_the_eigenvalues_over_the_lead_gain() {
    let mut seen = (false, false);
    // Up to the largest gain whose coefficient the Q1.31 format holds.
    for gain in [1.0, 2.0, 3.0, 3.5, 5.0, 7.5, 9.0] {
        let p = Params {
            lead_gain: gain,
            ..Params::default()
        };
        let (m, eig) = audit_and_eigen(&p);
        let both = m.iter().all(|x| x.stable);
        assert_eq!(
            both, eig,
            "lead_gain {gain}: audit {m:#?}, eigenvalues stable {eig}"
        );
        for x in &m {
            // The count is consistent, and a stable loop's margins are positive.
            assert_eq!(
                x.closed_loop_unstable_poles,
                x.open_loop_unstable_poles as i64 - x.encirclements
            );
            assert_eq!(x.stable, x.closed_loop_unstable_poles == 0);
            if x.stable {
                for v in [x.gain_db_quantised, x.phase_deg_quantised]
                    .into_iter()
                    .flatten()
                {
                    assert!(v > 0.0, "lead_gain {gain}: {x:#?}");
                }
                // The gain interval holds the present gain: below it, above it.
                assert!(x.gain_reduction_db.is_none_or(|g| g < 0.0), "{x:#?}");
                assert!(x.gain_increase_db.is_none_or(|g| g > 0.0), "{x:#?}");
            } else {
                assert!(x.gain_db_quantised.is_none() && x.phase_deg_quantised.is_none());
            }
        }
        let yaw = &m[0];
        assert!(
            yaw.open_loop_unstable_poles >= 1,
            "the yaw plant without the spring"
        );
        if eig {
            seen.0 = true;
        } else {
            seen.1 = true;
        }
    }
    assert!(
        seen.0 && seen.1,
        "the gains should span stable and unstable loops"
    );
}

#[test]
fn the_gain_interval_edges_are_where_the_eigenvalues_change() {
    let p = Params {
        lead_gain: 5.0,
        ..Params::default()
    };
    let (m, eig) = audit_and_eigen(&p);
    assert!(eig && m[0].stable, "{m:#?}");
    // The open-loop-unstable yaw plant needs a minimum gain: scaling the lead's gain
    // just inside the reported reduction keeps it stable, just beyond it does not.
    let down = m[0].gain_reduction_db.expect("a lower limit");
    for (factor, stable) in [(0.97, true), (1.03, false)] {
        let k = 10f64.powf(down / 20.0 * factor);
        let q = Params {
            lead_gain: 5.0 * k,
            ..Params::default()
        };
        let (_, eig) = audit_and_eigen(&q);
        assert_eq!(eig, stable, "gain x{k:.4} ({down:.2} dB x {factor})");
    }
}

#[test]
fn the_nyquist_verdict_agrees_with_the_eigenvalues_over_rates_and_delays() {
    let p = Params::default();
    let base = control_config(&p, YawLaw::Lead, true);
    let mut seen = (false, false);
    for (rate, delay) in [(1000, 1), (2000, 2), (5000, 3), (10_000, 1)] {
        for gain in [0.25, 0.5, 1.0] {
            // Gains up to the largest whose `k_hf` the Q1.31 format holds.
            let (m, eig) = audit_and_eigen_at(&p, base.with_design(rate, delay, gain));
            let both = m.iter().all(|x| x.stable);
            assert_eq!(both, eig, "{rate} Hz, {delay} ticks, lead x{gain}: {m:#?}");
            if eig {
                seen.0 = true;
            } else {
                seen.1 = true;
            }
        }
    }
    assert!(
        seen.0 && seen.1,
        "the points should span stable and unstable loops"
    );
}
