//! The simulated serial link (`wheelset_loop::sim_link`) through its public API: the fault
//! spec, the timing of the line, fault injection and the frame accounting.

use wheelset_loop::sim_link::*;
use wheelset_proto::Message;
use wheelset_proto::{encode_vec, Command, Sensor};

fn frame(seq: u16) -> Vec<u8> {
    encode_vec(&Message::Sensor(Sensor {
        seq,
        t_us: seq.wrapping_mul(200),
        lateral: wheelset_proto::Lateral::Velocity(i32::from(seq) * 7 - 3000),
        i_a_ma: 115_000,
        omega_m_mrad_s: 925_600,
        demand_nm: 2460,
        v_ref_mm_s: 0,
    }))
    .expect("fits")
    .to_vec()
}

#[test]
fn fault_spec_parses_and_refuses() {
    let f: Faults =
        "ber=1e-3, drop=0.1,outage=8.0:0.05,outage=9:1:down,burst=2:5,byte_drop=0.01,dir=up"
            .parse()
            .expect("valid");
    assert_eq!(f.ber, 1e-3);
    assert_eq!(f.frame_drop, 0.1);
    assert_eq!(f.byte_drop, 0.01);
    assert_eq!(
        f.outages,
        vec![
            Outage {
                start_ns: 8_000_000_000,
                len_ns: 50_000_000,
                dir: FaultDir::Both,
            },
            Outage {
                start_ns: 9_000_000_000,
                len_ns: 1_000_000_000,
                dir: FaultDir::Down,
            }
        ]
    );
    assert_eq!(
        f.burst,
        Some(Burst {
            rate_hz: 2.0,
            len_bytes: 5
        })
    );
    assert_eq!(f.dir, FaultDir::Up);
    assert!("outage=1:2:sideways".parse::<Faults>().is_err());
    assert_eq!("".parse::<Faults>(), Ok(Faults::none()));
    for (bad, needle) in [
        ("ber=1", "outside [0, 1)"),
        ("ber=x", "not a number"),
        ("drop=-0.1", "outside [0, 1]"),
        ("outage=8", "START_S:LEN_S"),
        ("outage=8:0", "second > 0"),
        ("burst=1:2.5", "whole number"),
        ("nope=1", "unknown key"),
        ("ber", "key=value"),
        ("dir=left", "both, up or down"),
    ] {
        let e = bad.parse::<Faults>().expect_err(bad);
        assert!(e.to_string().contains(needle), "{bad}: {e}");
        assert!(e.to_string().contains(bad), "{bad}: {e}");
    }
}

#[test]
fn the_fault_spec_prints_its_canonical_form_which_parses_back() {
    let f: Faults = " drop=0.05 ,ber=1e-3,outage=8:0.05:up"
        .parse()
        .expect("valid");
    assert_eq!(f.to_string(), "ber=0.001,drop=0.05,outage=8:0.05:up");
    assert_eq!(f.to_string().parse::<Faults>(), Ok(f));
    assert_eq!(Faults::none().to_string(), "");
}

#[test]
fn bytes_arrive_at_baud_plus_latency_in_order() {
    let cfg = LinkConfig {
        baud: 1_000_000,
        latency_ns: 3_000,
        ..LinkConfig::default()
    };
    let mut link = Link::new(&cfg);
    let a = frame(1);
    let b = frame(2);
    link.up.send(1_000, &a);
    link.up.send(1_000, &b); // queued behind `a`
    let n = a.len() + b.len();
    // 10 us per byte at 1 Mbaud: the last byte arrives after n * 10 us + latency.
    let last = 1_000 + n as u64 * 10_000 + 3_000;
    let mut got = Vec::new();
    link.up
        .deliver(last - 1, |run, id| got.extend(run.iter().map(|&b| (b, id))));
    assert_eq!(got.len(), n - 1);
    link.up
        .deliver(last, |run, id| got.extend(run.iter().map(|&b| (b, id))));
    let bytes: Vec<u8> = got.iter().map(|g| g.0).collect();
    assert_eq!(bytes, [a.clone(), b.clone()].concat());
    assert_eq!(got[a.len() - 1].1, 0);
    assert_eq!(got[a.len()].1, 1);
    assert_eq!(link.up.line_free_ns(), last - 3_000);
    assert_eq!(link.down.counters().frames_sent, 0);
}

