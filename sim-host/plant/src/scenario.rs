//! Track scenarios as data (`docs/model.md`, `docs/adhesion.md`; `sim-host/scenarios/`
//! built in): piecewise-linear track, traction and resistance steps, parameter overrides,
//! rail-condition sections (`dry` outside them), an actuator fault, integration settings.

use crate::adhesion::Condition;
use crate::control::YawLaw;
use crate::error::{from_toml, ConfigError};
use crate::fault::{ActuatorFault, RawActuatorFault};
use crate::params::Params;
use serde::Deserialize;
use std::path::Path;

mod track;
pub use track::{track_at, Knot, TrackCursor};

/// The built-in scenarios: `(name, TOML source)`.
pub const BUILTIN: &[(&str, &str)] = &[
    ("curve", include_str!("../../scenarios/curve.toml")),
    ("beating", include_str!("../../scenarios/beating.toml")),
    (
        "low-adhesion",
        include_str!("../../scenarios/low-adhesion.toml"),
    ),
    (
        "actuator-fault",
        include_str!("../../scenarios/actuator-fault.toml"),
    ),
];

/// Converts seconds to integer nanoseconds (rounded to nearest).
pub fn s_to_ns(t: f64) -> u64 {
    (t * 1e9).round() as u64
}

/// A step (or ramp) of a scalar input switched on at `t_on_ns` (default: no input).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepInput {
    /// Final value (SI).
    pub value: f64,
    /// Switch-on time, ns. Sampled at integrator step starts.
    pub t_on_ns: u64,
    /// Ramp duration, ns (0 = a step).
    pub ramp_ns: u64,
}

impl StepInput {
    /// Value at time `t_ns`: 0 before `t_on`, then a linear ramp to `value`.
    pub fn at(&self, t_ns: u64) -> f64 {
        if t_ns < self.t_on_ns {
            0.0
        } else if self.ramp_ns == 0 || t_ns >= self.t_on_ns + self.ramp_ns {
            self.value
        } else {
            self.value * (t_ns - self.t_on_ns) as f64 / self.ramp_ns as f64
        }
    }
}

/// Which mechanical model the run uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Axle {
    /// The two wheels are one body (`2 I_w`), no torsion.
    Rigid,
    /// Flexible axle: the wheels twist against each other through `k_t`.
    Flexible,
}

impl std::fmt::Display for Axle {
    /// `rigid` or `flexible`, as the scenario's `[plant] axle` key spells it.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Axle::Rigid => "rigid",
            Axle::Flexible => "flexible",
        })
    }
}

/// A validated scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Name (file stem or built-in name).
    pub name: String,
    /// Where it came from (`<builtin:curve>` or the path).
    pub source: String,
    /// Free text.
    pub description: String,
    /// Run length, ns.
    pub duration_ns: u64,
    /// Integration step, ns.
    pub dt_ns: u64,
    /// Output sampling interval, ns (a multiple of `dt_ns`).
    pub output_dt_ns: u64,
    /// Track knots, strictly increasing in time.
    pub track: Vec<Knot>,
    /// Traction demand at the wheel, N m (`n K_m i_ref`).
    pub traction: StepInput,
    /// Running resistance `F_run`, N.
    pub resistance: StepInput,
    /// Axle model.
    pub axle: Axle,
    /// Whether the traction drive is modelled (else the demand is a torque on the left wheel).
    pub drive: bool,
    /// Parameters after the scenario's overrides.
    pub params: Params,
    /// Rail-condition sections (sorted, disjoint); empty = the linear creep law.
    pub adhesion: Vec<AdhesionSection>,
    /// A yaw-actuator fault of the plant (`[actuator_fault]`), if any.
    pub actuator_fault: Option<ActuatorFault>,
    /// The yaw laws the scenario is meant for (its `laws` key); empty = every law.
    pub laws: Vec<YawLaw>,
}

