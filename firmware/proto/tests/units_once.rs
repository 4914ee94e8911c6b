//! Every wire unit is defined once, in `wheelset_proto::units`: no other source file of
//! the workspace writes one of the unit values as a literal where it means an LSB.
//!
//! The scan covers the non-test sources (`src/` of every crate, `build.rs`), comments
//! stripped. A literal equal to a unit value is refused on a line that names an LSB
//! (`lsb` in any case), that converts to or from wire codes (`quantize(`, `to_si(`,
//! `code(`), or inside a `WireLsb { .. }` literal. Unit values of 1 (the demand's N m)
//! cannot be told from every other 1.0 and are left to the named constants.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use wheelset_proto::units;

const UNITS: [(&str, f64); 9] = [
    ("LAT_VEL_LSB_M_PER_S", units::LAT_VEL_LSB_M_PER_S),
    ("LAT_ACC_LSB_M_PER_S2", units::LAT_ACC_LSB_M_PER_S2),
    ("CURRENT_LSB_A", units::CURRENT_LSB_A),
    ("SPEED_LSB_RAD_PER_S", units::SPEED_LSB_RAD_PER_S),
    ("DEMAND_LSB_NM", units::DEMAND_LSB_NM),
    ("TORQUE_LSB_NM", units::TORQUE_LSB_NM),
    ("VOLTAGE_LSB_V", units::VOLTAGE_LSB_V),
    ("V_REF_LSB_M_PER_S", units::V_REF_LSB_M_PER_S),
    ("TIME_LSB_S", units::TIME_LSB_S),
];

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let p = e.path();
        let name = e.file_name().to_string_lossy().into_owned();
        if p.is_dir() {
            if !matches!(
                name.as_str(),
                "target" | "tests" | "benches" | "examples" | "fuzz" | ".git"
            ) {
                sources(&p, out);
            }
        } else if name.ends_with(".rs") {
            out.push(p);
        }
    }
}

/// The float literals of `code` (tokens with a `.` or an exponent that parse as `f64`).
fn float_literals(code: &str) -> Vec<(String, f64)> {
    let b = code.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = b[i].is_ascii_digit()
            && (i == 0
                || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_' || b[i - 1] == b'.'));
        if !starts {
            i += 1;
            continue;
        }
        let s = i;
        while i < b.len()
            && (b[i].is_ascii_alphanumeric()
                || b[i] == b'_'
                || (b[i] == b'.' && i + 1 < b.len() && b[i + 1].is_ascii_digit())
                || ((b[i] == b'-' || b[i] == b'+') && (b[i - 1] == b'e' || b[i - 1] == b'E')))
        {
            i += 1;
        }
        let tok = &code[s..i];
        let num: String = tok
            .trim_end_matches("f64")
            .trim_end_matches("f32")
            .chars()
            .filter(|&c| c != '_')
            .collect();
        let is_float = num.contains('.') || num.contains('e') || num.contains('E');
        if is_float && !num.starts_with("0x") {
            if let Ok(v) = num.parse::<f64>() {
                out.push((tok.to_string(), v));
            }
        }
    }
    out
}

/// The unit values a literal `v` equals (other than 1).
fn unit_of(v: f64) -> Option<&'static str> {
    UNITS
        .iter()
        .find(|(_, u)| *u != 1.0 && (v - u).abs() <= 1e-12 * u.abs())
        .map(|(n, _)| *n)
}

fn offences(text: &str) -> Vec<String> {
    let mut found = Vec::new();
    let mut wire_lsb_depth: Option<i32> = None;
    for (n, line) in text.lines().enumerate() {
        let code = line.split("//").next().unwrap_or("");
        let lower = code.to_ascii_lowercase();
        let opens_wire_lsb = code.contains("WireLsb {") && !code.contains("struct WireLsb");
        if opens_wire_lsb && wire_lsb_depth.is_none() {
            wire_lsb_depth = Some(0);
        }
        let suspect = wire_lsb_depth.is_some()
            || lower.contains("lsb")
            || ["quantize(", "to_si(", "code("]
                .iter()
                .any(|c| code.contains(c));
        if suspect {
            for (tok, v) in float_literals(code) {
                if let Some(unit) = unit_of(v) {
                    found.push(format!(
                        "{}: `{tok}` is units::{unit}: {}",
                        n + 1,
                        line.trim()
                    ));
                }
            }
        }
        if let Some(d) = wire_lsb_depth.as_mut() {
            *d += code.matches('{').count() as i32 - code.matches('}').count() as i32;
            if *d <= 0 {
                wire_lsb_depth = None;
            }
        }
    }
    found
}

#[test]
fn the_scan_finds_what_it_looks_for() {
    assert_eq!(offences("let v = code(m.v_mps, 1e-3);").len(), 1);
    assert_eq!(offences("    v_ref_lsb_m_per_s: 1e-3,").len(), 1);
    assert_eq!(
        offences("WireLsb {\n    y_dot: 1e-6,\n    torque: 0.1,\n}\nlet x = 0.1;").len(),
        2
    );
    assert!(offences("let lsb = units::CURRENT_LSB_A; // 1e-3").is_empty());
    assert!(offences("let t = t_ns as f64 * 1e-9;").is_empty());
}

#[test]
fn wire_units_are_written_only_in_proto_units() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let units_rs = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/units.rs");
    let mut files = Vec::new();
    sources(&root, &mut files);
    assert!(
        files.len() > 50,
        "the scan found only {} files",
        files.len()
    );
    let mut bad = Vec::new();
    for f in files {
        if f.canonicalize().ok() == units_rs.canonicalize().ok() {
            continue;
        }
        let text = std::fs::read_to_string(&f).expect("a readable source");
        for o in offences(&text) {
            bad.push(format!("{}:{o}", f.display()));
        }
    }
    assert!(
        bad.is_empty(),
        "wire units written outside wheelset_proto::units (use the constant):\n{}",
        bad.join("\n")
    );
}
