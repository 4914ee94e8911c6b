//! What the control task drives, the firmware's [`FwRuntime`]: bytes in, one encoded frame
//! out per tick.

use wheelset_control::{Compiled, Monitor};
use wheelset_proto::{encode, Message, MAX_FRAME};
use wheelset_runtime::{Runtime, RuntimeBits, RuntimeError, SAFE_ACTUATION};

/// The default runtime compiled at build time (`build.rs`): the generated constant.
mod generated {
    use wheelset_control::{
        CompiledBits, MonitorBits, ScaleBits, ScheduleBits, WspBits, YawMode::*,
    };
    use wheelset_runtime::{AccBits, Designs, Rates, RuntimeBits};
    include!(concat!(env!("OUT_DIR"), "/default_runtime.rs"));
}

/// The core's sample type: fixed point (`I4F28`), or `f32` with the `f32` feature.
#[cfg(not(feature = "f32"))]
pub type Num = wheelset_control::Fx;
/// The core's sample type: fixed point (`I4F28`), or `f32` with the `f32` feature.
#[cfg(feature = "f32")]
pub type Num = f32;

/// The firmware's runtime.
pub type FwRuntime = Runtime<Num>;

/// The default configuration compiled for [`Num`] at build time: exact bits.
pub const DEFAULT_RUNTIME: RuntimeBits = generated::DEFAULT_RUNTIME;

/// The default core from [`DEFAULT_RUNTIME`] at compile time (validated by a host test).
pub const DEFAULT_CORE: Compiled<Num> = Compiled::<Num>::from_valid_bits(&DEFAULT_RUNTIME.control);

/// The default monitor at the default base rate, at compile time (validated by the same test).
pub const DEFAULT_MONITOR: Monitor<Num> = Monitor::<Num>::from_valid_bits(
    &DEFAULT_RUNTIME.monitor,
    DEFAULT_RUNTIME.control.schedule.base_rate_hz,
);

/// The fingerprint of the default core's rate-independent part, at compile time.
pub const DEFAULT_FINGERPRINT: u32 = DEFAULT_RUNTIME.control.fingerprint();

/// The firmware's runtime with the default configuration (no conversion code on the device).
pub fn new_runtime() -> Result<FwRuntime, RuntimeError> {
    FwRuntime::with_core(
        &DEFAULT_CORE,
        DEFAULT_FINGERPRINT,
        DEFAULT_RUNTIME.acc,
        DEFAULT_RUNTIME.hold_ticks,
        DEFAULT_RUNTIME.enable,
        DEFAULT_MONITOR,
        &DEFAULT_RUNTIME.designs,
    )
}

/// Encodes the safe-state frame ([`SAFE_ACTUATION`]) into `out`.
pub fn safe_frame(out: &mut [u8; MAX_FRAME]) -> &[u8] {
    match encode(&Message::Actuation(SAFE_ACTUATION), out) {
        Ok(n) => out.get(..n).unwrap_or(&[]),
        Err(_) => &[],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wheelset_proto::{encode_vec, Decoder, Flags, Lateral, Sensor};

    fn decode_all(bytes: &[u8]) -> Vec<Message> {
        let mut dec: Decoder = Decoder::new();
        let mut out = Vec::new();
        let mut rest = bytes;
        while !rest.is_empty() {
            let (r, more) = dec.next_message(rest);
            rest = more;
            if let Some(r) = r {
                out.push(r.unwrap());
            }
        }
        out
    }

    #[test]
    fn the_safe_frame_commands_zero_and_says_safe() {
        let mut buf = [0u8; MAX_FRAME];
        let frame = safe_frame(&mut buf).to_vec();
        assert_eq!(frame.last(), Some(&0));
        let msgs = decode_all(&frame);
        let [Message::Actuation(a)] = msgs.as_slice() else {
            panic!("{msgs:?}")
        };
        assert_eq!((a.t_psi_dnm, a.u_a_cv), (0, 0));
        assert!(a.flags.has(Flags::SAFE) && !a.flags.has(Flags::ENABLED));
    }

    /// The build script's constants are today's compilation of the default
    /// configuration, and the device built from them is the host's runtime, bit for bit.
    #[test]
    fn default_runtime_is_compiled() {
        let cfg = wheelset_runtime::RuntimeConfig::default();
        assert_eq!(
            RuntimeBits::try_new::<Num>(&cfg).unwrap(),
            DEFAULT_RUNTIME,
            "stale build-script output"
        );
        // The compile-time conversion is the validated one.
        assert_eq!(
            Compiled::from_bits(&DEFAULT_RUNTIME.control),
            Ok(DEFAULT_CORE)
        );
        let dev = new_runtime().unwrap();
        let host = FwRuntime::try_new(cfg).unwrap();
        assert_eq!(dev.core().compiled(), host.core().compiled());
        assert_eq!(dev.core().compiled().to_bits(), DEFAULT_RUNTIME.control);
        assert_eq!(DEFAULT_FINGERPRINT, DEFAULT_RUNTIME.control.fingerprint());
        // Both start alike: the same outputs on the same frames.
        let (mut dev, mut host) = (dev, host);
        for k in 1..=200u16 {
            let s = Sensor {
                seq: k,
                t_us: 0,
                lateral: Lateral::Velocity(i32::from(k) * 37 - 3_000),
                i_a_ma: 115_000,
                omega_m_mrad_s: 925_600,
                demand_nm: 2_460,
                v_ref_mm_s: 0,
            };
            let f = encode_vec(&Message::Sensor(s)).unwrap();
            dev.receive(&f);
            host.receive(&f);
            assert_eq!(dev.tick(0), host.tick(0), "tick {k}");
        }
    }

    #[test]
    fn the_device_interface_is_the_runtime() {
        let mut dev = new_runtime().unwrap();
        assert_eq!(dev.base_rate_hz(), wheelset_control::DEFAULT_BASE_RATE_HZ);
        let s = Sensor {
            seq: 41,
            omega_m_mrad_s: 925_600,
            ..Sensor::ZERO
        };
        let frame = encode_vec(&Message::Sensor(s)).unwrap();
        // Any chunking.
        let (a, b) = frame.split_at(3);
        dev.receive(a);
        dev.receive(b);
        let out = dev.tick(1234).to_vec();
        let msgs = decode_all(&out);
        let [Message::Actuation(a)] = msgs.as_slice() else {
            panic!("{msgs:?}")
        };
        assert_eq!(a.seq_echo, 41);
        assert_eq!(a.exec, 1234);
        assert!(a.flags.has(Flags::ENABLED));
    }
}
