//! The JSON form of a case's sweep. The fields of every struct here (and of
//! [`ModeValue`], [`Crossing`]) are in alphabetical order, so serialized directly the
//! keys come out sorted, as a `serde_json::Value` map writes them.

use super::*;
use serde::Serialize;
use serde_json::ser::{CompactFormatter, Formatter};
use std::io::{self, Write};

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

/// JSON form of one case.
#[derive(Debug, Serialize)]
pub struct CaseJson {
    /// Instability crossings.
    pub crossings: Vec<Crossing>,
    /// Creep values where the eigenvalue solver failed.
    pub failed_points: Vec<f64>,
    /// `a`..`d`.
    pub id: &'static str,
    /// Description.
    pub label: &'static str,
    /// Points, ascending creep.
    pub points: Vec<PointJson>,
    /// Stable at every point of the sweep (structural zero excluded).
    pub stable_everywhere: bool,
    /// Closed-loop states.
    pub states: Vec<&'static str>,
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

impl CaseSweep {
    /// Writes [`Self::to_json`] as compact JSON to `w`: byte for byte what
    /// `serde_json::to_writer` writes, without building the points.
    pub fn write_json<W: Write + ?Sized>(&self, w: &mut W) -> io::Result<()> {
        w.write_all(b"{\"crossings\":[")?;
        for (i, c) in self.crossings.iter().enumerate() {
            if i > 0 {
                w.write_all(b",")?;
            }
            w.write_all(b"{\"creep_n\":")?;
            write_json_number(w, c.creep_n)?;
            w.write_all(b",\"freq_hz\":")?;
            write_json_number(w, c.freq_hz)?;
            w.write_all(b",\"mode\":")?;
            write_json_string(w, &c.mode)?;
            w.write_all(if c.unstable_below {
                b",\"unstable_below\":true}"
            } else {
                b",\"unstable_below\":false}"
            })?;
        }
        w.write_all(b"],\"failed_points\":[")?;
        for (i, &c) in self.failed_points.iter().enumerate() {
            if i > 0 {
                w.write_all(b",")?;
            }
            write_json_number(w, c)?;
        }
        w.write_all(b"],\"id\":")?;
        write_json_string(w, self.case.id())?;
        w.write_all(b",\"label\":")?;
        write_json_string(w, self.case.label())?;
        w.write_all(b",\"points\":[")?;
        // Each mode's branches once for the case, and the text between its `im` and `re`.
        let mut modes: Vec<(Vec<u8>, Vec<usize>)> = Vec::new();
        for n in self.mode_names() {
            let b = (0..self.branch_names.len())
                .filter(|&b| self.branch_names[b] == n)
                .collect();
            let mut text = b",\"name\":".to_vec();
            write_json_string(&mut text, &n)?;
            text.extend_from_slice(b",\"re\":");
            modes.push((text, b));
        }
        let zero = self.branch_names.iter().position(|n| n == STRUCTURAL_ZERO);
        let mut stable_everywhere = true;
        // Each point is formatted into `buf` and reaches `w` in one write; a mode's `re`
        // and `im` and the structural zero are copied from the eigenvalues' text (`spans`).
        let mut buf: Vec<u8> = Vec::with_capacity(1024);
        let mut spans: Vec<PairSpan> = Vec::new();
        for (k, eig) in self.eig.iter().enumerate() {
            buf.clear();
            spans.clear();
            if k > 0 {
                buf.push(b',');
            }
            buf.extend_from_slice(b"{\"creep_n\":");
            write_json_number(&mut buf, self.creep[k])?;
            buf.extend_from_slice(b",\"eigenvalues\":[");
            for (i, l) in eig.iter().enumerate() {
                if i > 0 {
                    buf.push(b',');
                }
                let open = buf.len();
                buf.push(b'[');
                write_json_number(&mut buf, l.re)?;
                let comma = buf.len();
                buf.push(b',');
                write_json_number(&mut buf, l.im)?;
                let close = buf.len();
                buf.push(b']');
                spans.push(PairSpan { open, comma, close });
            }
            buf.extend_from_slice(b"],\"modes\":[");
            let mut stable = true;
            let mut first = true;
            for (name_text, branches) in &modes {
                // The least stable branch, as `mode_eig` picks it.
                let Some((b, l)) = branches
                    .iter()
                    .map(|&b| (b, eig[b]))
                    .max_by(|x, y| x.1.re.total_cmp(&y.1.re).then(x.1.im.total_cmp(&y.1.im)))
                else {
                    continue;
                };
                if !first {
                    buf.push(b',');
                }
                first = false;
                let m = ModeNumbers::new(l);
                stable &= m.re < 0.0;
                let span = spans[b];
                buf.extend_from_slice(b"{\"freq_hz\":");
                write_json_number(&mut buf, m.freq_hz)?;
                buf.extend_from_slice(b",\"im\":");
                let im = span.comma + 1;
                let im = if buf[im] == b'-' { im + 1 } else { im };
                buf.extend_from_within(im..span.close);
                buf.extend_from_slice(name_text);
                buf.extend_from_within(span.open + 1..span.comma);
                buf.extend_from_slice(b",\"zeta\":");
                write_json_number(&mut buf, m.zeta)?;
                buf.push(b'}');
            }
            stable_everywhere &= stable;
            buf.extend_from_slice(if stable {
                b"],\"stable\":true,\"structural_zero\":"
            } else {
                b"],\"stable\":false,\"structural_zero\":"
            });
            match zero {
                Some(b) => {
                    let span = spans[b];
                    buf.extend_from_within(span.open..span.close + 1);
                }
                None => buf.extend_from_slice(b"null"),
            }
            buf.push(b'}');
            w.write_all(&buf)?;
        }
        w.write_all(if stable_everywhere {
            b"],\"stable_everywhere\":true,\"states\":["
        } else {
            b"],\"stable_everywhere\":false,\"states\":["
        })?;
        for (i, s) in self.states.iter().enumerate() {
            if i > 0 {
                w.write_all(b",")?;
            }
            write_json_string(w, s)?;
        }
        w.write_all(b"]}")
    }
}

/// Where a point's eigenvalue `[re,im]` lies in its text.
#[derive(Clone, Copy)]
struct PairSpan {
    open: usize,
    comma: usize,
    close: usize,
}

/// A number as serde_json writes an `f64`: `null` unless finite.
pub fn write_json_number<W: Write + ?Sized>(w: &mut W, v: f64) -> io::Result<()> {
    if v.is_finite() {
        CompactFormatter.write_f64(w, v)
    } else {
        w.write_all(b"null")
    }
}

/// A JSON string as serde_json writes it: quoted as is when nothing needs escaping
/// (no `"`, `\` or control character below 0x20), else through serde_json.
pub fn write_json_string<W: Write + ?Sized>(w: &mut W, s: &str) -> io::Result<()> {
    if s.bytes().all(|b| b >= 0x20 && b != b'"' && b != b'\\') {
        w.write_all(b"\"")?;
        w.write_all(s.as_bytes())?;
        w.write_all(b"\"")
    } else {
        serde_json::to_writer(w, s).map_err(io::Error::from)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn serde_bytes(sw: &CaseSweep) -> Vec<u8> {
        serde_json::to_vec(&sw.to_json()).expect("serializable")
    }

    fn written(sw: &CaseSweep) -> Vec<u8> {
        let mut out = Vec::new();
        sw.write_json(&mut out).expect("writes to a Vec");
        out
    }

    #[test]
    fn write_json_is_serde_json_of_to_json() {
        let p = Params::default();
        for case in Case::ALL {
            let sw = sweep_case(&p, case, &creep_grid(40), || {}).expect("sweep");
            assert_eq!(written(&sw), serde_bytes(&sw), "case {}", case.id());
        }
    }

    #[test]
    fn write_json_non_finite_and_escapes() {
        let p = Params::default();
        let mut sw = sweep_case(&p, Case::C, &creep_grid(5), || {}).expect("sweep");
        sw.eig[1][0] = Complex::new(f64::NAN, f64::INFINITY);
        sw.eig[2][1] = Complex::new(-0.0, 1e-300);
        // Branch 0 alone carries its (renamed) mode: its `im` is written as |im|.
        sw.eig[3][0] = Complex::new(-1.5, -2.25e-7);
        sw.eig[4][0] = Complex::new(0.5, -0.0);
        sw.branch_names[0] = "a \"quoted\"\\ name\n\u{1}é".into();
        sw.failed_points = vec![1.5e6, f64::NAN];
        sw.crossings.push(Crossing {
            creep_n: 2e6,
            freq_hz: f64::NEG_INFINITY,
            mode: "tab\there".into(),
            unstable_below: false,
        });
        sw.states = vec!["s\"1", "s2"];
        assert_eq!(written(&sw), serde_bytes(&sw));
    }
}
