//! The compiled controller: what the tick multiplies and compares with, discretised (f64)
//! and quantised for one sample type ([`Compiled::try_new`]), and its exact bits
//! ([`CompiledBits`]). The device never discretises: it starts from build-time bits and
//! takes a new rate as a host-computed [`ScheduleBits`], checked by [`CompiledBits::fingerprint`].

use crate::config::{Config, ConfigError, YawMode, MAX_LIMIT_PU};
use crate::controller::Codec;
use crate::lead::Lead;
use crate::pi::Pi;
use crate::sample::{Coef, Fx, FxScale, Sample, SampleBits};
use crate::wsp::{Wsp, WspBits};

mod const_bits;

pub(crate) use const_bits::{f32_value, fx_coeff, fx_signal};

/// The discretised, quantised controller for `T` (immutable while running); each field in
/// `T` is the [`CompiledBits`] or [`ScheduleBits`] field of that name (the clamps: `*_max`).
#[derive(Clone, Copy, Debug, PartialEq)]
// `repr(C)`, the fast path's constants in its read order: neighbours load as one `LDRD`.
#[repr(C)]
pub struct Compiled<T: Sample> {
    pub(crate) y_dot_max: T,
    pub(crate) predict_half: T::Coeff,
    pub(crate) y_dot_pred_max: T,
    pub(crate) lead: Lead<T>,
    pub(crate) torque_max: T,
    pub(crate) current_max: T,
    pub(crate) demand_max: T,
    pub(crate) demand_to_iref: T::Coeff,
    pub(crate) iref_step: T,
    pub(crate) pi: Pi<T>,
    pub(crate) gain: T::Coeff,
    pub(crate) speed_max: T,
    pub(crate) back_emf: T::Coeff,
    pub(crate) iref_safe_step: T,
    pub(crate) torque_step: T,
    pub(crate) yaw_divisor: u16,
    pub(crate) traction_divisor: u16,
    /// Not used by the tick.
    pub(crate) delay_ticks: u8,
    pub(crate) base_rate_hz: u32,
    pub(crate) codec: Codec<T>,
    pub(crate) yaw_mode: YawMode,
    pub(crate) traction_enabled: bool,
    pub(crate) wsp: Wsp<T>,
}

/// The exact bits of one wire-code scale ([`SampleBits::scale_to_bits`]): fixed point
/// `out = (in mul + 2^(shift-1)) >> shift`; floats `mul` = the IEEE bits, `shift` = 0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScaleBits {
    /// Multiplier (fixed point, in `[1024, 2^31)`) or the float's bits.
    pub mul: u64,
    /// Right shift (fixed point, `<= 62`), 0 for floats.
    pub shift: u8,
}

/// The rate-dependent part of a [`Compiled`] as exact bits ([`Sample`] bit patterns).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScheduleBits {
    /// Base (tick) rate, Hz (100 ..= 100 000).
    pub base_rate_hz: u32,
    /// The yaw loop runs every `yaw_divisor` ticks (>= 1).
    pub yaw_divisor: u16,
    /// The traction loop runs every `traction_divisor` ticks (>= 1).
    pub traction_divisor: u16,
    /// Ticks of delay the gains are designed for ([`crate::design`]; `>= 1`).
    pub delay_ticks: u8,
    /// Lead `kappa = 1 - alpha` at the yaw period, coefficient, in `(0, 1)`.
    pub kappa: u64,
    /// Lead `K_hf` (pu), coefficient: designed per rate and delay.
    pub lead_k_hf: u64,
    /// The wheel-slip protection's scheduled lead gain `lead_gain K_hf` (pu), coefficient.
    pub wsp_lead_k_hf: u64,
    /// PI `Kp` (pu), coefficient: designed per rate and delay.
    pub kp: u64,
    /// PI `Ki`'s shift `s` (`ki = Ki 2^s`): fixed point `1..=30`, floats 0.
    pub ki_shift: u8,
    /// PI `Ki = Kp T/Ti` at the traction period (pu) times `2^s`, coefficient, in `(0, 1)`.
    pub ki: u64,
    /// Predictor `alpha/2 = yaw_predict_ticks/(2 yaw_divisor)`, coefficient, in `[0, 1)`.
    pub predict_half: u64,
    /// Current-reference slew per traction step, pu signal, in `(0, 2]`.
    pub iref_step: u64,
    /// Its safe-state ramp per traction step, pu signal, in `(0, 2]`.
    pub iref_safe_step: u64,
    /// Torque-limit ramp per yaw step, pu signal, in `(0, 2]`.
    pub torque_step: u64,
}

