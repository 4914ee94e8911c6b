//! What a run keeps: the output records, the run's info, the divergence rule.

use crate::plant::{ix, State};
use serde::Serialize;
use std::io::Write;

/// One output sample. CSV column names are in [`Record::COLUMNS`] (SI, unit suffix).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Record {
    /// Time, s.
    pub t_s: f64,
    /// Lateral displacement `y`, m.
    pub y_m: f64,
    /// Yaw angle `psi`, rad.
    pub psi_rad: f64,
    /// Total yaw torque on the wheelset `T_psi` (spring + actuator), N m, eq. 5 sign.
    pub t_psi_nm: f64,
    /// Right longitudinal creep force, N.
    pub fx_r_n: f64,
    /// Left longitudinal creep force, N.
    pub fx_l_n: f64,
    /// Lateral creep force per wheel, N.
    pub fy_n: f64,
    /// Forward speed, m/s.
    pub v_mps: f64,
    /// Armature current, A.
    pub i_a_a: f64,
    /// Armature voltage, V.
    pub u_a_v: f64,
    /// Lateral velocity relative to the track, m/s.
    pub yd_mps: f64,
    /// Actuator (control) part of the yaw torque, N m.
    pub t_ctrl_nm: f64,
    /// Passive spring part of the yaw torque `k_yaw psi`, N m.
    pub t_spring_nm: f64,
    /// Right wheel speed, rad/s.
    pub w_r_radps: f64,
    /// Left wheel speed, rad/s.
    pub w_l_radps: f64,
    /// Motor speed, rad/s.
    pub w_m_radps: f64,
    /// Axle twist, rad.
    pub twist_rad: f64,
    /// Gear wind-up, rad.
    pub wind_rad: f64,
    /// Current reference, A.
    pub i_ref_a: f64,
    /// Traction demand at the wheel, N m.
    pub demand_nm: f64,
    /// Running resistance, N.
    pub f_run_n: f64,
    /// Track curvature, 1/m.
    pub curvature_1pm: f64,
    /// Cant, rad.
    pub cant_rad: f64,
    /// Pure rolling line `r0 Lg / (lambda R)` for the current curvature, m.
    pub y0_m: f64,
    /// Longitudinal slip velocity of the wheelset, the mean of the two wheels'
    /// `v s_x` (`s_x` the creepage of eqs. 1-2: circumferential minus forward speed over
    /// `v`), m/s; + = the wheels turn faster than the vehicle runs (traction).
    pub slip_mps: f64,
    /// Adhesion available: the peak `F/Q` of the present rail condition's longitudinal
    /// characteristic at the present speed ([`crate::adhesion::Adhesion::peak`]); `inf`
    /// under the linear law (no limit).
    pub mu_avail: f64,
    /// Adhesion used: the traction coefficient `(F_xR + F_xL) / (2 Q)`.
    pub mu_used: f64,
}

impl Record {
    /// CSV header names, in the order of [`Record::values`].
    pub const COLUMNS: [&'static str; 27] = [
        "t_s",
        "y_m",
        "psi_rad",
        "T_psi_Nm",
        "Fx_R_N",
        "Fx_L_N",
        "Fy_N",
        "v_mps",
        "i_a_A",
        "u_a_V",
        "yd_mps",
        "T_ctrl_Nm",
        "T_spring_Nm",
        "w_R_radps",
        "w_L_radps",
        "w_m_radps",
        "twist_rad",
        "wind_rad",
        "i_ref_A",
        "demand_Nm",
        "F_run_N",
        "curvature_1pm",
        "cant_rad",
        "y0_m",
        "slip_mps",
        "mu_avail",
        "mu_used",
    ];

    /// The values in [`Record::COLUMNS`] order.
    pub fn values(&self) -> [f64; 27] {
        [
            self.t_s,
            self.y_m,
            self.psi_rad,
            self.t_psi_nm,
            self.fx_r_n,
            self.fx_l_n,
            self.fy_n,
            self.v_mps,
            self.i_a_a,
            self.u_a_v,
            self.yd_mps,
            self.t_ctrl_nm,
            self.t_spring_nm,
            self.w_r_radps,
            self.w_l_radps,
            self.w_m_radps,
            self.twist_rad,
            self.wind_rad,
            self.i_ref_a,
            self.demand_nm,
            self.f_run_n,
            self.curvature_1pm,
            self.cant_rad,
            self.y0_m,
            self.slip_mps,
            self.mu_avail,
            self.mu_used,
        ]
    }
}

/// What a run did, for reports.
#[derive(Debug, Clone, Serialize)]
pub struct RunInfo {
    /// Scenario name.
    pub scenario: String,
    /// Where the scenario came from.
    pub source: String,
    /// Control mode label (`passive`, `gain`, `lead`, or the sampled controller's).
    pub control: String,
    /// Integration step, s.
    pub dt_s: f64,
    /// Number of RK4 steps.
    pub steps: u64,
    /// Controller calls (sampled runs).
    pub controller_calls: u64,
    /// Actuator clamps counted (sampled runs).
    pub actuator_clamps: u64,
    /// Time at which the run was stopped because it diverged (a state not finite or
    /// `|y|` beyond [`DIVERGED_Y_M`]: an unstable loop), s; records end there.
    pub diverged_at_s: Option<f64>,
}

/// `|y|` beyond which a run counts as diverged (far outside the flange clearance and
/// the linear creep law), m.
pub const DIVERGED_Y_M: f64 = 0.05;

/// Whether state `x` has diverged (see [`RunInfo::diverged_at_s`]). By value, as
/// `Setup::record` takes the state.
pub(super) fn diverged(x: State) -> bool {
    !x.iter().all(|v| v.is_finite()) || x[ix::Y].abs() > DIVERGED_Y_M
}

/// A run's records and description.
#[derive(Debug, Clone)]
pub struct Trajectory {
    /// Samples at the scenario's output interval, first at t = 0, last at the end.
    pub records: Vec<Record>,
    /// Description.
    pub info: RunInfo,
}

impl Trajectory {
    /// Writes the CSV (header row [`Record::COLUMNS`], one row per record).
    pub fn write_csv<W: Write>(&self, w: W) -> std::io::Result<()> {
        self.write_csv_with(w, &[], |_, _| {})
    }

    /// [`Self::write_csv`] with the columns `extra` after the record's: `row(r, line)`
    /// appends each record's values to its line, each after a comma.
    pub fn write_csv_with<W: Write>(
        &self,
        mut w: W,
        extra: &[&str],
        mut row: impl FnMut(&Record, &mut String),
    ) -> std::io::Result<()> {
        use std::fmt::Write as _;
        let header: Vec<&str> = Record::COLUMNS.iter().chain(extra).copied().collect();
        writeln!(w, "{}", header.join(","))?;
        let mut line = String::with_capacity(600);
        for r in &self.records {
            line.clear();
            for (i, v) in r.values().iter().enumerate() {
                if i > 0 {
                    line.push(',');
                }
                let _ = write!(line, "{v:.9e}");
            }
            row(r, &mut line);
            writeln!(w, "{line}")?;
        }
        Ok(())
    }

    /// The record nearest to time `t_s`.
    pub fn at(&self, t_s: f64) -> Option<&Record> {
        self.records.iter().min_by(|a, b| {
            (a.t_s - t_s)
                .abs()
                .partial_cmp(&(b.t_s - t_s).abs())
                .unwrap_or(std::cmp::Ordering::Equal)
        })
    }
}
