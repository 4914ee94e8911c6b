//! The runtime's state as its accessors report it agrees with what it sends: `is_safe`
//! with the Actuation's `SAFE` flag on every tick through a hold, the safe state and the
//! recovery; `FAULT_LATCHED` before a fault, after a watchdog reset's boot and after
//! `ClearFaults`.

use wheelset_control::Fx;
use wheelset_proto::*;
use wheelset_runtime::*;

mod common;
use common::{act, frame, vel};

#[test]
fn is_safe_is_the_safe_flag_the_runtime_sends() {
    let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("the default runs");
    let hold = usize::from(r.hold_ticks());
    let mut seen_safe = false;
    let mut seq = 0u16;
    // Frames, then a silence past the hold, then frames again.
    for k in 0..(20 + hold + 5 + 20) {
        let fresh = !(20..20 + hold + 5).contains(&k);
        if fresh {
            seq = seq.wrapping_add(1);
            r.receive(&vel(seq, 0));
        }
        let a = act(r.tick(0));
        assert_eq!(
            r.is_safe(),
            a.flags.has(Flags::SAFE),
            "tick {k}: is_safe against the frame's flag"
        );
        seen_safe |= r.is_safe();
    }
    assert!(
        seen_safe,
        "the silence past the hold entered the safe state"
    );
    assert!(!r.is_safe(), "the frames after it left the safe state");
}

#[test]
fn fault_latched_is_set_by_a_watchdog_boot_until_cleared() {
    let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("the default runs");
    r.receive(&vel(1, 0));
    let a = act(r.tick(0));
    assert!(!a.flags.has(Flags::FAULT_LATCHED));
    // A boot after a watchdog reset latches the fault (and holds the safe state).
    r.set_boot(2, reset_cause::WATCHDOG);
    r.receive(&vel(2, 0));
    let a = act(r.tick(0));
    assert!(a.flags.has(Flags::FAULT_LATCHED));
    r.receive(&frame(&Message::Command(Command::ClearFaults)));
    r.receive(&vel(3, 0));
    let a = act(r.tick(0));
    assert!(!a.flags.has(Flags::FAULT_LATCHED));
}
