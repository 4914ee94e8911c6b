//! The paper's figures from simulation results: time histories (Figs. 6-9) and root
//! loci (Figs. 2-5, from [`wheelset_plant::modes`] sweeps), and the adhesion figures
//! (the creep characteristic, traction and slip against time), written as SVG with
//! [`wheelset_report::svg`].

use std::path::{Path, PathBuf};
use wheelset_plant::modes::{CaseSweep, STRUCTURAL_ZERO};
use wheelset_plant::sim::{Record, Trajectory};
use wheelset_plant::traction::{Characteristic, RUNAWAY_HOLD_S, RUNAWAY_SLIP_MPS};
use wheelset_report::svg::{Figure, Plot, Series, Style, PALETTE};

fn series(tr: &Trajectory, label: &str, f: impl Fn(&Record) -> f64) -> Series {
    Series::line(label, tr.records.iter().map(|r| (r.t_s, f(r))).collect())
}

fn label(tr: &Trajectory) -> String {
    tr.info.control.clone()
}

/// Writes the time-history figures of `runs` (first = main run, others overlaid for
/// comparison) into `dir`; returns the files written.
///
/// - `lateral.svg` (Fig. 6 for `curve`, Fig. 9 for `beating`): `y` in mm against the
///   pure rolling line `y0`.
/// - `torque.svg` (Fig. 7 for `curve`): yaw torque (control torque or passive spring
///   torque).
/// - `creep.svg` (Fig. 8 for `curve`): longitudinal and lateral creep forces.
/// - `traction.svg`: current and reference, voltage, speed, gear wind-up (Fig. 9 for
///   `beating`: the beating shows in the wind-up and in `y`).
///
/// Titles name the paper's figure only for the scenario that reproduces it.
pub fn write_time_histories(runs: &[Trajectory], dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let Some(main) = runs.first() else {
        return Ok(vec![]);
    };
    let title = format!("scenario {}", main.info.scenario);
    // The paper's figure each plot reproduces: `curve` is Figs. 6-8, `beating` Fig. 9;
    // other scenarios are no figure of the paper.
    let fig = |curve: &str, beating: &str| -> String {
        let n = match main.info.scenario.as_str() {
            "curve" => curve,
            "beating" => beating,
            _ => "",
        };
        if n.is_empty() {
            String::new()
        } else {
            format!(" (Fig. {n})")
        }
    };
    let mut files = Vec::new();
    let mut save = |name: &str, fig: Figure| -> std::io::Result<()> {
        let p = dir.join(name);
        fig.save(&p)?;
        files.push(p);
        Ok(())
    };

    // Fig. 6
    let mut p = Plot::new(&format!("Lateral displacement{}", fig("6", "9")))
        .x_label("t (s)")
        .y_label("y (mm)");
    for tr in runs {
        p = p.series(series(tr, &format!("y, {}", label(tr)), |r| r.y_m * 1e3));
    }
    p = p.series(
        series(main, "pure rolling line y0", |r| r.y0_m * 1e3)
            .style(Style::Dashed)
            .color("#000"),
    );
    let mut psi = Plot::new("Yaw angle")
        .x_label("t (s)")
        .y_label("psi (mrad)");
    for tr in runs {
        psi = psi.series(series(tr, &label(tr), |r| r.psi_rad * 1e3));
    }
    // Zoom on the traction step (Fig. 9's beating shows here).
    let t_step = main
        .records
        .iter()
        .find(|r| r.demand_nm != 0.0)
        .map_or(5.0, |r| r.t_s);
    let mut zoom = Plot::new("y - y0 around the traction step")
        .x_label("t (s)")
        .y_label("y - y0 (mm)")
        .x_range(t_step - 0.2, t_step + 2.0);
    for tr in runs {
        let pts = tr
            .records
            .iter()
            .filter(|r| r.t_s >= t_step - 0.2 && r.t_s <= t_step + 2.0)
            .map(|r| (r.t_s, (r.y_m - r.y0_m) * 1e3))
            .collect();
        zoom = zoom.series(Series::line(&label(tr), pts));
    }
    save(
        "lateral.svg",
        Figure::new(&title).panel(p).panel(psi).panel(zoom),
    )?;

    // Fig. 7
    let mut p = Plot::new(&format!(
        "Yaw torque: control (active) / suspension (passive){}",
        fig("7", "")
    ))
    .x_label("t (s)")
    .y_label("T_psi (N m)");
    for tr in runs {
        p = p.series(series(tr, &format!("T_psi, {}", label(tr)), |r| r.t_psi_nm));
    }
    save("torque.svg", Figure::new(&title).panel(p))?;

    // Fig. 8: one panel per force, one colour per run throughout (the main run solid,
    // the compared ones dashed and drawn over it, so that where they coincide both
    // show).
    let per_run = |title: &str, y_label: &str, f: &dyn Fn(&Record) -> f64| {
        let mut p = Plot::new(title).x_label("t (s)").y_label(y_label);
        for (k, tr) in runs.iter().enumerate() {
            let s = series(tr, &label(tr), f).color(PALETTE[k % PALETTE.len()]);
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
        Figure::new(&title).panel(fxr).panel(fxl).panel(fy),
    )?;

    // Traction and Fig. 9 view.
    let ia = Plot::new("Armature current")
        .x_label("t (s)")
        .y_label("i_a (A)")
        .series(series(main, "i_a", |r| r.i_a_a))
        .series(series(main, "i_ref", |r| r.i_ref_a).style(Style::Dashed));
    let ua = Plot::new("Armature voltage")
        .x_label("t (s)")
        .y_label("u_a (V)")
        .series(series(main, "u_a", |r| r.u_a_v));
    let wind = Plot::new(&format!(
        "Gear wind-up and axle twist{}",
        fig("", "9: beating")
    ))
    .x_label("t (s)")
    .y_label("angle (mrad)")
    .series(series(main, "wind-up phi_L - theta_m/n", |r| {
        r.wind_rad * 1e3
    }))
    .series(series(main, "twist phi_R - phi_L", |r| r.twist_rad * 1e3));
    let v = Plot::new("Forward speed")
        .x_label("t (s)")
        .y_label("v (m/s)")
        .series(series(main, "v", |r| r.v_mps));
    save(
        "traction.svg",
        Figure::new(&format!("{title}, control {}", label(main)))
            .panel(ia)
            .panel(ua)
            .panel(wind)
            .panel(v),
    )?;
    Ok(files)
}

/// Writes `modes_case_<id>.svg`: the root locus (eigenvalues of every named mode over
/// the sweep, structural zero left out; the 10 MN end marked with crosses), and the
/// frequency and damping ratio of each mode against the creep coefficient.
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
    // The subtitle states where the stability changes (the bisected crossings), so the
    // 10 MN end's markers are not read as a crossing there.
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
        "Root locus over f11 = f22 = 1-10 MN ({crossings}; x markers: the 10 MN end)"
    ))
    .x_label("Re (1/s)")
    .y_label("Im (rad/s)")
    .x_range(1.05 * re_lo, 1.05 * re_hi)
    .y_range(-1.05 * im_hi, 1.05 * im_hi)
    .size(900.0, 560.0)
    .vline(0.0);
    let mut freq = Plot::new("Damped frequency of each mode")
        .size(900.0, 360.0)
        .x_label("creep coefficient f11 = f22 (MN)")
        .y_label("frequency (Hz)");
    let mut zeta = Plot::new("Damping ratio of each mode (below 0 = unstable)")
        .size(900.0, 360.0)
        .x_label("creep coefficient f11 = f22 (MN)")
        .y_label("zeta")
        .hline(0.0);
    for (m, name) in names.iter().enumerate() {
        let col = PALETTE[m % PALETTE.len()];
        let mut pts = Vec::new();
        for k in (0..n_pts).step_by(stride) {
            for (b, l) in sw.eig[k].iter().enumerate() {
                if &sw.branch_names[b] == name {
                    pts.push((l.re, l.im));
                }
            }
        }
        locus = locus.series(Series::scatter(name, pts).color(col));
        let top: Vec<(f64, f64)> = sw.eig[n_pts - 1]
            .iter()
            .enumerate()
            .filter(|(b, _)| &sw.branch_names[*b] == name)
            .map(|(_, l)| (l.re, l.im))
            .collect();
        locus = locus.series(Series::scatter("", top).style(Style::Crosses).color(col));
        let vals: Vec<(f64, f64, f64)> = (0..n_pts)
            .filter_map(|k| {
                sw.mode_eig(name, k).map(|(_, l)| {
                    let mag = l.norm();
                    (
                        sw.creep[k] * 1e-6,
                        l.im.abs() / (2.0 * std::f64::consts::PI),
                        if mag > 0.0 { -l.re / mag } else { 0.0 },
                    )
                })
            })
            .collect();
        freq =
            freq.series(Series::line(name, vals.iter().map(|v| (v.0, v.1)).collect()).color(col));
        zeta =
            zeta.series(Series::line(name, vals.iter().map(|v| (v.0, v.2)).collect()).color(col));
    }
    for c in &sw.crossings {
        zeta = zeta.vline(c.creep_n * 1e-6);
    }
    let path = dir.join(format!("modes_case_{}.svg", sw.case.id()));
    Figure::new(&format!("Case ({}): {}", sw.case.id(), sw.case.label()))
        .panel(locus)
        .panel(freq)
        .panel(zeta)
        .save(&path)?;
    Ok(path)
}