/// A whole [`Compiled`] as exact bits: the firmware's build-time constants.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CompiledBits {
    /// The sample type ([`SampleBits::NUMERIC`]): 0 fixed point, 1 `f32`, 2 `f64`.
    pub numeric: u8,
    /// Lead `g/2`, coefficient.
    pub lead_g_half: u64,
    /// Pure gain `K` (pu), coefficient.
    pub gain: u64,
    /// PI lower output limit, pu signal.
    pub u_min: u64,
    /// PI upper output limit, pu signal.
    pub u_max: u64,
    /// Input clamps and the torque limit, pu in `(0, 2]`: `y'`, current, speed, demand, torque.
    pub clamps: [u64; 5],
    /// Demand pu -> current-reference pu, `scales.demand/(n K_m scales.current)`, coefficient.
    pub demand_to_iref: u64,
    /// Speed pu -> back-EMF pu, `K_m scales.speed/scales.voltage`, coefficient.
    pub back_emf: u64,
    /// Clamp of the predicted `y'` ([`MAX_LIMIT_PU`]), pu signal in `(0, 2]`.
    pub y_dot_pred_max: u64,
    /// The wire codec's scales: `y'`, current, speed, demand (in), torque, voltage (out).
    pub codec: [ScaleBits; 6],
    /// Yaw mode at start.
    pub yaw_mode: YawMode,
    /// Traction loop on at start.
    pub traction_enabled: bool,
    /// The rate-dependent part.
    pub schedule: ScheduleBits,
    /// Wheel-slip protection (rate-independent: its per-step quantities are ratios to `iref_step`).
    pub wsp: WspBits,
}

/// Why exact bits were refused: the field that is invalid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BitsError {
    /// The field ([`CompiledBits`] / [`ScheduleBits`] name).
    pub field: &'static str,
}

impl core::fmt::Display for BitsError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "compiled controller bits: `{}` is invalid for this sample type",
            self.field
        )
    }
}

impl core::error::Error for BitsError {}

