//! The report of `hil sweep`: `report.md` (a table of every point, through
//! [`wheelset_report::table`]) and the heat maps `verdict.svg` and `peak_y.svg`.

use std::io;
use std::path::{Path, PathBuf};

/// A parameter value for a label: 3 significant digits (`1.00e6`, `0.167`).
pub fn value_label(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e4 || v.abs() < 1e-2 {
        format!("{v:.2e}")
    } else {
        format!("{}", (v * 1e3).round() / 1e3)
    }
}

const VERDICT_COLOURS: [(wheelset_report::Verdict, &str); 3] = [
    (wheelset_report::Verdict::Pass, "#009E73"),
    (wheelset_report::Verdict::Warn, "#E69F00"),
    (wheelset_report::Verdict::Fail, "#D55E00"),
];

/// A parameter key with its unit (`f11 (N)`; a pure number stays bare).
fn axis_label(key: &str) -> String {
    match wheelset_plant::params::RANGES.iter().find(|r| r.key == key) {
        Some(r) if r.unit != "1" => format!("{key} ({})", r.unit),
        _ => key.to_string(),
    }
}

/// The heat maps of a campaign: the first axis across, the second (if any) up, one map
/// per combination of the further axes; `cell` colours and labels one record.
fn heat_maps(
    doc: &crate::sweep::SweepDoc,
    title: &str,
    cell: &dyn Fn(&crate::sweep::Record) -> wheelset_report::svg::heatmap::Cell,
    legend: &[(String, String)],
) -> Vec<wheelset_report::svg::heatmap::HeatMap> {
    use wheelset_report::svg::heatmap::{Cell, HeatMap};
    let axes = &doc.sweep.axes;
    let Some(x) = axes.first() else {
        return Vec::new();
    };
    let y = axes.get(1);
    let (nx, ny) = (x.values.len(), y.map_or(1, |a| a.values.len()));
    let per_map = nx * ny;
    let maps = doc.sweep.points / per_map.max(1);
    (0..maps.max(1))
        .map(|m| {
            let mut cells = vec![Cell::new("#eeeeee", "-"); per_map];
            let mut rest_label = String::new();
            for r in &doc.records {
                if r.index / per_map.max(1) != m {
                    continue;
                }
                let idx = crate::sweep::grid::axis_indices(axes, r.index);
                let (i, j) = (idx[0], idx.get(1).copied().unwrap_or(0));
                cells[j * nx + i] = cell(r);
                if rest_label.is_empty() && axes.len() > 2 {
                    rest_label = axes[2..]
                        .iter()
                        .zip(&idx[2..])
                        .map(|(a, &k)| format!("{} = {}", a.key, value_label(a.values[k])))
                        .collect::<Vec<_>>()
                        .join(", ");
                }
            }
            let t = if rest_label.is_empty() {
                title.to_string()
            } else {
                format!("{title} at {rest_label}")
            };
            let mut h = HeatMap::new(
                &t,
                x.values.iter().map(|&v| value_label(v)).collect(),
                y.map_or(vec![String::new()], |a| {
                    a.values.iter().map(|&v| value_label(v)).collect()
                }),
            )
            .labels(
                &axis_label(&x.key),
                &y.map_or(String::new(), |a| axis_label(&a.key)),
            )
            .cells(cells);
            for (c, l) in legend {
                h = h.legend(c, l);
            }
            h
        })
        .collect()
}

