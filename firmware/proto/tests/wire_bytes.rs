//! The bytes on the wire, pinned: 3 000 messages (every type, every varint length, the
//! extremes) encode to exactly the frames of the protocol's first implementation (a
//! hand-written codec, itself tested against postcard, the `cobs` crate and the `crc`
//! crate), recorded as a hash of them all and ten frames in full; each decodes back.
#![allow(clippy::unwrap_used)]

use wheelset_proto::*;

/// A deterministic spread of every message: the extremes of each field, then
/// pseudo-random values (xorshift32) biased to every varint length.
pub fn messages() -> Vec<Message> {
    let mut x = 0x2545_F491u32;
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        x
    };
    let mut out = Vec::new();
    for k in 0..600u32 {
        // Every varint length: 7, 14, 21, 28 and 32 significant bits.
        let mut v = || {
            let r = next();
            match r % 7 {
                0 => 0,
                1 => u32::MAX,
                2 => r >> 25,
                3 => r >> 18,
                4 => r >> 11,
                5 => r >> 4,
                _ => r,
            }
        };
        let i = |u: u32| u as i32;
        let lateral = match k % 3 {
            0 => Lateral::Velocity(i(v())),
            1 => Lateral::Acceleration(i(v())),
            _ => Lateral::Both {
                vel_um_s: i(v()),
                acc_dmm_s2: i(v()),
            },
        };
        let sensor = Sensor {
            seq: v() as u16,
            t_us: v() as u16,
            lateral,
            i_a_ma: i(v()),
            omega_m_mrad_s: i(v()),
            demand_nm: i(v()),
            v_ref_mm_s: i(v()),
        };
        let actuation = Actuation {
            seq_echo: v() as u16,
            tick: v() as u16,
            exec: v(),
            flags: Flags(v() as u16),
            t_psi_dnm: i(v()),
            u_a_cv: i(v()),
        };
        let rates = Rates {
            numeric: v() as u8,
            fingerprint: v(),
            base_rate_hz: v(),
            yaw_div: v() as u16,
            traction_div: v() as u16,
            delay_ticks: v() as u8,
            kappa: v(),
            lead_k_hf: v(),
            wsp_lead_k_hf: v(),
            kp: v(),
            ki: v(),
            ki_shift: v() as u8,
            predict_half: v(),
            iref_step: v(),
            iref_safe_step: v(),
            torque_step: v(),
            acc_gain_q32: u64::from(v()) << 32 | u64::from(v()),
            acc_leak_q32: u64::from(v()),
        };
        let config = Config {
            mode: [YawMode::Passive, YawMode::Gain, YawMode::Lead][(k % 3) as usize],
            traction: k % 2 == 0,
            enable: k % 5 != 0,
            hold_ticks: v() as u16,
            wsp: k % 3 == 0,
            monitor_safe: k % 7 == 0,
            rates: (k % 2 == 1).then_some(rates),
        };
        let command = [
            Command::ResetCounters,
            Command::RequestStatus,
            Command::ClearFaults,
            Command::InjectStall,
            Command::InjectHardFault,
        ][(k % 5) as usize];
        let status = Status {
            ticks: v(),
            rx_ok: v(),
            rx_crc: v(),
            rx_cobs: v(),
            rx_version: v(),
            rx_length: v(),
            rx_postcard: v(),
            rx_unexpected: v(),
            seq_gaps: v(),
            held_ticks: v(),
            safe_ticks: v(),
            safe_entries: v(),
            safe_exits: v(),
            yaw_sat: v(),
            traction_sat: v(),
            input_clamped: v(),
            cmd_refused: v(),
            ticks_late: v(),
            ticks_missed: v(),
            rx_overrun: v(),
            tx_dropped: v(),
            wsp_ticks: v(),
            wsp_events: v(),
            hunt_alarms: v(),
            act_alarms: v(),
            first_alarm_tick: v(),
            drive_alarms: v(),
            first_drive_alarm_tick: v(),
            boot_count: v(),
            stack_peak: v(),
            refuse_reason: v() as u8,
            reset_cause: v() as u8,
            flags: Flags(v() as u16),
        };
        out.extend([
            Message::Sensor(sensor),
            Message::Actuation(actuation),
            Message::Config(config),
            Message::Command(command),
            Message::Status(status),
        ]);
    }
    out
}

/// FNV-1a (64 bits) over bytes.
pub fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xCBF2_9CE4_8422_2325u64, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01B3)
    })
}

/// The first ten frames of [`messages`], hex.
const FIRST_FRAMES: [&str; 10] = [
    "0203054e73381906c6ad92e10106a19192d50108ca8a01554ceb3000",
    "0303010113f673ffffffff0fa55d01d2878e010fa86f0c00",
    "030302020106c0ce03010105509eed0600",
    "0303030590cbadbe00",
    "050304b8381316f2b27304ffffffff0fb46a9b936e9fb9523dd14599ea7ccc75ffffffff0ffea983e006ffffffff0f818ad61b4ba0cac0b905aaa3d68802ffffffff0fffffffff0fb7c177c0b329e4e6f46090223a0c042432e3d5d302fe30fa5a00",
    "020302520a3c0401d4e601ec010106016d57991000",
    "040301100fa7328c6e79a0bbd0010158f4997100",
    "040302010501e8d503010b0139054318c421e29301024324ffffffff0fb794d752f488d50b34ffd19a99900f8827f7d5ff2397858368ffffffff78010105af836e070101010565f1813500",
    "080303019348c64c00",
    "2a030480a89c2ef79b7dc8e6f9960b75e860ffffffff0fc0df8e05dd95bd71ffffffff0f96428fafd93b2f8f18e5e398bc0ab88cbab705acc1c59804ffffffff0f38ffffffff0fb6de7eefe1b1b90bffffffff0ffe95bda80f0581f41253059ecbc90a06b0e7f7d40908f3aa37738dcc2500",
];

#[test]
fn the_frames_are_the_recorded_ones() {
    let ms = messages();
    let mut all = Vec::new();
    let mut dec = Decoder::new();
    for m in &ms {
        let f = encode_vec(m).unwrap();
        all.extend_from_slice(&f);
        let (got, rest) = dec.next_message(&f);
        assert_eq!((got, rest.len()), (Some(Ok(*m)), 0));
    }
    for (m, want) in ms.iter().zip(FIRST_FRAMES) {
        let f = encode_vec(m).unwrap();
        let hex: String = f.iter().map(|b| format!("{b:02x}")).collect();
        assert_eq!(hex, want, "{m:?}");
    }
    assert_eq!(
        (ms.len(), all.len(), fnv(&all)),
        (3000, 123_425, 0x9e39_4458_8389_63bc)
    );
}