impl<T: Sample> Compiled<T> {
    /// Validate `config`, discretise (f64), quantise for `T`; the device never calls it.
    pub fn try_new(config: &Config) -> Result<Self, ConfigError> {
        config.validate()?;
        let s = &config.scales;
        let l = &config.limits;
        let lead_disc = config.lead.discretise(config.yaw_period())?;
        let pi_disc = config.pi.discretise(config.traction_period())?;
        let lead = Lead::new(&lead_disc.to_pu(s.y_dot, s.torque))?;
        // Ki's shift depends on Kp, which a design sets per rate: part of the schedule.
        let pi_pu = pi_disc.to_pu(s.current, s.voltage);
        let t_tr = config.traction_period();
        let pi = Pi::with_ki_max(
            &pi_pu,
            pi_pu.ki * (crate::pi::KI_SHIFT_PERIOD_S.max(t_tr) / t_tr),
            l.voltage_min / s.voltage,
            l.voltage_max / s.voltage,
        )?;
        let q = crate::config::coeff::<T>;
        let iref_max = l.demand / (config.motor.n * config.motor.k_m) / s.current;
        Ok(Self {
            lead,
            gain: q("gain_k (pu)", config.gain_k * s.y_dot / s.torque)?,
            pi,
            y_dot_max: T::from_f64(l.y_dot / s.y_dot),
            current_max: T::from_f64(l.current / s.current),
            speed_max: T::from_f64(l.speed / s.speed),
            demand_max: T::from_f64(l.demand / s.demand),
            torque_max: T::from_f64(l.torque / s.torque),
            demand_to_iref: q(
                "demand_to_iref (pu)",
                s.demand / (config.motor.n * config.motor.k_m * s.current),
            )?,
            back_emf: q("back_emf K_m (pu)", config.motor.k_m * s.speed / s.voltage)?,
            predict_half: q(
                "yaw_predict_ticks/(2 yaw_divisor)",
                config.yaw_predict_ticks / (2.0 * config.yaw_divisor as f64),
            )?,
            y_dot_pred_max: T::from_f64(MAX_LIMIT_PU),
            iref_step: T::from_f64(l.current_ref_rate * config.traction_period() / s.current),
            iref_safe_step: T::from_f64(
                iref_max * config.traction_period() / config.safe.traction_s,
            ),
            torque_step: T::from_f64(l.torque / s.torque * config.yaw_period() / config.safe.yaw_s),
            yaw_divisor: config.yaw_divisor,
            traction_divisor: config.traction_divisor,
            delay_ticks: config.delay_ticks,
            base_rate_hz: config.base_rate_hz,
            codec: Codec::try_new(&config.wire, s)?,
            yaw_mode: config.yaw_mode,
            traction_enabled: config.traction_enabled,
            wsp: Wsp::try_new(
                &config.wsp,
                &config.motor,
                s,
                l,
                config.wire.speed,
                &config.lead,
            )?,
        })
    }

    /// Base (tick) rate, Hz.
    pub fn base_rate_hz(&self) -> u32 {
        self.base_rate_hz
    }
    /// The lead as quantised.
    pub fn lead(&self) -> &Lead<T> {
        &self.lead
    }
    /// The PI as quantised.
    pub fn pi(&self) -> &Pi<T> {
        &self.pi
    }
    /// The wire codec.
    pub fn codec(&self) -> &Codec<T> {
        &self.codec
    }
}

impl<T: SampleBits> Compiled<T> {
    /// The exact bits (integer work).
    pub fn to_bits(&self) -> CompiledBits {
        let c = |v: T::Coeff| T::coeff_to_bits64(v);
        let sc = |v: &T::Scale| {
            let (mul, shift) = T::scale_to_bits(v);
            ScaleBits { mul, shift }
        };
        let k = &self.codec;
        CompiledBits {
            numeric: T::NUMERIC,
            lead_g_half: c(self.lead.g_half),
            gain: c(self.gain),
            u_min: self.pi.u_min.to_bits64(),
            u_max: self.pi.u_max.to_bits64(),
            clamps: [
                self.y_dot_max.to_bits64(),
                self.current_max.to_bits64(),
                self.speed_max.to_bits64(),
                self.demand_max.to_bits64(),
                self.torque_max.to_bits64(),
            ],
            demand_to_iref: c(self.demand_to_iref),
            back_emf: c(self.back_emf),
            y_dot_pred_max: self.y_dot_pred_max.to_bits64(),
            codec: [
                sc(&k.y_dot),
                sc(&k.current),
                sc(&k.speed),
                sc(&k.demand),
                sc(&k.torque),
                sc(&k.voltage),
            ],
            yaw_mode: self.yaw_mode,
            traction_enabled: self.traction_enabled,
            schedule: self.schedule(),
            wsp: self.wsp.to_bits(),
        }
    }

    /// The rate-dependent part's exact bits.
    pub fn schedule(&self) -> ScheduleBits {
        ScheduleBits {
            base_rate_hz: self.base_rate_hz,
            yaw_divisor: self.yaw_divisor,
            traction_divisor: self.traction_divisor,
            delay_ticks: self.delay_ticks,
            kappa: T::coeff_to_bits64(self.lead.kappa),
            lead_k_hf: T::coeff_to_bits64(self.lead.k_hf),
            wsp_lead_k_hf: T::coeff_to_bits64(self.wsp.lead_k_hf),
            kp: T::coeff_to_bits64(self.pi.kp),
            ki_shift: self.pi.ki_shift as u8,
            ki: T::coeff_to_bits64(self.pi.ki),
            predict_half: T::coeff_to_bits64(self.predict_half),
            iref_step: self.iref_step.to_bits64(),
            iref_safe_step: self.iref_safe_step.to_bits64(),
            torque_step: self.torque_step.to_bits64(),
        }
    }

