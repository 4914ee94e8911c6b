//! The JSON form of a case's sweep. The fields of every struct here (and of
//! [`ModeValue`], [`Crossing`]) are in alphabetical order, so serialized directly the
//! keys come out sorted, as a `serde_json::Value` map writes them.

use super::*;
use serde::Serialize;

/// JSON form of one point.
#[derive(Debug, Serialize)]
pub struct PointJson {
    /// `f11 = f22`, N.
    pub creep_n: f64,
    /// All eigenvalues `[re, im]` (including the structural zero).
    pub eigenvalues: Vec<[f64; 2]>,
    /// Named modes (structural zero excluded).
    pub modes: Vec<ModeValue>,
    /// Whether all modes are stable here (structural zero excluded).
    pub stable: bool,
    /// The structural zero eigenvalue `[re, im]` (excluded from verdicts).
    pub structural_zero: Option<[f64; 2]>,
}

/// JSON form of one case: [`CaseSweep`]'s fields, [`Case::id`] and [`Case::label`].
#[derive(Debug, Serialize)]
pub struct CaseJson {
    crossings: Vec<Crossing>,
    failed_points: Vec<f64>,
    id: &'static str,
    label: &'static str,
    /// Points, ascending creep.
    points: Vec<PointJson>,
    /// Stable at every point of the sweep (structural zero excluded).
    stable_everywhere: bool,
    states: Vec<&'static str>,
}

impl CaseSweep {
    /// The JSON form.
    pub fn to_json(&self) -> CaseJson {
        let names = self.mode_names();
        let points: Vec<PointJson> = (0..self.creep.len())
            .map(|k| {
                let modes = self.modes_named(&names, k);
                PointJson {
                    creep_n: self.creep[k],
                    eigenvalues: self.eig[k].iter().map(|l| [l.re, l.im]).collect(),
                    stable: modes.iter().all(|m| m.re < 0.0),
                    modes,
                    structural_zero: self.structural_zero(k).map(|l| [l.re, l.im]),
                }
            })
            .collect();
        CaseJson {
            id: self.case.id(),
            label: self.case.label(),
            states: self.states.clone(),
            stable_everywhere: points.iter().all(|p| p.stable),
            points,
            crossings: self.crossings.clone(),
            failed_points: self.failed_points.clone(),
        }
    }
}