#[test]
fn frames_in_flight_wrap_the_ring_in_order() {
    // 100 kbaud: 100 us per byte, so frames pile up behind each other; deliveries in
    // between take the front off while sends add at the back (the ring wraps and grows).
    let cfg = LinkConfig {
        baud: 100_000,
        latency_ns: 0,
        ..LinkConfig::default()
    };
    for faults in ["", "dir=up,ber=1e-12"] {
        let cfg = LinkConfig {
            faults: faults.parse().expect("valid"),
            ..cfg.clone()
        };
        let mut link = Link::new(&cfg);
        let mut sent: Vec<Vec<u8>> = Vec::new();
        let mut got: Vec<(u8, FrameId)> = Vec::new();
        let mut t = 0;
        for round in 0..6u16 {
            for k in 0..(1 + round % 4) {
                let f = frame(round * 10 + k);
                assert_eq!(link.up.send(t, &f) as usize, sent.len());
                sent.push(f);
            }
            t += 3_000_000; // 30 bytes' time: less than the frames sent
            link.up
                .deliver(t, |run, id| got.extend(run.iter().map(|&b| (b, id))));
            // What is still queued is exactly the frames not yet complete, in order.
            let done = sent
                .iter()
                .enumerate()
                .filter(|(id, f)| got.iter().filter(|g| g.1 as usize == *id).count() == f.len())
                .count();
            let queued: Vec<FrameId> = link.up.queued_frames().collect();
            let expect: Vec<FrameId> = (done as FrameId..sent.len() as FrameId).collect();
            assert_eq!(queued, expect, "{faults:?} round {round}");
        }
        link.up
            .deliver(u64::MAX, |run, id| got.extend(run.iter().map(|&b| (b, id))));
        assert_eq!(link.up.queued_frames().count(), 0);
        let bytes: Vec<u8> = got.iter().map(|g| g.0).collect();
        assert_eq!(bytes, sent.concat(), "{faults:?}");
        let ids: Vec<FrameId> = got.iter().map(|g| g.1).collect();
        let expect: Vec<FrameId> = sent
            .iter()
            .enumerate()
            .flat_map(|(id, f)| std::iter::repeat_n(id as FrameId, f.len()))
            .collect();
        assert_eq!(ids, expect, "{faults:?}");
    }
}

fn run(cfg: &LinkConfig, frames: u16) -> (Vec<u8>, Accounting, ChannelCounters) {
    let mut link = Link::new(cfg);
    let mut rx = RxPort::default();
    let mut out = Vec::new();
    let period = 200_000;
    for k in 0..frames {
        let t = u64::from(k) * period;
        link.up.send(t, &frame(k));
        link.up.deliver(t + period - 1, |run, id| {
            out.extend_from_slice(run);
            rx.push(run, id, |_| {});
        });
    }
    (out, rx.account(&link.up), *link.up.counters())
}

#[test]
fn deterministic_for_a_seed() {
    let faults: Faults = "ber=1e-3,drop=0.1,byte_drop=0.01,burst=20:4"
        .parse()
        .expect("valid");
    let cfg = LinkConfig {
        faults,
        seed: 7,
        ..LinkConfig::default()
    };
    let (a, acc_a, _) = run(&cfg, 2000);
    let (b, acc_b, _) = run(&cfg, 2000);
    assert_eq!(a, b);
    assert_eq!(acc_a, acc_b);
    let (c, _, _) = run(&LinkConfig { seed: 8, ..cfg }, 2000);
    assert_ne!(a, c);
}

