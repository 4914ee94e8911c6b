//! Frame sizes on the wire, at the `curve` scenario's typical values and at the extremes.
//! Run with `--nocapture` to see the table quoted in the crate docs.

use wheelset_proto::*;

fn len(m: Message) -> usize {
    encode_vec(&m).expect("fits").len()
}

fn sensor(lateral: Lateral, i_a_ma: i32, omega: i32, demand_nm: i32, v_ref_mm_s: i32) -> Message {
    Message::Sensor(Sensor {
        seq: 40_000,
        t_us: 12_345,
        lateral,
        i_a_ma,
        omega_m_mrad_s: omega,
        demand_nm,
        v_ref_mm_s,
    })
}

fn actuation(exec: u32, flags: u16, t_psi_dnm: i32, u_a_cv: i32) -> Message {
    Message::Actuation(Actuation {
        seq_echo: 40_000,
        tick: 40_001,
        exec,
        flags: Flags(flags),
        t_psi_dnm,
        u_a_cv,
    })
}

fn worst_status() -> Status {
    Status {
        ticks: u32::MAX,
        rx_ok: u32::MAX,
        rx_crc: u32::MAX,
        rx_cobs: u32::MAX,
        rx_version: u32::MAX,
        rx_length: u32::MAX,
        rx_postcard: u32::MAX,
        rx_unexpected: u32::MAX,
        seq_gaps: u32::MAX,
        held_ticks: u32::MAX,
        safe_ticks: u32::MAX,
        safe_entries: u32::MAX,
        safe_exits: u32::MAX,
        yaw_sat: u32::MAX,
        traction_sat: u32::MAX,
        input_clamped: u32::MAX,
        cmd_refused: u32::MAX,
        ticks_late: u32::MAX,
        ticks_missed: u32::MAX,
        rx_overrun: u32::MAX,
        tx_dropped: u32::MAX,
        wsp_ticks: u32::MAX,
        wsp_events: u32::MAX,
        hunt_alarms: u32::MAX,
        act_alarms: u32::MAX,
        first_alarm_tick: u32::MAX,
        drive_alarms: u32::MAX,
        first_drive_alarm_tick: u32::MAX,
        boot_count: u32::MAX,
        stack_peak: u32::MAX,
        refuse_reason: u8::MAX,
        reset_cause: u8::MAX,
        flags: Flags(u16::MAX),
    }
}

fn worst_config() -> Config {
    Config {
        mode: YawMode::Lead,
        traction: true,
        enable: true,
        hold_ticks: u16::MAX,
        wsp: true,
        monitor_safe: true,
        rates: Some(Rates {
            numeric: u8::MAX,
            fingerprint: u32::MAX,
            base_rate_hz: u32::MAX,
            yaw_div: u16::MAX,
            traction_div: u16::MAX,
            delay_ticks: u8::MAX,
            kappa: u32::MAX,
            lead_k_hf: u32::MAX,
            wsp_lead_k_hf: u32::MAX,
            kp: u32::MAX,
            ki: u32::MAX,
            ki_shift: u8::MAX,
            predict_half: u32::MAX,
            iref_step: u32::MAX,
            iref_safe_step: u32::MAX,
            torque_step: u32::MAX,
            acc_gain_q32: u64::MAX,
            acc_leak_q32: u64::MAX,
        }),
    }
}

#[test]
fn sizes_within_budget() {
    use units::*;
    let q = |x, lsb| quantize(x, lsb).0;
    // Typical, curve with traction: y' 2 mm/s, i_a 115 A, 925.6 rad/s, demand 2460 N m,
    // v 83.3 m/s; T_psi 200 N m, u_a 3965 V, a tick of 600 cycles, flags ENABLED.
    let m = i32::MIN;
    let s_typ = len(sensor(
        Lateral::Velocity(q(2e-3, LAT_VEL_LSB_M_PER_S)),
        q(115.0, CURRENT_LSB_A),
        q(925.6, SPEED_LSB_RAD_PER_S),
        q(2460.0, DEMAND_LSB_NM),
        q(83.3, V_REF_LSB_M_PER_S),
    ));
    let a_typ = len(actuation(
        600,
        Flags::ENABLED,
        q(200.0, TORQUE_LSB_NM),
        q(3965.0, VOLTAGE_LSB_V),
    ));
    let s_max = len(sensor(Lateral::Velocity(m), m, m, m, m));
    let s_both = len(sensor(
        Lateral::Both {
            vel_um_s: i32::MIN,
            acc_dmm_s2: i32::MIN,
        },
        m,
        m,
        m,
        m,
    ));
    let a_max = len(actuation(u32::MAX, u16::MAX, m, m));
    let st_max = len(Message::Status(worst_status()));
    let cfg_max = len(Message::Config(worst_config()));
    println!("wire bytes incl. delimiter: sensor typical {s_typ}, worst {s_max} (both lateral: {s_both}); actuation typical {a_typ}, worst {a_max}; both typical {}, worst {}; status worst {st_max}; config with rates worst {cfg_max}; MAX_FRAME {MAX_FRAME}", s_typ + a_typ, s_max + a_max);
    // Overhead 8 (COBS 1, delimiter 1, version 1, type 1, CRC 4) + the fields: sensor
    // seq 2 + t 2 + lateral tag 1 + y' 2 + i_a 3 + speed 3 + demand 2 + v_ref 3.
    assert!(s_typ <= 8 + 18, "sensor {s_typ}");
    // Actuation: seq 2 + tick 2 + exec 2 + flags 1 + torque 2 + voltage 3.
    assert!(a_typ <= 8 + 12, "actuation {a_typ}");
    assert!(
        s_both <= 43 && a_max <= 30,
        "sensor {s_both}, actuation {a_max}"
    );
    assert!(st_max <= MAX_FRAME);
    assert!(cfg_max <= MAX_FRAME, "config {cfg_max}");
}

/// The worst cases are the constants of the crate (every link budget uses them) and
/// each is reached: the longest encoding of each message.
#[test]
fn worst_cases_are_the_crate_constants() {
    let m = i32::MIN;
    let s = |lateral| len(sensor(lateral, m, m, m, m));
    assert_eq!(s(Lateral::Velocity(m)), SENSOR_ONE_LATERAL_MAX_FRAME);
    assert_eq!(s(Lateral::Acceleration(m)), SENSOR_ONE_LATERAL_MAX_FRAME);
    assert_eq!(
        s(Lateral::Both {
            vel_um_s: m,
            acc_dmm_s2: m
        }),
        SENSOR_MAX_FRAME
    );
    assert_eq!(
        len(actuation(u32::MAX, u16::MAX, m, m)),
        ACTUATION_MAX_FRAME
    );
    for c in [
        Command::ResetCounters,
        Command::RequestStatus,
        Command::ClearFaults,
        Command::InjectStall,
        Command::InjectHardFault,
    ] {
        assert_eq!(len(Message::Command(c)), COMMAND_MAX_FRAME);
    }
    assert_eq!(len(Message::Config(worst_config())), CONFIG_MAX_FRAME);
    assert_eq!(len(Message::Status(worst_status())), STATUS_MAX_FRAME);
    for n in [
        SENSOR_MAX_FRAME,
        ACTUATION_MAX_FRAME,
        CONFIG_MAX_FRAME,
        STATUS_MAX_FRAME,
    ] {
        assert!(n <= MAX_FRAME, "{n} > MAX_FRAME {MAX_FRAME}");
    }
}
