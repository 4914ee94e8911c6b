//! The hostile-Config table (`wheelset_hostile`) on the host runtime, for both
//! sample types: one runtime through every row, each row from the nominal state
//! (restored, and the restore proven), refused with its reason and nothing else changed,
//! or applied. `hil/harness/tests/qemu_hostile.rs` runs the same table on the firmware.

use wheelset_control::{Fx, SampleBits};
use wheelset_hostile::{self as hostile, Expect, Row};
use wheelset_proto::{Actuation, Config, Flags, RefuseReason, YawMode};
use wheelset_runtime::{Runtime, RuntimeConfig, DEFAULT_HOLD_TICKS};

/// The runtime runs `c` (after an applied row): its switches (the outputs' on the trace's
/// last Actuation), hold and, with rates, the schedule bit for bit.
fn runs<T: SampleBits>(rt: &Runtime<T>, last: &Actuation, c: &Config, what: &str) {
    assert_eq!(rt.hold_ticks(), c.hold_ticks, "{what}");
    assert_eq!(last.flags.has(Flags::ENABLED), c.enable, "{what}");
    assert_eq!(rt.core().mode(), c.mode, "{what}");
    assert_eq!(rt.core().wsp_enabled(), c.wsp, "{what}");
    if let Some(r) = &c.rates {
        let s = rt.core().compiled().schedule();
        assert_eq!(
            (s.base_rate_hz, s.yaw_divisor, s.traction_divisor),
            (r.base_rate_hz, r.yaw_div, r.traction_div),
            "{what}"
        );
        assert_eq!(
            [
                s.kappa,
                s.ki,
                s.predict_half,
                s.iref_step,
                s.iref_safe_step,
                s.torque_step
            ],
            [
                r.kappa,
                r.ki,
                r.predict_half,
                r.iref_step,
                r.iref_safe_step,
                r.torque_step
            ]
            .map(u64::from),
            "{what}"
        );
    }
}

fn every_row<T: SampleBits>() -> Vec<Row> {
    let name = if T::NUMERIC == 0 {
        "fixed point"
    } else {
        "f32"
    };
    let nominal = hostile::nominal::<T>().expect("the host computes the nominal rates");
    let mut rt = Runtime::<T>::try_new(RuntimeConfig::default()).expect("the default");
    let base = hostile::probe(&mut rt, &nominal, hostile::null_frame().as_bytes())
        .expect("the runtime answers every frame");
    // The nominal run drives (the probe has something to show): outputs enabled, the
    // lead's torque moving with y', the safe state in the gap and left after it.
    assert!(base.before.iter().all(|a| a.flags.has(Flags::ENABLED)));
    assert!(base
        .before
        .iter()
        .any(|a| a.t_psi_dnm != base.before[0].t_psi_dnm));
    assert!(base.after.iter().any(|a| a.flags.has(Flags::SAFE)));
    assert!(!base.after[hostile::AFTER_TICKS - 1].flags.has(Flags::SAFE));
    assert_eq!((base.s1.cmd_refused, base.s1.safe_entries), (0, 1));
    let mut rows = Vec::new();
    hostile::rows::<T>(|r| rows.push(r)).expect("the table");
    let fresh = Runtime::<T>::try_new(RuntimeConfig::default()).expect("the default");
    for row in &rows {
        let what = format!("{name}: {row}");
        let trace = hostile::probe(&mut rt, &nominal, row.frame().as_bytes())
            .expect("the runtime answers every frame");
        if let Err(f) = hostile::judge(row.expect, &trace, &base) {
            panic!("{what}: {f}");
        }
        match row.expect {
            Expect::Refused(_) => {
                // The nominal configuration stayed.
                runs(&rt, &trace.after[hostile::AFTER_TICKS - 1], &nominal, &what);
                assert_eq!(rt.core().compiled(), fresh.core().compiled(), "{what}");
            }
            Expect::Applied { .. } => runs(
                &rt,
                &trace.after[hostile::AFTER_TICKS - 1],
                &row.config,
                &what,
            ),
        }
    }
    rows
}

/// The table holds what it must: a refusing row for every reason a Config can be
/// refused for, the limits on both sides, every nominal rate.
fn covers(rows: &[Row]) {
    for why in RefuseReason::ALL {
        let n = rows
            .iter()
            .filter(|r| r.expect == Expect::Refused(why))
            .count();
        match why {
            // Not about a Config, or unreachable past the ranges (module docs).
            RefuseReason::None | RefuseReason::Bits | RefuseReason::Unsupported => {
                assert_eq!(n, 0, "{why:?}")
            }
            _ => assert!(n >= 2, "{why:?}: {n} rows"),
        }
    }
    let applied = |f: &str| {
        rows.iter()
            .filter(|r| r.field == f && matches!(r.expect, Expect::Applied { .. }))
            .count()
    };
    assert!(
        applied(RefuseReason::HoldTicks.field()) >= 2,
        "hold: just inside"
    );
    // Every design point is applied, and nothing else that sets rates.
    let nominal: Vec<_> = rows
        .iter()
        .filter(|r| r.field == "nominal")
        .filter_map(|r| r.config.rates.map(|x| (x.base_rate_hz, x.delay_ticks)))
        .collect();
    let designed: Vec<_> = wheelset_control::design::DESIGNED
        .iter()
        .map(|p| (p.base_rate_hz, p.delay_ticks))
        .collect();
    assert_eq!(nominal, designed);
    // The switches every build takes.
    assert!(rows
        .iter()
        .any(|r| r.config.wsp && r.expect == Expect::Applied { visible: true }));
    assert!(rows.iter().any(|r| r.config.monitor_safe
        && r.config.mode == YawMode::Lead
        && matches!(r.expect, Expect::Applied { .. })));
    assert!(rows
        .iter()
        .all(|r| r.config.hold_ticks == DEFAULT_HOLD_TICKS
            || r.field == RefuseReason::HoldTicks.field()));
}

#[test]
fn every_hostile_config_is_refused_with_its_reason_fixed_point() {
    covers(&every_row::<Fx>());
}

#[test]
fn every_hostile_config_is_refused_with_its_reason_f32() {
    let rows = every_row::<f32>();
    covers(&rows);
    // The f32 patterns no fixed-point value has.
    for change in ["the largest subnormal", "NaN", "infinity", "1 LSB"] {
        let k = rows
            .iter()
            .find(|r| r.field == RefuseReason::Kappa.field() && r.change == change)
            .expect(change);
        assert_eq!(k.expect, Expect::Refused(RefuseReason::Kappa));
    }
}