#[test]
fn bit_error_rate_matches() {
    let cfg = LinkConfig {
        faults: "ber=1e-2".parse().expect("valid"),
        ..LinkConfig::default()
    };
    let (_, _, c) = run(&cfg, 5000);
    let bits = (c.bytes_delivered * 8) as f64;
    let expect = bits * 1e-2;
    // Binomial: 5 sigma.
    let sigma = (bits * 1e-2 * 0.99).sqrt();
    assert!(
        (c.bits_flipped as f64 - expect).abs() < 5.0 * sigma,
        "{} flips, expected {expect}",
        c.bits_flipped
    );
}

#[test]
fn outage_loses_exactly_its_window() {
    let cfg = LinkConfig {
        faults: "outage=0.1:0.05".parse().expect("valid"),
        ..LinkConfig::default()
    };
    let (_, acc, c) = run(&cfg, 1000);
    // 0.05 s at 200 us per frame: 250 frames lost whole, the two at the edges damaged.
    assert!((249..=251).contains(&acc.dropped), "{acc}");
    assert!(acc.rejected <= 2, "{acc}");
    assert!(c.bytes_outage > 0);
    assert!(acc.adds_up(), "{acc}");
    assert_eq!(acc.received + acc.rejected + acc.dropped, 1000);
}

#[test]
fn every_frame_accounted_under_every_fault() {
    let faults: Faults = "ber=1e-3,drop=0.1,byte_drop=0.005,burst=50:6,outage=0.2:0.05"
        .parse()
        .expect("valid");
    let cfg = LinkConfig {
        faults,
        seed: 3,
        ..LinkConfig::default()
    };
    let (_, acc, c) = run(&cfg, 5000);
    assert!(acc.adds_up(), "{acc}");
    assert!(acc.dropped >= acc.link_dropped_whole);
    assert_eq!(acc.link_dropped_whole, c.frames_dropped);
    // 10 % whole-frame drops, within 5 sigma.
    assert!(
        (c.frames_dropped as f64 - 500.0).abs() < 5.0 * (450.0f64).sqrt(),
        "{acc}"
    );
    assert!(acc.rejected > 0 && acc.received > 2500, "{acc}");
    // Without faults, every frame arrives valid.
    let (_, clean, _) = run(&LinkConfig::default(), 500);
    assert_eq!((clean.received, clean.rejected, clean.dropped), (500, 0, 0));
    let _ = Command::ResetCounters;
}

#[test]
fn budget_fits_or_names_the_numbers() {
    // 5 kHz, the worst-case frames 43 + 30 bytes at 5 Mbaud, 2 us latency:
    // 730 bits / 5 Mbaud = 146 us, + 4 us, of the 170 us share of 200 us.
    let (up, down) = (
        wheelset_proto::SENSOR_MAX_FRAME,
        wheelset_proto::ACTUATION_MAX_FRAME,
    );
    let rt = check_budget(up, down, DEFAULT_BAUD, DEFAULT_LATENCY_NS, 200_000, 1).expect("fits");
    assert_eq!(
        rt,
        ((up + down) as u64 * 10 * 1_000_000_000).div_ceil(5_000_000) + 4_000
    );
    assert!(check_budget(up, down, 4_000_000, DEFAULT_LATENCY_NS, 200_000, 1).is_err());
    let e = check_budget(33, 28, 1_000_000, 2_000, 200_000, 1).expect_err("too slow");
    let msg = e.to_string();
    for needle in [
        "33 + 28",
        "1000000 baud",
        "614.0 us",
        "5000 Hz",
        "170.0 us",
        "3674699",
    ] {
        assert!(msg.contains(needle), "missing {needle}: {msg}");
    }
    assert!(check_budget(33, 28, 0, 0, 200_000, 1).is_err());
}
