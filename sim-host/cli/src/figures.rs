//! The commands' figures, as SVG ([`wheelset_report::svg`]): time histories, root loci
//! and the adhesion figures.

use std::path::{Path, PathBuf};
use wheelset_plant::modes::{CaseSweep, STRUCTURAL_ZERO};
use wheelset_plant::sim::{Record, Trajectory};
use wheelset_plant::traction::{Characteristic, RUNAWAY_HOLD_S, RUNAWAY_SLIP_MPS};
use wheelset_report::svg::{Figure, Plot, Series, Style, PALETTE};

fn series(tr: &Trajectory, label: &str, f: impl Fn(&Record) -> f64) -> Series {
    Series::line(label, tr.records.iter().map(|r| (r.t_s, f(r))).collect())
}

fn over_t(title: &str, y_label: &str) -> Plot {
    Plot::new(title).x_label("t (s)").y_label(y_label)
}

/// Run `k`'s colour, the same in every panel.
fn colour(k: usize) -> &'static str {
    PALETTE[k % PALETTE.len()]
}

/// The runs' drawing order: the others first, then the first (the main run) on top.
fn drawing_order(n: usize) -> impl Iterator<Item = usize> {
    (1..n).chain(0..n.min(1))
}

/// Run `k`'s series in its colour, the others' wide and pale beneath the main run's.
fn overlaid(k: usize, s: Series) -> Series {
    let s = s.color(colour(k));
    if k == 0 {
        s
    } else {
        s.width(4.0).opacity(0.5)
    }
}

