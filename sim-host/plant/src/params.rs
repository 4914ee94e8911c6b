//! Physical and controller parameters of the wheelset, its drive and the reference
//! controllers, SI, with the paper's defaults (`docs/model.md`). A TOML table may
//! override any subset; unknown keys and out-of-range values are a [`ConfigError`].

use crate::error::{from_toml, ConfigError};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The wheelset, drive and controller parameters. Field names are the TOML keys.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Wheelset mass `m`, kg.
    pub m: f64,
    /// Vehicle mass `m_v`, kg (eq. 8 carries `m_v / 2`).
    pub m_v: f64,
    /// Wheelset yaw inertia `J`, kg m^2.
    pub j: f64,
    /// Rotational inertia of one wheel `I_w`, kg m^2 (the rigid axle has `2 I_w`).
    pub i_w: f64,
    /// Motor rotor inertia `I_m`, kg m^2.
    pub i_m: f64,
    /// Longitudinal creep coefficient `f11`, N.
    pub f11: f64,
    /// Lateral creep coefficient `f22`, N (per wheel).
    pub f22: f64,
    /// Lateral damping per wheelset `c_lat`, N s/m.
    pub c_lat: f64,
    /// Lateral stiffness `k_lat`, N/m (not given by the paper; default 0).
    pub k_lat: f64,
    /// Passive yaw stiffness `k_yaw`, N m/rad: `T_psi = k_yaw psi` (passive mode only).
    pub k_yaw: f64,
    /// Axle torsion frequency, Hz, used when `k_t` is absent:
    /// `k_t = I_w (2 pi f)^2 / 2` (the two wheels against each other).
    pub torsion_hz: f64,
    /// Axle torsional stiffness `k_t`, N m/rad; overrides `torsion_hz`.
    pub k_t: Option<f64>,
    /// Motor-on-gear frequency (wheel held), Hz, used when `k_gear` is absent:
    /// `k_gear = n^2 I_m (2 pi f)^2`.
    pub gear_hz: f64,
    /// Gear (transmission) stiffness `k_gear`, N m/rad at the wheel; overrides `gear_hz`.
    pub k_gear: Option<f64>,
    /// Half gauge `Lg`, m.
    pub l_g: f64,
    /// Wheel rolling radius `r0`, m.
    pub r0: f64,
    /// Effective conicity `lambda`, dimensionless.
    pub lambda: f64,
    /// Gravity `g`, m/s^2.
    pub g: f64,
    /// Forward speed `v`, m/s: the initial speed of a run and the linearisation speed.
    pub v: f64,
    /// Gear ratio `n` (motor turns per wheel turn).
    pub n_gear: f64,
    /// Motor constant `K_m`, V s/rad = N m/A.
    pub k_m: f64,
    /// Armature inductance `L_a`, H.
    pub l_a: f64,
    /// Armature resistance `R_a`, ohm.
    pub r_a: f64,
    /// Active yaw damping gain `K`, N m s/m: `T_psi = K y'` (pure gain).
    pub k_active: f64,
    /// Phase-lead high-frequency factor `a` in `Ks(s) = K a (s + z)/(s + p)` (7.5).
    pub lead_gain: f64,
    /// Phase-lead zero `z`, rad/s (37).
    pub lead_zero: f64,
    /// Phase-lead pole `p`, rad/s (274).
    pub lead_pole: f64,
    /// Traction PI proportional gain `Kp`, V/A: `Kt(s) = Kp (1 + 1/(Ti s))`.
    pub pi_kp: f64,
    /// Traction PI integral time `Ti`, s (0.5 from `Kt = (0.5 s + 1)/(0.5 s)`; the
    /// appendix lists 0.05).
    pub pi_ti: f64,
    /// Vertical wheel load `Q` per wheel, N, for the adhesion law (absent: [`Params::q`]).
    pub q: Option<f64>,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            m: 1250.0,
            m_v: 20_000.0,
            j: 600.0,
            i_w: 35.0,
            i_m: 11.0,
            f11: 10e6,
            f22: 10e6,
            c_lat: 24e3,
            k_lat: 0.0,
            k_yaw: 4.7e6,
            torsion_hz: 40.0,
            k_t: None,
            gear_hz: 20.0,
            k_gear: None,
            l_g: 0.7,
            r0: 0.45,
            lambda: 0.2,
            g: 9.81,
            v: 83.3,
            n_gear: 5.0,
            k_m: 4.28,
            l_a: 4e-4,
            r_a: 0.04,
            k_active: 1.05e5,
            lead_gain: 7.5,
            lead_zero: 37.0,
            lead_pole: 274.0,
            pi_kp: 1.0,
            pi_ti: 0.5,
            q: None,
        }
    }
}

