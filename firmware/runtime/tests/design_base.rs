//! The runtime configuration's design base and build errors (`RuntimeConfig::designed`,
//! `RuntimeConfig::design_base`, `RuntimeBits::try_new`, `RuntimeError`'s message): the
//! designs of other rates are scaled from the base, never from a design of it; the
//! monitor's drive check is quantised in the control core's own current scale; every
//! error names its cause.

use wheelset_control::{BitsError, Config as ControlConfig, ConfigError, Fx, MonitorParams};
use wheelset_runtime::*;

/// A design point other than the paper's (5 kHz, one tick), with the yaw law designed.
const OTHER: (u32, u8) = (10_000, 2);

#[test]
fn the_design_base_is_the_design_field_else_the_control_core() {
    // Without a design base the configuration is its own: a control core that is not
    // the default one (a design of another rate, taken as a base) is its base.
    let own = ControlConfig::default()
        .designed(OTHER.0, OTHER.1)
        .expect("a design point");
    assert_ne!(own, ControlConfig::default());
    let cfg = RuntimeConfig {
        control: own,
        design: None,
        ..RuntimeConfig::default()
    };
    assert_eq!(cfg.design_base(), own);
    // With one, the base is that one, whatever the core runs.
    let cfg = RuntimeConfig {
        design: Some(ControlConfig::default()),
        ..cfg
    };
    assert_eq!(cfg.design_base(), ControlConfig::default());
}

#[test]
fn a_design_is_scaled_from_the_base_and_remembers_it() {
    let boot = RuntimeConfig::default();
    // Another point: the control core is the base's design there, and the base is kept
    // (a second design is scaled from it, not from the first design).
    let at = boot.designed(OTHER.0, OTHER.1).expect("designed");
    assert_eq!(
        at.control,
        boot.control.designed(OTHER.0, OTHER.1).expect("designed")
    );
    assert_ne!(at.control, boot.control, "another rate, other gains");
    assert_eq!(at.design, Some(boot.control));
    assert_eq!(at.design_base(), boot.control);
    // The rest of the configuration is carried over.
    assert_eq!(
        (at.hold_ticks, at.enable, at.monitor),
        (boot.hold_ticks, boot.enable, boot.monitor)
    );
    let back = at.designed(5_000, 1).expect("the paper's point");
    assert_eq!(
        back.control, boot.control,
        "the base's own point is the base"
    );
    // At the base's own point, the configuration is its own design base: no base added.
    let same = boot.designed(5_000, 1).expect("the paper's point");
    assert_eq!(same.control, boot.control);
    assert_eq!(same.design, None);
    assert_eq!(same, boot);
    // A point outside the designs is an error, not a configuration.
    assert!(matches!(
        boot.designed(7_000, 1),
        Err(RuntimeError::Control(ConfigError::Range { .. }))
    ));
}

#[test]
fn the_monitor_is_quantised_in_the_control_cores_current_scale() {
    // `MonitorParams::current_scale_a` is replaced by the control core's scale: a
    // monitor configured with another one compiles to the same bits.
    let boot = RuntimeConfig::default();
    let params = boot.monitor.expect("the default runs the monitor");
    assert_eq!(params.current_scale_a, boot.control.scales.current);
    let other = RuntimeConfig {
        monitor: Some(MonitorParams {
            current_scale_a: 4.0 * params.current_scale_a,
            ..params
        }),
        ..boot
    };
    let (a, b) = (
        RuntimeBits::try_new::<Fx>(&boot).expect("valid"),
        RuntimeBits::try_new::<Fx>(&other).expect("valid"),
    );
    assert_eq!(a.monitor, b.monitor);
    // And the scale matters to the monitor: a core with another current scale compiles
    // another drive check (its ripple level in other per-unit).
    let mut scaled = boot;
    scaled.control.scales.current *= 1.2;
    let c = RuntimeBits::try_new::<Fx>(&scaled).expect("valid");
    assert_ne!(a.monitor, c.monitor);
}

#[test]
fn every_runtime_error_names_its_cause() {
    let range = ConfigError::Range {
        field: "base_rate_hz",
        value: 7_000.0,
        reason: "no design",
    };
    let control = RuntimeError::Control(range).to_string();
    assert!(control.contains(&range.to_string()), "{control}");
    let bits = RuntimeError::from(BitsError { field: "kappa" });
    assert_eq!(bits, RuntimeError::Bits(BitsError { field: "kappa" }));
    assert!(bits.to_string().contains("`kappa`"), "{bits}");
    assert_eq!(RuntimeError::from(range), RuntimeError::Control(range));
    let washout = RuntimeError::Washout.to_string();
    assert!(washout.contains("acc_washout_s"), "{washout}");
    let design = RuntimeError::Design.to_string();
    assert!(design.contains("design base"), "{design}");
    // Each from the runtime, so a log line tells the runtime's refusal from others'.
    for m in [control, bits.to_string(), washout, design] {
        assert!(m.starts_with("runtime: "), "{m}");
    }
}