/// One `[[adhesion]]` section: a rail condition on `[t0_ns, t1_ns)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdhesionSection {
    /// Start, ns.
    pub t0_ns: u64,
    /// End (exclusive), ns.
    pub t1_ns: u64,
    /// Rail condition.
    pub condition: Condition,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAdhesion {
    start_s: f64,
    end_s: f64,
    condition: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawKnot {
    t_s: f64,
    radius_m: Option<f64>,
    curvature_per_m: Option<f64>,
    #[serde(default)]
    cant_deg: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTraction {
    demand_nm: f64,
    t_on_s: f64,
    #[serde(default)]
    ramp_s: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawResistance {
    f_run_n: f64,
    t_on_s: f64,
    #[serde(default)]
    ramp_s: f64,
}

#[derive(Deserialize)]
#[serde(default, deny_unknown_fields)]
struct RawSim {
    dt_s: f64,
    output_dt_s: f64,
}

impl Default for RawSim {
    fn default() -> Self {
        RawSim {
            dt_s: 1e-4,
            output_dt_s: 1e-3,
        }
    }
}

#[derive(Deserialize)]
#[serde(default, deny_unknown_fields)]
struct RawPlant {
    axle: Axle,
    drive: bool,
}

impl Default for RawPlant {
    fn default() -> Self {
        RawPlant {
            axle: Axle::Flexible,
            drive: true,
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScenario {
    name: Option<String>,
    #[serde(default)]
    description: String,
    duration_s: f64,
    #[serde(default)]
    sim: RawSim,
    #[serde(default)]
    plant: RawPlant,
    #[serde(default)]
    track: Vec<RawKnot>,
    traction: Option<RawTraction>,
    resistance: Option<RawResistance>,
    params: Option<toml::Table>,
    #[serde(default)]
    adhesion: Vec<RawAdhesion>,
    actuator_fault: Option<RawActuatorFault>,
    laws: Option<Vec<String>>,
}

/// The `laws` list: each `passive`, `gain` or `lead`, at least one, no repeats.
fn parse_laws(file: &str, laws: &Option<Vec<String>>) -> Result<Vec<YawLaw>, ConfigError> {
    let Some(names) = laws else {
        return Ok(Vec::new());
    };
    check(
        !names.is_empty(),
        file,
        "laws",
        "an empty list: omit `laws` for a scenario meant for every law",
    )?;
    let mut out = Vec::with_capacity(names.len());
    for (i, n) in names.iter().enumerate() {
        let law = [YawLaw::Passive, YawLaw::Gain, YawLaw::Lead]
            .into_iter()
            .find(|l| l.name() == n);
        let reason = match law {
            None => format!("`{n}` is not a yaw law (passive, gain, lead)"),
            Some(l) if out.contains(&l) => format!("`{n}` is listed twice"),
            Some(l) => {
                out.push(l);
                continue;
            }
        };
        return Err(invalid(file, format!("laws[{i}]"), reason));
    }
    Ok(out)
}

fn invalid(file: &str, key: impl Into<String>, reason: impl Into<String>) -> ConfigError {
    ConfigError::Invalid {
        file: file.to_string(),
        key: key.into(),
        reason: reason.into(),
    }
}

fn check(
    ok: bool,
    file: &str,
    key: impl Into<String>,
    reason: impl Into<String>,
) -> Result<(), ConfigError> {
    if ok {
        Ok(())
    } else {
        Err(invalid(file, key, reason))
    }
}

/// `t` s as ns, refused outside `[0, max]` s.
pub(crate) fn time(file: &str, key: &str, t: f64, max: f64) -> Result<u64, ConfigError> {
    let ok = t.is_finite() && (0.0..=max).contains(&t);
    check(ok, file, key, format!("time {t} s is outside [0, {max}] s"))?;
    Ok(s_to_ns(t))
}

impl Scenario {
    /// Parses and validates a scenario from TOML text on `base` (`file` names it in errors).
    pub fn from_toml_str(src: &str, file: &str, base: &Params) -> Result<Scenario, ConfigError> {
        let raw: RawScenario = toml::from_str(src).map_err(|e| from_toml(file, src, &e))?;
        let duration_ns = time(file, "duration_s", raw.duration_s, 1e5)?;
        check(duration_ns > 0, file, "duration_s", "must be positive")?;
        let sim = raw.sim;
        let dt_ok = sim.dt_s.is_finite() && (1e-7..=1e-2).contains(&sim.dt_s);
        let reason = format!("{} s is outside [1e-7, 1e-2] s", sim.dt_s);
        check(dt_ok, file, "sim.dt_s", reason)?;
        let dt_ns = s_to_ns(sim.dt_s);
        let out_ns = time(file, "sim.output_dt_s", sim.output_dt_s, 1.0)?;
        let reason = format!(
            "{} s must be a positive multiple of sim.dt_s = {} s",
            sim.output_dt_s, sim.dt_s
        );
        let ok = out_ns > 0 && out_ns.is_multiple_of(dt_ns);
        check(ok, file, "sim.output_dt_s", reason)?;
        crate::memory::check_runs(duration_ns, out_ns, None, 1)
            .map_err(|r| invalid(file, "duration_s", r))?;
        let laws = parse_laws(file, &raw.laws)?;
        let plant = raw.plant;
        let mut track = Vec::with_capacity(raw.track.len());
        for (i, k) in raw.track.iter().enumerate() {
            let key = |k: &str| format!("track[{i}].{k}");
            let t_ns = time(file, &key("t_s"), k.t_s, 1e5)?;
            let rising = track.last().is_none_or(|prev: &Knot| t_ns > prev.t_ns);
            let reason = "knot times must be strictly increasing";
            check(rising, file, key("t_s"), reason)?;
            let curvature = match (k.radius_m, k.curvature_per_m) {
                (Some(_), Some(_)) => {
                    let reason = "give either radius_m or curvature_per_m, not both";
                    return Err(invalid(file, key("radius_m"), reason));
                }
                (Some(r), None) => {
                    let reason =
                        format!("{r} m: |R| must be at least 50 m (omit it for straight track)");
                    let ok = r.is_finite() && r.abs() >= 50.0;
                    check(ok, file, key("radius_m"), reason)?;
                    1.0 / r
                }
                (None, Some(c)) => {
                    let reason = format!("{c} 1/m is outside [-0.02, 0.02] 1/m");
                    let ok = c.is_finite() && c.abs() <= 0.02;
                    check(ok, file, key("curvature_per_m"), reason)?;
                    c
                }
                (None, None) => 0.0,
            };
            let cant = k.cant_deg;
            let reason = format!("{cant} deg is outside [-15, 15] deg");
            let ok = cant.is_finite() && cant.abs() <= 15.0;
            check(ok, file, key("cant_deg"), reason)?;
            track.push(Knot {
                t_ns,
                curvature,
                cant: k.cant_deg.to_radians(),
            });
        }
        let step = |key: &str, raw: Option<(f64, f64, f64)>, max: f64| {
            let Some((value, t_on, ramp)) = raw else {
                return Ok(StepInput::default());
            };
            let reason = format!("{value} is outside [-{max}, {max}]");
            check(value.is_finite() && value.abs() <= max, file, key, reason)?;
            let table = key.split('.').next().unwrap_or(key);
            Ok(StepInput {
                value,
                t_on_ns: time(file, &format!("{table}.t_on_s"), t_on, 1e5)?,
                ramp_ns: time(file, &format!("{table}.ramp_s"), ramp, 1e5)?,
            })
        };
        let traction = raw.traction.map(|t| (t.demand_nm, t.t_on_s, t.ramp_s));
        let traction = step("traction.demand_nm", traction, 1e5)?;
        let resistance = raw.resistance.map(|r| (r.f_run_n, r.t_on_s, r.ramp_s));
        let resistance = step("resistance.f_run_n", resistance, 1e6)?;
        let params = (raw.params.as_ref())
            .map_or_else(|| Ok(base.clone()), |t| base.with_overrides(t, file))
            .map_err(|e| e.under("params"))?;
        let mut adhesion: Vec<AdhesionSection> = Vec::with_capacity(raw.adhesion.len());
        for (i, a) in raw.adhesion.iter().enumerate() {
            let key = |k: &str| format!("adhesion[{i}].{k}");
            let t0_ns = time(file, &key("start_s"), a.start_s, 1e5)?;
            let t1_ns = time(file, &key("end_s"), a.end_s, 1e5)?;
            let reason = format!("{} s must be after start_s = {} s", a.end_s, a.start_s);
            check(t1_ns > t0_ns, file, key("end_s"), reason)?;
            let sorted = adhesion.last().is_none_or(|prev| t0_ns >= prev.t1_ns);
            let reason = "sections must be sorted and must not overlap";
            check(sorted, file, key("start_s"), reason)?;
            let condition = Condition::from_name(&a.condition).ok_or_else(|| {
                let reason = format!("`{}` is not a rail condition (dry, wet, low)", a.condition);
                invalid(file, key("condition"), reason)
            })?;
            adhesion.push(AdhesionSection {
                t0_ns,
                t1_ns,
                condition,
            });
        }
        let actuator_fault = (raw.actuator_fault.as_ref())
            .map(|f| f.validate(file, raw.duration_s))
            .transpose()?;
        let name = raw.name.unwrap_or_else(|| {
            Path::new(file)
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| file.to_string())
        });
        Ok(Scenario {
            name,
            source: file.to_string(),
            description: raw.description,
            duration_ns,
            dt_ns,
            output_dt_ns: out_ns,
            track,
            traction,
            resistance,
            axle: plant.axle,
            drive: plant.drive,
            params,
            adhesion,
            actuator_fault,
            laws,
        })
    }

    /// Loads `name_or_path`: a built-in scenario ([`BUILTIN`]) or a TOML file.
    pub fn load(name_or_path: &str, base: &Params) -> Result<Scenario, ConfigError> {
        if let Some((name, src)) = BUILTIN.iter().find(|(n, _)| *n == name_or_path) {
            return Self::from_toml_str(src, &format!("<builtin:{name}>"), base);
        }
        let path = Path::new(name_or_path);
        if !path.exists() {
            return Err(ConfigError::UnknownScenario {
                name: name_or_path.to_string(),
                builtin: BUILTIN.iter().map(|(n, _)| *n).collect(),
            });
        }
        let src = crate::input::read_input(path)?;
        Self::from_toml_str(&src, name_or_path, base)
    }

    /// The rail condition at `t_ns`: `None` without `[[adhesion]]` sections, else the
    /// section's, `dry` outside every section. Inlined: the runs ask every step.
    #[inline]
    pub fn condition_at(&self, t_ns: u64) -> Option<Condition> {
        let section = self
            .adhesion
            .iter()
            .find(|s| (s.t0_ns..s.t1_ns).contains(&t_ns));
        (!self.adhesion.is_empty()).then(|| section.map_or(Condition::Dry, |s| s.condition))
    }

    /// The warning before running with a `law` that the scenario's `laws` key does not list.
    pub fn law_warning(&self, law: YawLaw) -> Option<String> {
        if self.laws.is_empty() || self.laws.contains(&law) {
            return None;
        }
        Some(format!(
            "scenario {} is meant for --control {} (its `laws`), not {}: expect a result outside what it was made to show{}",
            self.name,
            self.laws.iter().map(|l| l.name()).collect::<Vec<_>>().join(" or "),
            law.name(),
            if self.description.is_empty() {
                String::new()
            } else {
                format!(" ({})", self.description)
            }
        ))
    }
}