/// The plausible range of one parameter: values outside `[min, max]` are refused by
/// [`Params::validate`] with `why`; `docs/model.md` prints the rows (a test compares).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    /// The TOML key.
    pub key: &'static str,
    /// SI unit of the value (`1` for a pure number).
    pub unit: &'static str,
    /// Smallest accepted value (inclusive).
    pub min: f64,
    /// Largest accepted value (inclusive).
    pub max: f64,
    /// Why these bounds: what is physically plausible, and what breaks outside.
    pub why: &'static str,
}

/// Declares [`RANGES`] from rows `key, unit, min, max, why;` (one row per parameter).
macro_rules! ranges {
    ($($key:ident, $unit:literal, $min:literal, $max:literal, $why:literal;)*) => {
        /// Plausible range of every parameter (SI), in the struct's order: physical
        /// limits with a generous margin (light rail to heavy freight, 0.1 m/s to the
        /// speed record); outside them the linear algebra is meaningless (`l_a = 1e-61` H
        /// puts `R_a / L_a = 4e59` 1/s in the plant matrix).
        pub const RANGES: &[Range] = &[$(Range {
            key: stringify!($key),
            unit: $unit,
            min: $min,
            max: $max,
            why: $why,
        }),*];
    };
}

#[rustfmt::skip]
ranges! {
    m, "kg", 100.0, 1e4, "a wheelset: light rail ~500 kg, heavy freight ~2.5 t";
    m_v, "kg", 0.0, 2e6, "vehicle (or hauled train) mass per driven wheelset; 0 = none; a heavy train ~2000 t on 4 driven axles is 5e5";
    j, "kg m^2", 10.0, 1e4, "wheelset yaw inertia ~ m Lg^2 (600 at 1.25 t)";
    i_w, "kg m^2", 1.0, 1000.0, "one wheel (with its half axle): 20-100 kg m^2";
    i_m, "kg m^2", 0.01, 1000.0, "motor rotor: 1-50 kg m^2 for traction motors";
    f11, "N", 1e5, 1e8, "Kalker coefficient: 1-10 MN for 5-20 t wheel loads; 0.1 MN = severely reduced adhesion";
    f22, "N", 1e5, 1e8, "as f11";
    c_lat, "N s/m", 0.0, 1e7, "lateral (primary) damping: 0-100 kN s/m typical";
    k_lat, "N/m", 0.0, 1e9, "lateral (primary) stiffness: 0-10 MN/m typical";
    k_yaw, "N m/rad", 0.0, 1e9, "passive yaw stiffness: 1-20 MN m/rad typical";
    torsion_hz, "Hz", 1.0, 1000.0, "axle torsion mode: 30-100 Hz for solid axles";
    k_t, "N m/rad", 1000.0, 1e10, "axle torsional stiffness: ~1e6-1e8 N m/rad";
    gear_hz, "Hz", 1.0, 1000.0, "motor-on-gear mode (wheel held): 5-100 Hz";
    k_gear, "N m/rad", 1000.0, 1e10, "gear stiffness at the wheel: ~1e5-1e8 N m/rad";
    l_g, "m", 0.3, 1.0, "half gauge: 600 mm narrow gauge to 1676 mm broad gauge, contact points";
    r0, "m", 0.2, 0.8, "wheel rolling radius: tram 0.3 m to locomotive 0.63 m";
    lambda, "1", 0.01, 1.0, "effective conicity: new profiles 0.05-0.4, worn up to ~0.8";
    g, "m/s^2", 1.0, 20.0, "gravity: 9.78-9.83 on Earth; other values only to study the gravitational stiffness";
    v, "m/s", 0.1, 160.0, "forward speed: standstill excluded (the model divides by v) to the 160 m/s record";
    n_gear, "1", 1.0, 20.0, "traction gear ratio: 2-8 typical";
    k_m, "N m/A", 0.1, 100.0, "motor constant (= V s/rad): 1-10 typical";
    l_a, "H", 1e-5, 1.0, "armature inductance: 0.1-10 mH; below 10 uH the armature pole is past any sampling rate";
    r_a, "ohm", 0.0, 10.0, "armature resistance: 10-100 mOhm typical; 0 = ideal";
    k_active, "N m s/m", 0.0, 1e7, "active yaw damping gain: the paper's 1.05e5 with two decades of margin";
    lead_gain, "1", 1.0, 100.0, "phase-lead high-frequency factor a >= 1 (the paper: 7.5)";
    lead_zero, "rad/s", 0.1, 1e4, "phase-lead zero (the paper: 37 rad/s)";
    lead_pole, "rad/s", 0.1, 1e5, "phase-lead pole (the paper: 274 rad/s)";
    pi_kp, "V/A", 1e-3, 1000.0, "traction PI proportional gain (the paper: 1 V/A)";
    pi_ti, "s", 1e-4, 100.0, "traction PI integral time (the paper: 0.5 s)";
    q, "N", 1e3, 5e5, "vertical wheel load: a light tram ~20 kN to a 35 t freight axle ~170 kN per wheel";
}