/// Writes the time-history figures of `runs` (first = main run, others overlaid) into
/// `dir`: `lateral.svg` (Fig. 6 for `curve`, Fig. 9 for `beating`), `torque.svg` (Fig. 7),
/// `creep.svg` (Fig. 8) and `traction.svg`; returns the files written.
pub fn write_time_histories(runs: &[Trajectory], dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let Some(main) = runs.first() else {
        return Ok(vec![]);
    };
    let others: Vec<&str> = runs[1..].iter().map(|r| r.info.control.as_str()).collect();
    let main_law = &main.info.control;
    let titled = |main_style: &str, others_style: &str| {
        if others.is_empty() {
            format!("scenario {}, control {main_law}", main.info.scenario)
        } else {
            format!(
                "scenario {}: control {main_law} ({main_style}) vs {} ({others_style})",
                main.info.scenario,
                others.join(", ")
            )
        }
    };
    let title = titled("thin, on top", "wide, pale, beneath");
    let fig = |curve: &str, beating: &str| -> String {
        let n = match main.info.scenario.as_str() {
            "curve" => curve,
            "beating" => beating,
            _ => "",
        };
        Some(n)
            .filter(|n| !n.is_empty())
            .map_or(String::new(), |n| format!(" (Fig. {n})"))
    };
    let mut files = Vec::new();
    let mut save = |name: &str, title: &str, panels: Vec<Plot>| -> std::io::Result<()> {
        let p = dir.join(name);
        let title = title.to_string();
        Figure { title, panels }.save(&p)?;
        files.push(p);
        Ok(())
    };
    let overlay = |mut p: Plot, prefix: &str, f: fn(&Record) -> f64| {
        for k in drawing_order(runs.len()) {
            let tr = &runs[k];
            p = p.series(overlaid(
                k,
                series(tr, &format!("{prefix}{}", tr.info.control), f),
            ));
        }
        p
    };

    // The pure rolling line as a wide grey band beneath the runs.
    let p = over_t(
        &format!(
            "Lateral displacement y against the pure rolling line y0{}",
            fig("6", "9")
        ),
        "y (mm)",
    )
    .series(
        series(main, "pure rolling line y0 (grey band)", |r| r.y0_m * 1e3)
            .color("#BBBBBB")
            .width(6.0),
    );
    let p = overlay(p, "y, ", |r| r.y_m * 1e3);
    let psi = over_t("Yaw angle", "psi (mrad)");
    let psi = overlay(psi, "", |r| r.psi_rad * 1e3);
    // Zoom on the traction step (Fig. 9's beating shows here).
    let t_step = main
        .records
        .iter()
        .find(|r| r.demand_nm != 0.0)
        .map_or(5.0, |r| r.t_s);
    let mut zoom = over_t("y - y0 around the traction step", "y - y0 (mm)")
        .x_range(t_step - 0.2, t_step + 2.0);
    for k in drawing_order(runs.len()) {
        let tr = &runs[k];
        let pts = tr
            .records
            .iter()
            .filter(|r| r.t_s >= t_step - 0.2 && r.t_s <= t_step + 2.0)
            .map(|r| (r.t_s, (r.y_m - r.y0_m) * 1e3))
            .collect();
        zoom = zoom.series(overlaid(k, Series::line(&tr.info.control, pts)));
    }
    save(
        "lateral.svg",
        &format!("Lateral motion, {title}"),
        vec![p, psi, zoom],
    )?;

    let p = over_t(
        &format!(
            "Yaw torque: control (active) / suspension (passive){}",
            fig("7", "")
        ),
        "T_psi (N m)",
    );
    let p = overlay(p, "T_psi, ", |r| r.t_psi_nm);
    save("torque.svg", &title, vec![p])?;

    // One panel per force; the compared runs dashed over the main run.
    let per_run = |title: &str, y_label: &str, f: &dyn Fn(&Record) -> f64| {
        let mut p = over_t(title, y_label);
        for (k, tr) in runs.iter().enumerate() {
            let s = series(tr, &tr.info.control, f).color(colour(k));
            p = p.series(if k == 0 { s } else { s.style(Style::Dashed) });
        }
        p
    };
    let fxr = per_run(
        &format!("Longitudinal creep force, right wheel F_xR{}", fig("8", "")),
        "F_xR (kN)",
        &|r| r.fx_r_n * 1e-3,
    );
    let fxl = per_run(
        "Longitudinal creep force, left wheel F_xL",
        "F_xL (kN)",
        &|r| r.fx_l_n * 1e-3,
    );
    let fy = per_run("Lateral creep force per wheel F_y", "F_y (kN)", &|r| {
        r.fy_n * 1e-3
    });
    save(
        "creep.svg",
        &titled("solid", "dashed, on top"),
        vec![fxr, fxl, fy],
    )?;

    let ia = over_t("Armature current", "i_a (A)")
        .series(series(main, "i_a", |r| r.i_a_a))
        .series(series(main, "i_ref", |r| r.i_ref_a).style(Style::Dashed));
    let ua = over_t("Armature voltage", "u_a (V)").series(series(main, "u_a", |r| r.u_a_v));
    let wind = over_t(
        &format!("Gear wind-up and axle twist{}", fig("", "9: beating")),
        "angle (mrad)",
    )
    .series(series(main, "wind-up phi_L - theta_m/n", |r| {
        r.wind_rad * 1e3
    }))
    .series(series(main, "twist phi_R - phi_L", |r| r.twist_rad * 1e3));
    let v = over_t("Forward speed", "v (m/s)").series(series(main, "v", |r| r.v_mps));
    let drive = format!(
        "scenario {}, control {main_law}: the drive",
        main.info.scenario
    );
    save("traction.svg", &drive, vec![ia, ua, wind, v])?;
    Ok(files)
}

