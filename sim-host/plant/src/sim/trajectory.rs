//! What a run keeps: the output records, the run's info, the divergence rule.

use crate::plant::{ix, State};
use serde::Serialize;
use std::io::Write;

/// Declares [`Record`] from rows `field => "CSV column",` (each an `f64`, SI).
macro_rules! record {
    ($($(#[$doc:meta])* $field:ident => $col:literal,)*) => {
        /// One output sample. CSV column names are in [`Record::COLUMNS`] (SI, unit suffix).
        #[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
        pub struct Record {
            $($(#[$doc])* pub $field: f64,)*
        }

        impl Record {
            /// CSV header names, in the order of [`Record::values`].
            pub const COLUMNS: [&'static str; [$($col),*].len()] = [$($col),*];

            /// The values in [`Record::COLUMNS`] order.
            pub fn values(&self) -> [f64; Self::COLUMNS.len()] {
                [$(self.$field),*]
            }
        }
    };
}

record! {
    /// Time, s.
    t_s => "t_s",
    /// Lateral displacement `y`, m.
    y_m => "y_m",
    /// Yaw angle `psi`, rad.
    psi_rad => "psi_rad",
    /// Total yaw torque on the wheelset `T_psi` (spring + actuator), N m, eq. 5 sign.
    t_psi_nm => "T_psi_Nm",
    /// Right longitudinal creep force, N.
    fx_r_n => "Fx_R_N",
    /// Left longitudinal creep force, N.
    fx_l_n => "Fx_L_N",
    /// Lateral creep force per wheel, N.
    fy_n => "Fy_N",
    /// Forward speed, m/s.
    v_mps => "v_mps",
    /// Armature current, A.
    i_a_a => "i_a_A",
    /// Armature voltage, V.
    u_a_v => "u_a_V",
    /// Lateral velocity relative to the track, m/s.
    yd_mps => "yd_mps",
    /// Actuator (control) part of the yaw torque, N m.
    t_ctrl_nm => "T_ctrl_Nm",
    /// Passive spring part of the yaw torque `k_yaw psi`, N m.
    t_spring_nm => "T_spring_Nm",
    /// Right wheel speed, rad/s.
    w_r_radps => "w_R_radps",
    /// Left wheel speed, rad/s.
    w_l_radps => "w_L_radps",
    /// Motor speed, rad/s.
    w_m_radps => "w_m_radps",
    /// Axle twist, rad.
    twist_rad => "twist_rad",
    /// Gear wind-up, rad.
    wind_rad => "wind_rad",
    /// Current reference, A.
    i_ref_a => "i_ref_A",
    /// Traction demand at the wheel, N m.
    demand_nm => "demand_Nm",
    /// Running resistance, N.
    f_run_n => "F_run_N",
    /// Track curvature, 1/m.
    curvature_1pm => "curvature_1pm",
    /// Cant, rad.
    cant_rad => "cant_rad",
    /// Pure rolling line `r0 Lg / (lambda R)` for the current curvature, m.
    y0_m => "y0_m",
    /// Longitudinal slip velocity of the wheelset, the mean of the two wheels'
    /// `v s_x` (`s_x` the creepage of eqs. 1-2: circumferential minus forward speed over
    /// `v`), m/s; + = the wheels turn faster than the vehicle runs (traction).
    slip_mps => "slip_mps",
    /// Adhesion available: the peak `F/Q` of the present rail condition's longitudinal
    /// characteristic at the present speed ([`crate::adhesion::Adhesion::peak`]); `inf`
    /// under the linear law (no limit).
    mu_avail => "mu_avail",
    /// Adhesion used: the traction coefficient `(F_xR + F_xL) / (2 Q)`.
    mu_used => "mu_used",
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

/// Whether state `x` has diverged ([`RunInfo::diverged_at_s`]); by value, as `Setup::record`.
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
        let d = |r: &Record| (r.t_s - t_s).abs();
        self.records.iter().min_by(|a, b| d(a).total_cmp(&d(b)))
    }
}
