//! Shared proptest strategies for every message.
#![allow(dead_code)]

use proptest::prelude::*;
use wheelset_proto::*;

/// Any i32, with the extremes and zero over-represented.
pub fn any_i32() -> impl Strategy<Value = i32> {
    prop_oneof![
        Just(i32::MIN),
        Just(i32::MAX),
        Just(0),
        Just(-1),
        -100_000..100_000i32,
        any::<i32>(),
    ]
}

/// Any u32, extremes over-represented.
pub fn any_u32() -> impl Strategy<Value = u32> {
    prop_oneof![Just(0), Just(u32::MAX), 0..10_000u32, any::<u32>()]
}

pub fn lateral() -> impl Strategy<Value = Lateral> {
    prop_oneof![
        any_i32().prop_map(Lateral::Velocity),
        any_i32().prop_map(Lateral::Acceleration),
        (any_i32(), any_i32()).prop_map(|(vel_um_s, acc_dmm_s2)| Lateral::Both {
            vel_um_s,
            acc_dmm_s2
        }),
    ]
}

pub fn sensor() -> impl Strategy<Value = Sensor> {
    (
        any::<u16>(),
        any::<u16>(),
        lateral(),
        any_i32(),
        any_i32(),
        any_i32(),
        any_i32(),
    )
        .prop_map(
            |(seq, t_us, lateral, i_a_ma, omega_m_mrad_s, demand_nm, v_ref_mm_s)| Sensor {
                seq,
                t_us,
                lateral,
                i_a_ma,
                omega_m_mrad_s,
                demand_nm,
                v_ref_mm_s,
            },
        )
}

pub fn actuation() -> impl Strategy<Value = Actuation> {
    (
        any::<u16>(),
        any::<u16>(),
        any_u32(),
        any::<u16>(),
        any_i32(),
        any_i32(),
    )
        .prop_map(
            |(seq_echo, tick, exec, flags, t_psi_dnm, u_a_cv)| Actuation {
                seq_echo,
                tick,
                exec,
                flags: Flags(flags),
                t_psi_dnm,
                u_a_cv,
            },
        )
}

/// Any u64, extremes over-represented.
pub fn any_u64() -> impl Strategy<Value = u64> {
    prop_oneof![Just(0), Just(u64::MAX), 0..(1u64 << 33), any::<u64>()]
}

pub fn rates() -> impl Strategy<Value = Rates> {
    (
        (
            any::<u8>(),
            any_u32(),
            any_u32(),
            any::<u16>(),
            any::<u16>(),
        ),
        proptest::array::uniform9(any_u32()),
        (any::<u8>(), any::<u8>(), any_u64(), any_u64()),
    )
        .prop_map(
            |(
                (numeric, fingerprint, base_rate_hz, yaw_div, traction_div),
                c,
                (delay_ticks, ki_shift, g, l),
            )| Rates {
                numeric,
                fingerprint,
                base_rate_hz,
                yaw_div,
                traction_div,
                delay_ticks,
                kappa: c[0],
                lead_k_hf: c[6],
                wsp_lead_k_hf: c[7],
                kp: c[8],
                ki: c[1],
                ki_shift,
                predict_half: c[2],
                iref_step: c[3],
                iref_safe_step: c[4],
                torque_step: c[5],
                acc_gain_q32: g,
                acc_leak_q32: l,
            },
        )
}

pub fn config() -> impl Strategy<Value = Config> {
    (
        prop_oneof![
            Just(YawMode::Passive),
            Just(YawMode::Gain),
            Just(YawMode::Lead)
        ],
        any::<bool>(),
        any::<bool>(),
        any::<u16>(),
        (any::<bool>(), any::<bool>()),
        proptest::option::of(rates()),
    )
        .prop_map(
            |(mode, traction, enable, hold_ticks, (wsp, monitor_safe), rates)| Config {
                mode,
                traction,
                enable,
                hold_ticks,
                wsp,
                monitor_safe,
                rates,
            },
        )
}

pub fn status() -> impl Strategy<Value = Status> {
    // A Vec, not an array: a 30-element array strategy overflowed the test's stack.
    (
        proptest::collection::vec(any_u32(), 30),
        any::<u8>(),
        any::<u8>(),
        any::<u16>(),
    )
        .prop_map(|(c, refuse_reason, reset_cause, flags)| Status {
            ticks: c[0],
            rx_ok: c[1],
            rx_crc: c[2],
            rx_cobs: c[3],
            rx_version: c[4],
            rx_length: c[5],
            rx_postcard: c[6],
            rx_unexpected: c[7],
            seq_gaps: c[8],
            held_ticks: c[9],
            safe_ticks: c[10],
            safe_entries: c[11],
            safe_exits: c[12],
            yaw_sat: c[13],
            traction_sat: c[14],
            input_clamped: c[15],
            cmd_refused: c[16],
            ticks_late: c[17],
            ticks_missed: c[18],
            rx_overrun: c[19],
            tx_dropped: c[20],
            wsp_ticks: c[21],
            wsp_events: c[22],
            hunt_alarms: c[23],
            act_alarms: c[24],
            first_alarm_tick: c[25],
            drive_alarms: c[26],
            first_drive_alarm_tick: c[27],
            boot_count: c[28],
            stack_peak: c[29],
            refuse_reason,
            reset_cause,
            flags: Flags(flags),
        })
}

pub fn message() -> impl Strategy<Value = Message> {
    prop_oneof![
        sensor().prop_map(Message::Sensor),
        actuation().prop_map(Message::Actuation),
        config().prop_map(Message::Config),
        prop_oneof![Just(Command::ResetCounters), Just(Command::RequestStatus)]
            .prop_map(Message::Command),
        status().prop_map(Message::Status),
    ]
}

/// Feeds `bytes` to a fresh decoder; returns every result.
pub fn decode_all(bytes: &[u8]) -> Vec<Result<Message, FrameError>> {
    Decoder::new().messages(bytes).collect()
}