/// Writes `modes_case_<id>.svg`: the root locus of every named mode over the sweep (the
/// 10 MN end marked), and each mode's frequency and damping against the creep.
pub fn write_root_locus(sw: &CaseSweep, dir: &Path) -> std::io::Result<std::path::PathBuf> {
    let names = sw.mode_names();
    let n_pts = sw.creep.len();
    let stride = (n_pts / 150).max(1);
    // Axis window: the modes that are not far out on the real axis.
    let mut re_lo: f64 = -1.0;
    let mut im_hi: f64 = 1.0;
    for row in &sw.eig {
        for (b, l) in row.iter().enumerate() {
            if sw.branch_names[b] == STRUCTURAL_ZERO || l.re < -400.0 {
                continue;
            }
            re_lo = re_lo.min(l.re);
            im_hi = im_hi.max(l.im.abs());
        }
    }
    let re_hi = sw
        .eig
        .iter()
        .flatten()
        .map(|l| l.re)
        .fold(0.0f64, f64::max)
        .max(-0.05 * re_lo);
    // The subtitle states where the stability changes (the bisected crossings).
    let crossings = if sw.crossings.is_empty() {
        "no stability change in 1-10 MN".to_string()
    } else {
        sw.crossings
            .iter()
            .map(|c| format!("{} crosses at {:.2} MN", c.mode, c.creep_n * 1e-6))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut locus = Plot::new(&format!(
        "Root locus, f11 = f22 = 1-10 MN ({crossings}; x: the 10 MN end)"
    ))
    .x_label("Re (1/s)")
    .y_label("Im (rad/s)")
    .x_range(1.05 * re_lo, 1.05 * re_hi)
    .y_range(-1.05 * im_hi, 1.05 * im_hi)
    .size(980.0, 560.0)
    .vmark(0.0, "", AXIS_GREY);
    let mut freq = Plot::new(
        "Frequency of each mode: natural |lambda|/2pi dashed, damped Im lambda/2pi solid",
    )
    .size(980.0, 360.0)
    .x_label("creep coefficient f11 = f22 (MN)")
    .y_label("frequency (Hz)");
    let mut zeta =
        Plot::new("Damping ratio of each mode (below 0 = unstable; real: 1, nested bands)")
            .size(980.0, 360.0)
            .x_label("creep coefficient f11 = f22 (MN)")
            .y_label("zeta")
            .hmark(0.0, "", AXIS_GREY);
    // Modes real somewhere coincide there at zero frequency and zeta = 1: the ones drawn
    // first are wider, so they show as nested bands (nested dots on the real axis).
    let real: Vec<bool> = names
        .iter()
        .map(|n| (0..n_pts).any(|k| sw.mode_eig(n, k).is_some_and(|(_, l)| l.im == 0.0)))
        .collect();
    for (m, name) in names.iter().enumerate() {
        let col = MODE_COLOURS[m % MODE_COLOURS.len()];
        let later_real = real[m + 1..].iter().filter(|r| **r).count();
        let width = if real[m] {
            1.6 + 3.0 * later_real as f64
        } else {
            1.6
        };
        let branch = |k: usize| {
            sw.eig[k]
                .iter()
                .zip(&sw.branch_names)
                .filter(|(_, b)| *b == name)
                .map(|(l, _)| (l.re, l.im))
        };
        let pts: Vec<(f64, f64)> = (0..n_pts).step_by(stride).flat_map(branch).collect();
        let vals: Vec<(f64, f64, f64, f64)> = (0..n_pts)
            .filter_map(|k| {
                sw.mode_eig(name, k).map(|(_, l)| {
                    let mag = l.norm();
                    (
                        sw.creep[k] * 1e-6,
                        l.im.abs() / (2.0 * std::f64::consts::PI),
                        if mag > 0.0 { -l.re / mag } else { 0.0 },
                        if l.im == 0.0 {
                            f64::NAN
                        } else {
                            mag / (2.0 * std::f64::consts::PI)
                        },
                    )
                })
            })
            .collect();
        // The legend names each mode with its natural frequency range (min/max skip NaN).
        let (lo, hi) = (vals.iter()).fold((f64::INFINITY, 0.0f64), |(a, b), v| {
            (a.min(v.3), b.max(v.3))
        });
        let mut named = if hi > 0.0 {
            format!("{name}: f_n {lo:.1}-{hi:.1} Hz")
        } else if name.contains("real") {
            name.clone()
        } else {
            format!("{name}: real")
        };
        // How far a branch runs past the axis's left end.
        let far = (0..n_pts).flat_map(branch).map(|p| p.0).fold(0.0, f64::min);
        if far < 1.05 * re_lo {
            let sep = if named.contains(':') { "," } else { ":" };
            named += &format!("{sep} to {far:.0} 1/s");
        }
        locus = locus.series(Series::scatter(&named, pts).color(col).width(width));
        let top = branch(n_pts - 1).collect();
        locus = locus.series(Series::scatter("", top).style(Style::Crosses).color(col));
        let line = |label: &str, f: fn(&(f64, f64, f64, f64)) -> f64| {
            Series::line(label, vals.iter().map(|v| (v.0, f(v))).collect()).color(col)
        };
        freq = (freq.series(line(name, |v| v.1).width(width)))
            .series(line("", |v| v.3).style(Style::Dashed));
        zeta = zeta.series(line(name, |v| v.2).width(width));
    }
    for c in &sw.crossings {
        zeta = zeta.vmark(c.creep_n * 1e-6, "", AXIS_GREY);
    }
    let path = dir.join(format!("modes_case_{}.svg", sw.case.id()));
    let title = format!("Case ({}): {}", sw.case.id(), sw.case.label());
    let panels = vec![locus, freq, zeta];
    Figure { title, panels }.save(&path)?;
    Ok(path)
}

/// The colour of the root locus's imaginary axis, zeta = 0 and the crossings' lines.
const AXIS_GREY: &str = "#888888";

/// The modes' colours: the palette with its two blues apart (the sky blue last).
const MODE_COLOURS: [&str; 8] = [
    "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#000000", "#999999", "#56B4E9",
];

/// One run of [`write_figure`]: its label (e.g. `protection on`), the run, and the slip
/// regulator's set point while the protection acted, `(t_s, m/s)`.
#[derive(Debug, Clone, Copy)]
pub struct FigureRun<'a> {
    pub label: &'a str,
    pub tr: &'a Trajectory,
    pub set_point: &'a [(f64, f64)],
}

