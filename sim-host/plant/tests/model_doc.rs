//! The model document (`docs/model.md`) and the code do not drift: its table of
//! plausible parameter ranges is `wheelset_plant::params::RANGES`, row for row, and every
//! range is enforced at its bounds.

use wheelset_plant::params::{Params, RANGES};

const DOC: &str = include_str!("../../../docs/model.md");

/// The rows of the ranges table: `(key, unit, min, max)`.
fn doc_rows() -> Vec<(String, String, f64, f64)> {
    let begin = DOC
        .find("<!-- ranges:begin -->")
        .expect("ranges:begin marker");
    let end = DOC.find("<!-- ranges:end -->").expect("ranges:end marker");
    DOC[begin..end]
        .lines()
        .filter(|l| l.starts_with("| `"))
        .map(|l| {
            let cells: Vec<&str> = l.trim_matches('|').split('|').map(str::trim).collect();
            assert!(
                cells.len() >= 5,
                "row `{l}`: want key | unit | min | max | why"
            );
            let num = |s: &str| -> f64 {
                s.parse()
                    .unwrap_or_else(|_| panic!("row `{l}`: `{s}` is not a number"))
            };
            (
                cells[0].trim_matches('`').to_string(),
                cells[1].to_string(),
                num(cells[2]),
                num(cells[3]),
            )
        })
        .collect()
}

#[test]
fn the_documented_ranges_are_the_code_ranges() {
    let doc = doc_rows();
    let code: Vec<(String, String, f64, f64)> = RANGES
        .iter()
        .map(|r| (r.key.to_string(), r.unit.to_string(), r.min, r.max))
        .collect();
    assert_eq!(
        doc, code,
        "docs/model.md's table differs from params::RANGES"
    );
    // Every parameter has a range, and the defaults are inside.
    let all = Params {
        k_t: Some(1e6),
        k_gear: Some(1e6),
        q: Some(5e4),
        ..Params::default()
    };
    let table = toml::Table::try_from(&all).expect("table");
    let mut keys: Vec<&str> = table.keys().map(String::as_str).collect();
    let mut ranged: Vec<&str> = RANGES.iter().map(|r| r.key).collect();
    let entries: Vec<&str> = all.entries().iter().map(|e| e.0).collect();
    assert_eq!(entries, ranged, "the entries in the ranges' order");
    keys.sort();
    ranged.sort();
    assert_eq!(keys, ranged, "a parameter without a plausible range");
    assert!(Params::default().validate().is_ok());
}

#[test]
fn each_bound_is_enforced_and_named() {
    for r in RANGES.iter() {
        for (value, ok) in [
            (r.min, true),
            (r.max, true),
            (r.min - r.min.abs().max(1.0) * 1e-3, false),
            (r.max * (1.0 + 1e-3), false),
            (f64::NAN, false),
        ] {
            let v = if value.is_nan() {
                "nan".to_string()
            } else {
                format!("{value:e}")
            };
            let src = format!("{} = {v}\n", r.key);
            let got = Params::from_toml_str(&src, "p.toml");
            match (ok, got) {
                (true, Ok(_)) => {}
                (false, Err(e)) => {
                    assert_eq!(e.key(), Some(r.key), "{src}: {e}");
                    let msg = e.to_string();
                    assert!(msg.contains("plausible range"), "{src}: {msg}");
                    assert!(msg.contains(r.why), "{src}: {msg}");
                }
                (true, Err(e)) => {
                    // A bound may be unreachable alone through a derived stiffness
                    // (e.g. i_w = 1 gives k_t below its range, m_v = 2e6 a wheel load q
                    // above its): then that key is named.
                    let k = e.key().unwrap_or("");
                    assert!(k == "k_t" || k == "k_gear" || k == "q", "{src}: {e}");
                }
                (false, Ok(_)) => panic!("{src}: accepted"),
            }
        }
    }
}

/// Every citation of the model document in the repository points at `docs/model.md`
/// (the spec's own path is not in the repository).
#[test]
fn every_citation_points_at_docs_model_md() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let stale = concat!("spec", "/model.md");
    let mut bad = Vec::new();
    let mut stack = vec![root.clone()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in entries.flatten() {
            let p = e.path();
            let name = e.file_name().to_string_lossy().into_owned();
            if p.is_dir() {
                if !name.starts_with('.') && name != "target" && name != "out" {
                    stack.push(p);
                }
            } else if [".rs", ".md", ".toml"].iter().any(|x| name.ends_with(x)) {
                let text = std::fs::read_to_string(&p).unwrap_or_default();
                for (i, line) in text.lines().enumerate() {
                    if line.contains(stale) {
                        bad.push(format!("{}:{}: {line}", p.display(), i + 1));
                    }
                }
            }
        }
    }
    assert!(root.join("docs/model.md").is_file());
    assert!(bad.is_empty(), "stale citations:\n{}", bad.join("\n"));
}
