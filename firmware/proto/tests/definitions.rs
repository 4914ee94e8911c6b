//! The wire's definitions as the docs state them: the Actuation flags are the documented
//! bits (`Flags` docs: "Bit n"), `has` asks for every bit of a mask and `set` changes
//! only the mask's bits; a raw frame is at most `MAX_RAW` bytes; the refusal reasons name
//! distinct fields and their rows' reasons; the errors say what was rejected.

use wheelset_proto::plausible::{Plausible, PLAUSIBLE, PREDICT_HALF_MAX_QUARTERS};
use wheelset_proto::*;

/// Each flag and the bit its docs give it.
const BITS: [(u16, u32); 13] = [
    (Flags::ENABLED, 0),
    (Flags::HOLDING, 1),
    (Flags::SAFE, 2),
    (Flags::RX_ERROR, 3),
    (Flags::YAW_SAT, 4),
    (Flags::TRACTION_SAT, 5),
    (Flags::NO_SAMPLE, 6),
    (Flags::CMD_REFUSED, 7),
    (Flags::WHEEL_SLIP, 8),
    (Flags::HUNTING, 9),
    (Flags::ACTUATOR_FAULT, 10),
    (Flags::FAULT_LATCHED, 11),
    (Flags::DRIVE_OSC, 12),
];

#[test]
fn every_flag_is_its_documented_bit() {
    for (mask, bit) in BITS {
        assert_eq!(mask, 1u16 << bit, "bit {bit}");
    }
}

#[test]
fn has_asks_for_every_bit_and_set_changes_only_the_mask() {
    let (a, b) = (Flags::SAFE, Flags::HUNTING);
    let mut f = Flags::default();
    assert!(!f.has(a) && !f.has(b));
    f.set(a, true);
    assert!(f.has(a) && !f.has(b));
    assert!(!f.has(a | b), "one of the two bits is not every bit");
    f.set(b, true);
    assert!(f.has(a | b));
    assert_eq!(f, Flags(a | b));
    // Setting a set bit keeps it; clearing one bit keeps the other.
    f.set(a, true);
    assert_eq!(f, Flags(a | b));
    f.set(a, false);
    assert_eq!(f, Flags(b));
    assert!(!f.has(a) && f.has(b));
    f.set(a, false);
    assert_eq!(f, Flags(b), "clearing a clear bit changes nothing");
    // The empty mask is held by any flags.
    assert!(Flags::default().has(0));
}

#[test]
fn a_raw_frame_is_at_most_max_raw_bytes() {
    // VERSION | body of MAX_RAW bytes: framed, MAX_FRAME bytes with the delimiter, and
    // the CRC and version check pass (the body is no message: postcard's verdict).
    let mut raw = vec![0x55u8; MAX_RAW];
    raw[0] = VERSION;
    let mut out = [0u8; 2 * MAX_FRAME];
    let n = frame_raw(&raw, &mut out).expect("MAX_RAW bytes fit");
    assert_eq!(n, MAX_FRAME);
    let mut d = Decoder::new();
    let got = d.next_message(&out[..n]).0;
    assert!(
        matches!(got, Some(Err(FrameError::Postcard | FrameError::Length))),
        "{got:?}"
    );
    // One byte more is refused, whatever room the output has.
    raw.push(0x55);
    assert_eq!(frame_raw(&raw, &mut out), Err(EncodeError::BufferTooSmall));
}

#[test]
fn the_errors_say_what_was_rejected() {
    let said: Vec<String> = FrameError::KINDS.iter().map(ToString::to_string).collect();
    for (k, words) in FrameError::KINDS
        .iter()
        .zip(["CRC", "COBS", "version", "length", "decode"])
    {
        let s = k.to_string();
        assert!(
            s.starts_with("frame rejected: ") && s.contains(words),
            "{s}"
        );
    }
    for (i, s) in said.iter().enumerate() {
        assert_eq!(said.iter().filter(|t| *t == s).count(), 1, "{i}: {s}");
    }
    let e = EncodeError::BufferTooSmall.to_string();
    assert!(e.contains("MAX_FRAME"), "{e}");
}

fn row(r: RefuseReason) -> Option<&'static Plausible> {
    PLAUSIBLE.iter().find(|p| p.reason == r)
}

#[test]
fn each_refusal_names_its_own_field_and_its_rows_reason() {
    let fields: Vec<&str> = RefuseReason::ALL.iter().map(|r| r.field()).collect();
    for (r, f) in RefuseReason::ALL.iter().zip(&fields) {
        assert!(!f.is_empty(), "{r:?}");
        assert_eq!(fields.iter().filter(|g| *g == f).count(), 1, "{r:?}: {f}");
    }
    // The fields of the Config's rates are spelt as the message's.
    assert_eq!(RefuseReason::Kappa.field(), "rates.kappa");
    assert_eq!(RefuseReason::HoldTicks.field(), "hold_ticks");
    // The message: the field and the reason of its row in the table.
    let mut whys = Vec::new();
    for r in RefuseReason::ALL {
        let s = r.to_string();
        assert!(s.starts_with("refused: "), "{s}");
        assert!(s.contains(r.field()), "{s}");
        if let Some(p) = row(r) {
            assert!(s.contains(p.why), "{r:?}: {s}");
            whys.push(p.why);
        }
    }
    // (The rows do not all give one reason: the lookup is what picks it.)
    whys.dedup();
    assert!(whys.len() > 1);
}

#[test]
fn predict_half_is_at_most_three_quarters() {
    // The designs extrapolate over at most 1.5 ticks (`alpha`), and `predict_half` is
    // `alpha/2`: 3/4, the constant's `num/2^2`.
    let p = row(RefuseReason::PredictHalf).expect("a row");
    assert_eq!(p.max, 1.5 / 2.0);
    assert_eq!(p.max, f64::from(PREDICT_HALF_MAX_QUARTERS) / 4.0);
    assert_eq!(p.min, 0.0);
}

#[test]
fn the_shortest_frame_is_judged_on_its_message() {
    // MIN_DECODED bytes (version, type, CRC) is a whole frame: a Command without its
    // variant is a message that does not decode, not a bad length; one byte fewer is.
    let mut out = [0u8; MAX_FRAME];
    let n = frame_raw(&[VERSION, 3], &mut out).expect("fits");
    assert_eq!(n, MIN_DECODED + 2, "COBS byte and delimiter");
    let mut d = Decoder::new();
    assert_eq!(d.next_message(&out[..n]).0, Some(Err(FrameError::Postcard)));
    assert_eq!(d.next_request(&out[..n]).0, Some(Err(FrameError::Postcard)));
    let n = frame_raw(&[VERSION], &mut out).expect("fits");
    assert_eq!(d.next_message(&out[..n]).0, Some(Err(FrameError::Length)));
}
