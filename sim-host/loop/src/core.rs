//! The control core itself (`wheelset_control::Controller<T>`) on the plant without the
//! link: the device's laws and protection, its timing (tick `k` acts from `k + 1`) and
//! its wire quantisation of the inputs.

use crate::device_loop::control_config;
use crate::drive::drive;
use wheelset_control::{Controller, InputCodes, Inputs, SampleBits};
use wheelset_plant::control::{Actuation, Measurements, SampledController, YawLaw};
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::{SimError, Trajectory};
use wheelset_proto::units::{
    CURRENT_LSB_A, DEMAND_LSB_NM, LAT_VEL_LSB_M_PER_S, SPEED_LSB_RAD_PER_S, TORQUE_LSB_NM,
    VOLTAGE_LSB_V, V_REF_LSB_M_PER_S,
};

/// Which wire quantisations a [`CoreController`] applies (the device: [`Sources::WIRE`]);
/// the audit removes one at a time to attribute a limit cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sources {
    /// `y'` quantised to its wire LSB (else passed to the core exact, in per unit).
    pub y_wire: bool,
    /// The outputs quantised to their wire LSBs (else converted to SI exact).
    pub out_wire: bool,
}

impl Sources {
    /// Every input and output through its wire LSB, as the Sensor and Actuation frames.
    pub const WIRE: Sources = Sources {
        y_wire: true,
        out_wire: true,
    };
}

/// The core as a sampled controller: quantise to wire codes, tick, decode.
pub struct CoreController<T: SampleBits> {
    core: Controller<T>,
    cfg: wheelset_control::Config,
    period_ns: u64,
    src: Sources,
}

/// `round(x / lsb)` (half away from zero) saturated to the `i32` range, NaN to 0: an SI
/// value as the wire code the host's Sensor frame carries.
fn code(x: f64, lsb: f64) -> i32 {
    let c = (x / lsb).round();
    if c.is_nan() {
        0
    } else {
        c.clamp(i32::MIN as f64, i32::MAX as f64) as i32
    }
}

impl<T: SampleBits> CoreController<T> {
    /// The core of `cfg` (validated), protection on or off, every wire quantisation applied.
    pub fn try_new(
        cfg: &wheelset_control::Config,
        wsp: bool,
    ) -> Result<Self, wheelset_control::ConfigError> {
        let mut core = Controller::<T>::try_new(cfg)?;
        core.set_wsp(wsp);
        Ok(CoreController {
            core,
            cfg: *cfg,
            period_ns: 1_000_000_000 / u64::from(cfg.base_rate_hz),
            src: Sources::WIRE,
        })
    }

    /// The same core with the wire quantisations `src` (the audit's attribution).
    #[must_use]
    pub fn with_sources(mut self, src: Sources) -> Self {
        self.src = src;
        self
    }

    /// The core (counters, protection state).
    pub fn core(&self) -> &Controller<T> {
        &self.core
    }

    /// The slip regulator's set point `slip_sp + slip_sp_per_a cap`, m/s, if it acted last tick.
    pub fn wsp_set_point(&self) -> Option<f64> {
        let (sp, per_a) = (self.cfg.wsp.slip_sp_mps, self.cfg.wsp.slip_sp_per_a);
        let cap_a = self.core.wsp_state().cap.to_f64() * self.cfg.scales.current;
        self.core
            .tick_events()
            .wsp_acting()
            .then(|| sp + per_a * cap_a.max(0.0))
    }
}

impl<T: SampleBits> SampledController for CoreController<T> {
    fn period_ns(&self) -> u64 {
        self.period_ns
    }

    fn step(&mut self, _t_ns: u64, m: &Measurements) -> Actuation {
        self.core.set_v_ref_code(code(m.v_mps, V_REF_LSB_M_PER_S));
        let codes = InputCodes {
            y_dot: code(m.yd_mps, LAT_VEL_LSB_M_PER_S),
            current: code(m.i_a, CURRENT_LSB_A),
            speed: code(m.w_m, SPEED_LSB_RAD_PER_S),
            demand: code(m.demand_nm, DEMAND_LSB_NM),
        };
        let c = if self.src == Sources::WIRE {
            self.core.tick_codes(&codes)
        } else {
            let mut inp: Inputs<T> = self.core.compiled().codec().decode(&codes);
            if !self.src.y_wire {
                inp.y_dot = T::from_f64(m.yd_mps / self.cfg.scales.y_dot);
            }
            let out = self.core.tick(&inp);
            if !self.src.out_wire {
                let (t_psi, u_a) = out.to_si(&self.cfg.scales);
                return Actuation { t_psi, u_a };
            }
            self.core.compiled().codec().encode(&out)
        };
        Actuation {
            t_psi: f64::from(c.yaw_torque) * TORQUE_LSB_NM,
            u_a: f64::from(c.voltage) * VOLTAGE_LSB_V,
        }
    }
}

/// Why a core run could not start.
#[derive(Debug, Clone, PartialEq)]
pub enum CoreError {
    /// The scenario's parameters do not compile into a control core.
    Config(wheelset_control::ConfigError),
    /// The sampled run refused its timing.
    Sim(SimError),
}

impl std::fmt::Display for CoreError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CoreError::Config(e) => write!(f, "control core: {e}"),
            CoreError::Sim(e) => write!(f, "control core run: {e}"),
        }
    }
}

impl std::error::Error for CoreError {}

/// What a core run did besides its trajectory.
#[derive(Debug, Clone, PartialEq)]
pub struct CoreRun {
    /// Traction steps the protection acted on.
    pub wsp_ticks: u32,
    /// Times it started acting.
    pub wsp_events: u32,
    /// The slip regulator's set point `slip_sp + slip_sp_per_a cap` (`wheelset_control`'s
    /// `wsp`), `(t_s, m/s)` on each control tick the protection acted on (empty with
    /// the protection off): what the regulated slip is held to.
    pub set_point: Vec<(f64, f64)>,
}

/// Runs `sc` with the control core of sample type `T` (the scenario's parameters, yaw
/// law `law`, protection `wsp`), one base period of actuation delay.
pub fn run_core<T: SampleBits>(
    sc: &Scenario,
    law: YawLaw,
    wsp: bool,
) -> Result<(Trajectory, CoreRun), CoreError> {
    run_core_with::<T>(sc, &control_config(&sc.params, law, sc.drive), law, wsp)
}

/// [`run_core`] on the core of `cfg`, acting `cfg.delay_ticks` base periods after each sample.
pub fn run_core_with<T: SampleBits>(
    sc: &Scenario,
    cfg: &wheelset_control::Config,
    law: YawLaw,
    wsp: bool,
) -> Result<(Trajectory, CoreRun), CoreError> {
    let mut ctrl = CoreController::<T>::try_new(cfg, wsp).map_err(CoreError::Config)?;
    let label = format!("core {} wsp {}", T::NAME, if wsp { "on" } else { "off" });
    let mut set_point = Vec::new();
    let delay = u32::from(cfg.delay_ticks);
    let tr = drive(sc, &mut ctrl, delay, law.has_spring(), &label, |c, t, _| {
        if let Some(sp) = c.wsp_set_point() {
            set_point.push((t as f64 * 1e-9, sp));
        }
    })
    .map_err(CoreError::Sim)?;
    let c = ctrl.core.counters();
    Ok((
        tr,
        CoreRun {
            wsp_ticks: c.wsp_ticks,
            wsp_events: c.wsp_events,
            set_point,
        },
    ))
}
