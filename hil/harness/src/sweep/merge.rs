//! `hil sweep merge`: the shards' documents joined into the document of a single run.
//!
//! The parts must be one split of one campaign: the same header (grid, seed, flags and
//! the [`Identity`](super::Identity) of the build and input files), the same `N`, each
//! shard `0..N-1` exactly once, and each holding exactly its own points. Anything else
//! is refused, naming the file and the shard: a missing shard (a task still running or
//! failed), a shard given twice, a shard of another campaign or build (a stale file in
//! the output directory), a document whose records are not its shard's.

use std::collections::{BTreeMap, BTreeSet};

use super::{Shard, Summary, SweepDoc};

/// The first field where two JSON values differ, as a dotted path, with the two values
/// when they are short.
fn first_difference(a: &serde_json::Value, b: &serde_json::Value, path: &str) -> Option<String> {
    use serde_json::Value;
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let keys: BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            keys.into_iter().find_map(|k| {
                let p = format!("{path}.{k}");
                match (x.get(k), y.get(k)) {
                    (Some(u), Some(v)) => first_difference(u, v, &p),
                    _ => Some(format!("`{p}` is in one header only")),
                }
            })
        }
        _ if a == b => None,
        _ => {
            let (sa, sb) = (a.to_string(), b.to_string());
            Some(if sa.len() + sb.len() <= 160 {
                format!("`{path}` differs ({sa} vs {sb})")
            } else {
                format!("`{path}` differs")
            })
        }
    }
}

/// Joins shard documents (`(file name, document)`, any order) into the document of a
/// single run: the same header, every point once in index order, the summary
/// recomputed. The error names the file and the shard that break the rules.
pub fn merge(parts: &[(String, SweepDoc)]) -> Result<SweepDoc, String> {
    let Some((first_name, first)) = parts.first() else {
        return Err("merge: no documents given".into());
    };
    for (name, d) in parts {
        if d.sweep != first.sweep {
            let why = match (
                serde_json::to_value(&first.sweep),
                serde_json::to_value(&d.sweep),
            ) {
                (Ok(a), Ok(b)) => first_difference(&a, &b, "sweep"),
                _ => None,
            };
            return Err(format!(
                "merge: {name} is of another campaign than {first_name}: {}",
                why.unwrap_or_else(|| "their `sweep` headers differ".into())
            ));
        }
    }
    let points = first.sweep.points;
    // Each part's shard: the whole grid for a document without one.
    let whole = Shard { index: 0, count: 1 };
    let count = first.shard.unwrap_or(whole).count;
    let mut seen: BTreeMap<usize, &str> = BTreeMap::new();
    for (name, d) in parts {
        let s = d.shard.unwrap_or(whole);
        if s.count != count {
            let what = |s: Shard| {
                if s.count == 1 {
                    "the whole grid".to_string()
                } else {
                    format!("shard {s}")
                }
            };
            return Err(format!(
                "merge: {first_name} is {} but {name} is {}: the parts of one split are needed",
                what(first.shard.unwrap_or(whole)),
                what(s)
            ));
        }
        if let Some(other) = seen.insert(s.index, name) {
            return Err(format!(
                "merge: shard {s} is in more than one document: {other} and {name}"
            ));
        }
        let want: Vec<usize> = s.points(points).collect();
        let have: Vec<usize> = d.records.iter().map(|r| r.index).collect();
        if have != want {
            let wrong = have.iter().find(|&&i| i >= points || !s.holds(i));
            return Err(match wrong {
                Some(i) => format!(
                    "merge: {name} (shard {s}) holds point {i}, which is not of shard {s} of a \
                     grid of {points}"
                ),
                None => format!(
                    "merge: {name} (shard {s}) holds points [{}] but shard {s} of a grid of \
                     {points} is [{}]",
                    list(&have),
                    list(&want)
                ),
            });
        }
    }
    let missing: Vec<usize> = (0..count).filter(|i| !seen.contains_key(i)).collect();
    if !missing.is_empty() {
        let shards: Vec<String> = missing.iter().map(|i| format!("{i}/{count}")).collect();
        let pts: Vec<usize> = missing
            .iter()
            .flat_map(|&index| Shard { index, count }.points(points))
            .collect();
        return Err(format!(
            "merge: shard{} {} of {first_name}'s campaign {} missing ({} of {points} points \
             missing: {}); is a task still running, or did it fail?",
            if missing.len() == 1 { "" } else { "s" },
            shards.join(", "),
            if missing.len() == 1 { "is" } else { "are" },
            pts.len(),
            list(&pts)
        ));
    }
    let mut records: Vec<_> = parts
        .iter()
        .flat_map(|(_, d)| d.records.iter().cloned())
        .collect();
    records.sort_by_key(|r| r.index);
    Ok(SweepDoc {
        sweep: first.sweep.clone(),
        shard: None,
        summary: Summary::of(&records),
        records,
    })
}

fn list(v: &[usize]) -> String {
    let mut s: Vec<String> = v.iter().take(8).map(usize::to_string).collect();
    if v.len() > 8 {
        s.push("...".into());
    }
    s.join(", ")
}