/// `v` for messages: plain between 1e-3 and 1e6, else in exponent form (`1e-61`).
fn num(v: f64) -> String {
    if v == 0.0 || !v.is_finite() || (1e-3..1e6).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

impl Params {
    /// Axle torsional stiffness `k_t`, N m/rad (explicit, or from `torsion_hz`).
    pub fn k_t(&self) -> f64 {
        self.k_t
            .unwrap_or_else(|| self.i_w * (2.0 * PI * self.torsion_hz).powi(2) / 2.0)
    }

    /// Gear stiffness `k_gear`, N m/rad (explicit, or from `gear_hz`).
    pub fn k_gear(&self) -> f64 {
        self.k_gear.unwrap_or_else(|| {
            self.n_gear * self.n_gear * self.i_m * (2.0 * PI * self.gear_hz).powi(2)
        })
    }

    /// Pure rolling line `y0 = r0 Lg / (lambda R)` for curvature `1/R`, m.
    pub fn pure_rolling_y(&self, curvature: f64) -> f64 {
        self.r0 * self.l_g * curvature / self.lambda
    }

    /// Kinematic (Klingel) frequency of the free rigid wheelset,
    /// `v sqrt(lambda / (r0 Lg)) / 2 pi`, Hz.
    pub fn kinematic_hz(&self) -> f64 {
        self.v * (self.lambda / (self.r0 * self.l_g)).sqrt() / (2.0 * PI)
    }

    /// Wheel load `Q`, N (explicit, or `(m + m_v/2) g / 2`).
    pub fn q(&self) -> f64 {
        self.q
            .unwrap_or_else(|| (self.m + self.m_v / 2.0) * self.g / 2.0)
    }

    /// The values with their keys, in [`RANGES`] order (for reports and validation);
    /// `k_t`, `k_gear` and `q` as used (explicit or derived).
    pub fn entries(&self) -> Vec<(&'static str, f64)> {
        // Every field is an f64 or an Option<f64>: the table cannot fail to build.
        let table = toml::Table::try_from(self).unwrap_or_default();
        let value = |key| match key {
            "k_t" => self.k_t(),
            "k_gear" => self.k_gear(),
            "q" => self.q(),
            _ => table
                .get(key)
                .and_then(toml::Value::as_float)
                .unwrap_or(f64::NAN),
        };
        RANGES.iter().map(|r| (r.key, value(r.key))).collect()
    }

    /// Checks every value against its plausible range ([`RANGES`]).
    pub fn validate(&self) -> Result<(), ConfigError> {
        // The values as given first, then the stiffnesses derived from them, so a bad
        // `n_gear` is named as such rather than through `k_gear`.
        let from = |key: &str| match (key, self.k_t, self.k_gear, self.q) {
            ("k_t", None, _, _) => " (derived from i_w and torsion_hz)",
            ("k_gear", _, None, _) => " (derived from n_gear, i_m and gear_hz)",
            ("q", _, _, None) => " (derived from m, m_v and g)",
            _ => "",
        };
        let entries = self.entries();
        let (given, derived): (Vec<_>, Vec<_>) = RANGES
            .iter()
            .zip(&entries)
            .partition(|(r, _)| from(r.key).is_empty());
        for (r, &(key, value)) in given.into_iter().chain(derived) {
            if !value.is_finite() || value < r.min || value > r.max {
                return Err(ConfigError::Invalid {
                    file: String::new(),
                    key: key.to_string(),
                    reason: format!(
                        "value {}{} is outside the plausible range [{}, {}] {}: {}",
                        num(value),
                        from(key),
                        num(r.min),
                        num(r.max),
                        r.unit,
                        r.why
                    ),
                });
            }
        }
        Ok(())
    }

    /// Parses a parameter table (every key optional) and validates it.
    pub fn from_toml_str(src: &str, file: &str) -> Result<Params, ConfigError> {
        let p: Params = toml::from_str(src).map_err(|e| from_toml(file, src, &e))?;
        p.validate().map_err(|e| e.with_file(file))?;
        Ok(p)
    }

    /// Reads and validates a parameter file.
    pub fn from_file(path: &std::path::Path) -> Result<Params, ConfigError> {
        let file = path.display().to_string();
        let src = crate::input::read_input(path)?;
        Self::from_toml_str(&src, &file)
    }

    /// Applies a TOML table of overrides on top of `self` (unknown keys refused), validated.
    pub fn with_overrides(&self, table: &toml::Table, file: &str) -> Result<Params, ConfigError> {
        let parse = |reason: String| ConfigError::Parse {
            file: file.to_string(),
            key: None,
            line: None,
            reason,
        };
        let mut base = toml::Table::try_from(self).map_err(|e| parse(e.to_string()))?;
        base.extend(table.clone());
        let src = toml::to_string(table).unwrap_or_default();
        // Check the override table alone first, so an unknown key is reported as such.
        let _: Params = toml::from_str(&src).map_err(|e| {
            let mut err = from_toml(file, &src, &e);
            if let ConfigError::Parse { line, .. } = &mut err {
                *line = None; // lines refer to the re-serialised table, not the file
            }
            err
        })?;
        let p: Params = base
            .try_into()
            .map_err(|e: toml::de::Error| parse(e.message().to_string()))?;
        p.validate().map_err(|e| e.with_file(file))?;
        Ok(p)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_derived_values_match_spec() {
        let p = Params::default();
        assert!(p.validate().is_ok());
        // k_gear = n^2 I_m (2 pi 20)^2 = 4.34e6 (spec table).
        assert!(
            (p.k_gear() - 4.34e6).abs() / 4.34e6 < 2e-3,
            "{}",
            p.k_gear()
        );
        // y0 = 0.685 mm at R = 2300 m.
        let y0 = p.pure_rolling_y(1.0 / 2300.0);
        assert!((y0 - 0.685e-3).abs() < 0.001e-3, "{y0}");
        // back-EMF at 83.3 m/s: about 3961 V.
        assert!((p.k_m * p.n_gear * p.v / p.r0 - 3961.0).abs() < 2.0);
    }

    #[test]
    fn unknown_key_and_bad_range_are_named() {
        let e = Params::from_toml_str("f11 = 1e7\nfoo = 3\n", "p.toml").unwrap_err();
        assert_eq!(e.key(), Some("foo"), "{e}");
        assert!(e.to_string().starts_with("p.toml:"), "{e}");
        let e = Params::from_toml_str("lambda = -0.2\n", "p.toml").unwrap_err();
        assert_eq!(e.key(), Some("lambda"), "{e}");
        let e = Params::from_toml_str("r0 = \"big\"\n", "p.toml").unwrap_err();
        assert!(matches!(e, ConfigError::Parse { .. }), "{e}");
        let e = Params::from_toml_str("v = nan\n", "p.toml").unwrap_err();
        assert_eq!(e.key(), Some("v"), "{e}");
    }
}