/// One run of [`write_figure`].
#[derive(Debug, Clone, Copy)]
pub struct FigureRun<'a> {
    /// Legend label (e.g. `protection on`).
    pub label: &'a str,
    /// The run.
    pub tr: &'a Trajectory,
    /// The slip regulator's set point while the protection acted, `(t_s, m/s)`
    /// ([`wheelset_loop::core::CoreRun::set_point`]); empty for a run without protection.
    pub set_point: &'a [(f64, f64)],
}

/// The traction engineer's figure (`adhesion.svg` in `dir`): traction force delivered,
/// then the slip velocity of each run in its own panel and scale (a protected wheel's
/// tenths of m/s against its regulator's set point and the detection threshold
/// `slip_on_mps`; an unprotected one's runaway against the runaway threshold), then the
/// adhesion available and used. Each run keeps its colour across the panels.
pub fn write_figure(
    runs: &[FigureRun<'_>],
    slip_on_mps: f64,
    dir: &Path,
) -> std::io::Result<PathBuf> {
    std::fs::create_dir_all(dir)?;
    let colour = |k: usize| PALETTE[k % PALETTE.len()];
    // One time axis for every panel: a run stopped as diverged ends early.
    let end = runs
        .iter()
        .filter_map(|r| r.tr.records.last().map(|x| x.t_s))
        .fold(0.0f64, f64::max);
    let panel = |title: &str, y_label: &str| {
        let p = Plot::new(title).x_label("t (s)").y_label(y_label);
        if end > 0.0 {
            p.x_range(0.0, end)
        } else {
            p
        }
    };
    let mut force = panel("Traction force delivered F_xR + F_xL", "F (kN)");
    let mut mu = panel("Adhesion available (peak) and used", "F / Q (1)");
    let mut slips = Vec::new();
    for (k, run) in runs.iter().enumerate() {
        let pts = |f: &dyn Fn(&Record) -> f64| -> Vec<(f64, f64)> {
            run.tr.records.iter().map(|r| (r.t_s, f(r))).collect()
        };
        force = force.series(
            Series::line(run.label, pts(&|r| (r.fx_r_n + r.fx_l_n) * 1e-3)).color(colour(k)),
        );
        mu = mu.series(
            Series::line(&format!("used, {}", run.label), pts(&|r| r.mu_used)).color(colour(k)),
        );
        if k == 0 {
            mu = mu.series(
                Series::line("available", pts(&|r| r.mu_avail))
                    .style(Style::Dashed)
                    .color("#000"),
            );
        }
        let slip = panel(&format!("Slip velocity, {}", run.label), "slip (m/s)")
            .series(Series::line(run.label, pts(&|r| r.slip_mps)).color(colour(k)));
        slips.push(if run.set_point.is_empty() {
            slip.hmark(
                RUNAWAY_SLIP_MPS,
                &format!("runaway: above {RUNAWAY_SLIP_MPS} m/s for {RUNAWAY_HOLD_S} s"),
                "#D55E00",
            )
        } else {
            // The set point, broken where the protection did not act.
            let mut sp = Vec::with_capacity(run.set_point.len());
            let dt = run
                .set_point
                .windows(2)
                .map(|w| w[1].0 - w[0].0)
                .fold(f64::INFINITY, f64::min);
            for w in run.set_point.windows(2) {
                sp.push(w[0]);
                if w[1].0 - w[0].0 > 1.5 * dt {
                    sp.push((f64::NAN, f64::NAN));
                }
            }
            sp.extend(run.set_point.last());
            slip.series(
                Series::line("regulator's set point", sp)
                    .style(Style::Dashed)
                    .color("#000"),
            )
            .hmark(
                slip_on_mps,
                &format!("detection: slip above {slip_on_mps} m/s"),
                "#D55E00",
            )
        });
    }
    let path = dir.join("adhesion.svg");
    let mut fig = Figure::new("low adhesion: traction, slip, adhesion").panel(force);
    for p in slips {
        fig = fig.panel(p);
    }
    fig.panel(mu).save(&path)?;
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
    .x_label("longitudinal creepage (1)")
    .y_label("F / Q (1)")
    .series(Series::line(&format!("{}", ch.condition), pts))
    .series(
        Series::line("linear law f11 s / Q", lin)
            .style(Style::Dashed)
            .color("#000"),
    )
    .hline(ch.mu_peak);
    Figure::new(&format!("adhesion: {}", ch.source)).panel(plot)
}

#[cfg(test)]
mod tests;