/// The traction engineer's figure (`adhesion.svg` in `dir`): traction force, the slip
/// velocity of each run in its own panel (against the set point and thresholds), then
/// the adhesion available and used; each run keeps its colour across the panels.
pub fn write_figure(
    runs: &[FigureRun<'_>],
    slip_on_mps: f64,
    dir: &Path,
) -> std::io::Result<PathBuf> {
    std::fs::create_dir_all(dir)?;
    // One time axis for every panel: a run stopped as diverged ends early.
    let end = runs
        .iter()
        .filter_map(|r| r.tr.records.last().map(|x| x.t_s))
        .fold(0.0f64, f64::max);
    let panel = |title: &str, y_label: &str| over_t(title, y_label).x_range(0.0, end);
    let mut force = panel("Traction force delivered F_xR + F_xL", "F (kN)");
    let mut mu = panel(
        "Adhesion available (peak) and used",
        "F / Q (creep force over wheel load)",
    );
    for k in drawing_order(runs.len()) {
        let run = &runs[k];
        force = force.series(overlaid(
            k,
            series(run.tr, run.label, |r| (r.fx_r_n + r.fx_l_n) * 1e-3),
        ));
        let used = format!("used, {}", run.label);
        mu = mu.series(overlaid(k, series(run.tr, &used, |r| r.mu_used)));
    }
    if let Some(run) = runs.first() {
        mu = mu.series(
            series(run.tr, "available", |r| r.mu_avail)
                .style(Style::Dashed)
                .color("#000"),
        );
    }
    // A run that stopped early (diverged) says so where it ends, in every panel it is in.
    let ends: Vec<(f64, String, &str)> = runs
        .iter()
        .enumerate()
        .filter_map(|(k, r)| {
            let last = r.tr.records.last()?.t_s;
            (last < end - 1e-9).then(|| {
                let why = if r.tr.info.diverged_at_s.is_some() {
                    "stopped: diverged"
                } else {
                    "ends"
                };
                (last, format!("{} {why} at {last:.3} s", r.label), colour(k))
            })
        })
        .collect();
    let mut slips = Vec::new();
    for (k, run) in runs.iter().enumerate() {
        let mut slip = panel(&format!("Slip velocity, {}", run.label), "slip (m/s)")
            .series(series(run.tr, run.label, |r| r.slip_mps).color(colour(k)));
        if let Some((t, l, c)) = ends.iter().find(|e| e.1.starts_with(run.label)) {
            slip = slip.vmark(*t, l, c);
        }
        slips.push(if run.set_point.is_empty() {
            slip.hmark(
                RUNAWAY_SLIP_MPS,
                &format!("runaway: above {RUNAWAY_SLIP_MPS} m/s for {RUNAWAY_HOLD_S} s"),
                "#D55E00",
            )
        } else {
            // The set point, broken where the protection did not act, a dot at each end.
            let mut sp = Vec::with_capacity(run.set_point.len());
            let mut released = Vec::new();
            let dt = run
                .set_point
                .windows(2)
                .map(|w| w[1].0 - w[0].0)
                .fold(f64::INFINITY, f64::min);
            for w in run.set_point.windows(2) {
                sp.push(w[0]);
                if w[1].0 - w[0].0 > 1.5 * dt {
                    sp.push((f64::NAN, f64::NAN));
                    released.push(w[0]);
                }
            }
            sp.extend(run.set_point.last());
            released.extend(run.set_point.last());
            let top = run
                .set_point
                .iter()
                .map(|p| p.1)
                .chain(run.tr.records.iter().map(|r| r.slip_mps))
                .fold(slip_on_mps, f64::max);
            slip.series(
                Series::line("regulator's set point", sp)
                    .style(Style::Dashed)
                    .color("#000"),
            )
            .series(Series::scatter("protection releases", released).color("#000"))
            .y_range(-0.05 * top, 1.15 * top)
            .hmark(
                slip_on_mps,
                &format!("detection: slip above {slip_on_mps} m/s"),
                "#D55E00",
            )
        });
    }
    for (t, l, c) in &ends {
        force = force.vmark(*t, l, c);
        mu = mu.vmark(*t, "", c);
    }
    let path = dir.join("adhesion.svg");
    let names: Vec<&str> = runs.iter().map(|r| r.label).collect();
    let title = format!(
        "Low adhesion, {}: traction force, slip, adhesion",
        names.join(" vs ")
    );
    let panels = std::iter::once(force).chain(slips).chain([mu]).collect();
    Figure { title, panels }.save(&path)?;
    Ok(path)
}

/// The SVG of the creep characteristic `ch` (and of the linear law for comparison).
pub fn characteristic(ch: &Characteristic) -> Figure {
    let pts: Vec<(f64, f64)> = ch
        .creepage
        .iter()
        .zip(&ch.force_over_q)
        .map(|(&s, &f)| (s, f))
        .collect();
    let lin: Vec<(f64, f64)> = ch
        .creepage
        .iter()
        .map(|&s| (s, ch.f11_n * s / ch.q_n))
        .take_while(|&(_, f)| f <= 1.5 * ch.mu_peak)
        .collect();
    let plot = Plot::new(&format!(
        "Polach creep characteristic, {} rail, v = {} m/s (peak {:.3} at creepage {:.4})",
        ch.condition, ch.v_mps, ch.mu_peak, ch.creepage_peak
    ))
    .x_label("longitudinal creepage (slip velocity over speed)")
    .y_label("F / Q (creep force over wheel load)")
    .series(Series::line(&format!("{}", ch.condition), pts))
    .series(
        Series::line("linear law f11 s / Q", lin)
            .style(Style::Dashed)
            .color("#000"),
    )
    .hmark(
        ch.mu_peak,
        &format!("peak adhesion {:.3}", ch.mu_peak),
        "#777777",
    );
    // As wide as its title needs: 9 px a character at font-size 15.
    let title = format!("adhesion: {}", ch.source);
    let width = (title.chars().count() as f64 * 9.0 + 40.0).max(plot.width);
    Figure::new(&title).panel(plot.size(width, 360.0))
}

#[cfg(test)]
mod tests;