    /// From exact bits, validated (integer work): limits in `(0, 2]` pu, the schedule as
    /// [`Self::with_schedule`].
    pub fn from_bits(b: &CompiledBits) -> Result<Self, BitsError> {
        if b.numeric != T::NUMERIC {
            return Err(BitsError { field: "numeric" });
        }
        let coef = |field, v| T::coeff_from_bits64(v).ok_or(BitsError { field });
        let limit = |field, v| pu_limit::<T>(v).ok_or(BitsError { field });
        let scale =
            |field, s: ScaleBits| T::scale_from_bits(s.mul, s.shift).ok_or(BitsError { field });
        let [y_dot, current, speed, demand, torque] = b.clamps;
        let [sy, si, sw, sd, st, su] = b.codec;
        let u_min = T::from_bits64(b.u_min).ok_or(BitsError { field: "u_min" })?;
        let u_max = T::from_bits64(b.u_max).ok_or(BitsError { field: "u_max" })?;
        let m = T::MAX_LIMIT;
        if !(u_min < u_max && T::ZERO.sat_sub(m) <= u_min && u_max <= m) {
            return Err(BitsError {
                field: "u_min/u_max",
            });
        }
        let c = Self {
            lead: Lead {
                k_hf: Default::default(),
                g_half: coef("lead_g_half", b.lead_g_half)?,
                kappa: Default::default(),
            },
            gain: coef("gain", b.gain)?,
            pi: Pi {
                kp: Default::default(),
                ki: Default::default(),
                ki_shift: 0,
                u_min,
                u_max,
            },
            y_dot_max: limit("clamps.y_dot", y_dot)?,
            current_max: limit("clamps.current", current)?,
            speed_max: limit("clamps.speed", speed)?,
            demand_max: limit("clamps.demand", demand)?,
            torque_max: limit("clamps.torque", torque)?,
            demand_to_iref: coef("demand_to_iref", b.demand_to_iref)?,
            back_emf: coef("back_emf", b.back_emf)?,
            predict_half: Default::default(),
            y_dot_pred_max: limit("y_dot_pred_max", b.y_dot_pred_max)?,
            iref_step: T::ZERO,
            iref_safe_step: T::ZERO,
            torque_step: T::ZERO,
            yaw_divisor: 1,
            traction_divisor: 1,
            delay_ticks: 1,
            base_rate_hz: 0,
            codec: Codec {
                y_dot: scale("codec.y_dot", sy)?,
                current: scale("codec.current", si)?,
                speed: scale("codec.speed", sw)?,
                demand: scale("codec.demand", sd)?,
                torque: scale("codec.torque", st)?,
                voltage: scale("codec.voltage", su)?,
            },
            yaw_mode: b.yaw_mode,
            traction_enabled: b.traction_enabled,
            wsp: Wsp::from_bits(&b.wsp)?,
        };
        c.with_schedule(&b.schedule)
    }