/// Writes a campaign's report (the module docs' three files) into `dir`; returns them.
pub fn write_sweep_report(
    doc: &crate::sweep::SweepDoc,
    dir: &Path,
    command: &str,
) -> io::Result<Vec<PathBuf>> {
    use wheelset_report::svg::heatmap::{sequential, stack, Cell};
    let h = &doc.sweep;
    let what = format!(
        "{} with {:?} on {}{}",
        h.scenario,
        h.control,
        h.target,
        if h.faults.is_empty() {
            String::new()
        } else {
            format!(", faults {}", h.faults)
        }
    )
    .to_lowercase();
    let colour = |v: wheelset_report::Verdict| {
        VERDICT_COLOURS
            .iter()
            .find(|(w, _)| *w == v)
            .map_or("#999999", |(_, c)| c)
    };
    let legend: Vec<(String, String)> = VERDICT_COLOURS
        .iter()
        .map(|(v, c)| ((*c).to_string(), v.to_string()))
        .collect();
    let verdicts = heat_maps(
        doc,
        &format!("Verdict: {what}"),
        &|r| Cell::new(colour(r.verdict), &r.verdict.to_string()),
        &legend,
    );

    let peaks: Vec<f64> = doc
        .records
        .iter()
        .map(|r| r.peak_abs_y_m)
        .filter(|p| p.is_finite() && *p > 0.0)
        .collect();
    let lo = peaks.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = peaks.iter().copied().fold(0.0, f64::max);
    let scale = move |p: f64| {
        if !(p.is_finite() && p > 0.0) {
            f64::NAN
        } else if hi > lo {
            (p / lo).ln() / (hi / lo).ln()
        } else {
            0.5
        }
    };
    let legend = if peaks.is_empty() {
        Vec::new()
    } else {
        let mut l: Vec<(String, String)> = (0..5)
            .map(|k| {
                let t = f64::from(k) / 4.0;
                let v = lo * (hi / lo).powf(t) * 1e3;
                (sequential(t), format!("{v:.3} mm"))
            })
            .collect();
        l.push(("none".into(), "log colour scale".into()));
        if doc.records.iter().any(|r| r.diverged_at_s.is_some()) {
            l.push(("none".into(), "div t: diverged at t".into()));
        }
        l
    };
    let peak_maps = heat_maps(
        doc,
        &format!("Peak |y| (mm): {what}"),
        &|r| {
            let text = match r.diverged_at_s {
                Some(t) => format!("div {t:.2} s"),
                None => format!("{:.3}", r.peak_abs_y_m * 1e3),
            };
            Cell::new(&sequential(scale(r.peak_abs_y_m)), &text)
        },
        &legend,
    );
    crate::report::write_files(
        dir,
        [
            ("verdict.svg", stack("", &verdicts)),
            ("peak_y.svg", stack("", &peak_maps)),
            ("report.md", sweep_markdown(doc, command)),
        ],
    )
}

/// The Markdown text of a campaign's report.
#[must_use]
pub fn sweep_markdown(doc: &crate::sweep::SweepDoc, command: &str) -> String {
    let h = &doc.sweep;
    let axes: Vec<String> = h
        .axes
        .iter()
        .map(|a| {
            format!(
                "{} in {} ({} values)",
                a.key,
                a.values
                    .iter()
                    .map(|&v| value_label(v))
                    .collect::<Vec<_>>()
                    .join(", "),
                a.values.len()
            )
        })
        .collect();
    let follows: String = h
        .follows
        .iter()
        .map(|(k, l)| format!("; {k} follows {l}"))
        .collect();
    let faults = if h.faults.is_empty() {
        "none"
    } else {
        &h.faults
    };
    let sm = &doc.summary;
    let shard = doc.shard.map_or(String::new(), |sh| {
        format!(" (shard {sh}: {} of the points)", doc.records.len())
    });
    let mut s = format!(
        "# HIL sweep: {} with {:?} on {}\n\nReproduce: `{command}`\n\n\
         {} points: {}{follows}. Link faults: {faults}, seed {}. Parameters: {}, with the \
         scenario's [params] on top.\n\n**{} pass, {} warn, {} fail**{shard}.\n\n\
         ![verdicts](verdict.svg)\n\n![peak |y|](peak_y.svg)\n\n",
        h.scenario,
        h.control,
        h.target,
        h.points,
        axes.join("; "),
        h.seed,
        h.params_file.as_deref().unwrap_or("the paper's"),
        sm.pass,
        sm.warn,
        sm.fail,
    );
    let keys: Vec<String> = doc
        .records
        .first()
        .map(|r| r.params.iter().map(|(k, _)| k.clone()).collect())
        .unwrap_or_default();
    let mut t = wheelset_report::table::Table::new(
        std::iter::once("#".to_string())
            .chain(keys.iter().cloned())
            .chain(
                [
                    "verdict",
                    "peak |y| (mm)",
                    "diverged at (s)",
                    "checks not passed",
                ]
                .map(String::from),
            ),
    );
    for r in &doc.records {
        let checks = if r.failing.is_empty() {
            "-".to_string()
        } else {
            r.failing
                .iter()
                .map(|c| format!("{} {}: {}", c.check, c.verdict, c.reason))
                .collect::<Vec<_>>()
                .join("; ")
        };
        t.row(
            std::iter::once(r.index.to_string())
                .chain(r.params.iter().map(|(_, v)| value_label(*v)))
                .chain([
                    r.verdict.to_string(),
                    format!("{:.3}", r.peak_abs_y_m * 1e3),
                    r.diverged_at_s.map_or("-".into(), |t| format!("{t:.3}")),
                    checks,
                ]),
        );
    }
    s.push_str(&t.render());
    s
}