    /// The same controller at other rates, validated (integer work): 100 ..= 100 000 Hz,
    /// divisors and delay >= 1, `kappa`, `Kp`, `Ki` in `(0, 1)`, `alpha/2` in `[0, 1)`, steps in `(0, 2]` pu.
    pub fn with_schedule(&self, s: &ScheduleBits) -> Result<Self, BitsError> {
        let e = |field| BitsError { field };
        if !(100..=100_000).contains(&s.base_rate_hz) {
            return Err(e("base_rate_hz"));
        }
        if s.yaw_divisor == 0 {
            return Err(e("yaw_divisor"));
        }
        if s.traction_divisor == 0 {
            return Err(e("traction_divisor"));
        }
        if s.delay_ticks == 0 {
            return Err(e("delay_ticks"));
        }
        let unit = |field, v, zero_ok| {
            T::coeff_from_bits64(v)
                .filter(|c| T::coeff_in_unit(*c, zero_ok))
                .ok_or(e(field))
        };
        let kappa = unit("kappa", s.kappa, false)?;
        let ki = unit("ki", s.ki, false)?;
        let kp = unit("kp", s.kp, false)?;
        let k_hf = T::coeff_from_bits64(s.lead_k_hf).ok_or(e("lead_k_hf"))?;
        let wsp_k_hf = T::coeff_from_bits64(s.wsp_lead_k_hf).ok_or(e("wsp_lead_k_hf"))?;
        let predict_half = unit("predict_half", s.predict_half, true)?;
        let mut c = *self;
        c.lead.kappa = kappa;
        c.lead.k_hf = k_hf;
        c.wsp.lead_k_hf = wsp_k_hf;
        c.pi.ki = ki;
        c.pi.kp = kp;
        c.pi.ki_shift = Some(u32::from(s.ki_shift))
            .filter(|k| T::acc_shift_ok(*k))
            .ok_or(e("ki_shift"))?;
        c.delay_ticks = s.delay_ticks;
        c.predict_half = predict_half;
        c.iref_step = pu_limit::<T>(s.iref_step).ok_or(e("iref_step"))?;
        c.iref_safe_step = pu_limit::<T>(s.iref_safe_step).ok_or(e("iref_safe_step"))?;
        c.torque_step = pu_limit::<T>(s.torque_step).ok_or(e("torque_step"))?;
        c.yaw_divisor = s.yaw_divisor;
        c.traction_divisor = s.traction_divisor;
        c.base_rate_hz = s.base_rate_hz;
        Ok(c)
    }
}

/// A positive per-unit limit or step, at most 2 pu.
fn pu_limit<T: SampleBits>(v: u64) -> Option<T> {
    T::from_bits64(v).filter(|x| *x > T::ZERO && *x <= T::MAX_LIMIT)
}

impl CompiledBits {
    /// A 32-bit FNV-1a hash of all but the schedule, start mode and traction (`const`).
    pub const fn fingerprint(&self) -> u32 {
        // Over slices by pattern (no index arithmetic): `const` has no iterators.
        const fn bytes(mut h: u32, mut rest: &[u8]) -> u32 {
            while let [b, tail @ ..] = rest {
                h = (h ^ *b as u32).wrapping_mul(0x0100_0193);
                rest = tail;
            }
            h
        }
        const fn word(h: u32, w: u64) -> u32 {
            bytes(h, &w.to_le_bytes())
        }
        const fn words(mut h: u32, mut rest: &[u64]) -> u32 {
            while let [w, tail @ ..] = rest {
                h = word(h, *w);
                rest = tail;
            }
            h
        }
        let mut h: u32 = 0x811c_9dc5;
        h = word(h, self.numeric as u64);
        let fields = [
            self.lead_g_half,
            self.gain,
            self.u_min,
            self.u_max,
            self.demand_to_iref,
            self.back_emf,
            self.y_dot_pred_max,
            self.wsp.slip_on,
            self.wsp.slip_accel,
            self.wsp.accel_ratio,
            self.wsp.cut,
            self.wsp.sp_half,
            self.wsp.sp_half_slope,
            self.wsp.kp,
            self.wsp.kp_shift as u64,
            self.wsp.ki,
            self.wsp.ki_shift as u64,
            self.wsp.lead_rho,
            self.wsp.v_ref.mul,
            self.wsp.v_ref.shift as u64,
        ];
        h = words(h, &fields);
        h = words(h, &self.clamps);
        let mut rest: &[ScaleBits] = &self.codec;
        while let [c, tail @ ..] = rest {
            h = word(h, c.mul);
            h = word(h, c.shift as u64);
            rest = tail;
        }
        h
    }
}
