//! `sim-host run`: a scenario on the continuous loop or the control core, the printed
//! summary and the run's JSON summary.

use std::path::PathBuf;
use wheelset_plant::control::YawLaw;
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::{run_continuous, Record, Trajectory};
use wheelset_report::outln;

use super::loop_device::{cmd_run_device, DeviceArgs, LoopKind, OnOff};
use super::{check_outputs, create_file, io_fail, load_params, warn, write_json, Failure};

#[derive(clap::Args)]
pub(crate) struct RunArgs {
    /// Built-in scenario (`curve`, `beating`) or a scenario TOML file.
    #[arg(long, default_value = "curve")]
    pub(crate) scenario: String,
    /// Yaw control mode.
    #[arg(long, value_enum, default_value = "lead")]
    pub(crate) control: YawLaw,
    /// Parameter file (TOML, any subset of the parameters); the scenario's [params]
    /// table is applied on top.
    #[arg(long)]
    pub(crate) params: Option<PathBuf>,
    /// Write the trajectory as CSV (1 ms samples by default; directories created).
    #[arg(long)]
    pub(crate) csv: Option<PathBuf>,
    /// Write the run's summary as JSON (with `[[adhesion]]` sections: the `adhesion`
    /// object of `wheelset_plant::traction`; directories created).
    #[arg(long)]
    pub(crate) json: Option<PathBuf>,
    /// Write SVG plots (lateral, torque, creep, traction) into this directory.
    #[arg(long)]
    pub(crate) plot: Option<PathBuf>,
    /// Also run these modes and overlay them on the plots (e.g. `--compare passive`).
    #[arg(long, value_enum)]
    pub(crate) compare: Vec<YawLaw>,
    /// Print the state of every run (this one and the `--compare` ones) at this time, s
    /// (repeatable; the nearest output sample), and each run's peaks.
    #[arg(long = "at", value_name = "T_S", allow_negative_numbers = true)]
    pub(crate) at: Vec<f64>,
    /// With `--loop core` on a scenario with `[[adhesion]]` sections: print only the
    /// sections table with and without wheel-slip protection (both core runs), as
    /// Markdown (the README's generated comparison table).
    #[arg(long)]
    pub(crate) sections_table: bool,
    /// The run is meant to diverge (a demonstration of an unstable case, e.g. Fig. 9's
    /// beating or a slipping wheel without protection): exit 0 when it does and 1 when it
    /// does not. Without it a diverging run exits 1, naming what diverged, and so does a
    /// device run whose drive limit-cycles (the device's drive alarm).
    #[arg(long)]
    pub(crate) expect_divergence: bool,
    #[command(flatten)]
    pub(crate) device: DeviceArgs,
}

/// The exit of a run as `--expect-divergence` says (after every output is written).
pub(crate) fn judge_divergence(a: &RunArgs, tr: &Trajectory) -> Result<(), Failure> {
    match (wheelset_plant::outcome::stop_of(tr), a.expect_divergence) {
        (Some(stop), true) => {
            outln!("diverged as expected (--expect-divergence): {stop}");
            Ok(())
        }
        (Some(stop), false) => Err(Failure::failed(format!(
            "the run diverged: {stop} (add --expect-divergence if that is its point)"
        ))),
        (None, true) => Err(Failure::failed(
            "--expect-divergence: the run did not diverge".into(),
        )),
        (None, false) => Ok(()),
    }
}

pub(crate) fn cmd_run(a: &RunArgs) -> Result<(), Failure> {
    if a.device.loop_kind != LoopKind::Device {
        if let Some(flag) = a.device.given().first() {
            return Err(Failure::bad(format!(
                    "{flag}: applies only to the device loop over the simulated link (add --loop device); \
                     the {} loop has no link, rate or device",
                    if a.device.loop_kind == LoopKind::Core {
                        "core"
                    } else {
                        "continuous"
                    }
                )));
        }
    }
    let base = load_params(&a.params)?;
    let sc = Scenario::load(&a.scenario, &base)?;
    check_outputs(
        &[("--csv", a.csv.as_deref()), ("--json", a.json.as_deref())],
        &[("--plot", a.plot.as_deref())],
    )?;
    if a.sections_table && (a.device.loop_kind != LoopKind::Core || sc.adhesion.is_empty()) {
        return Err(Failure::bad(
            "--sections-table: only with --loop core on a scenario with [[adhesion]] \
                  sections"
                .into(),
        ));
    }
    let end_s = sc.duration_ns as f64 * 1e-9;
    if let Some(t) =
        a.at.iter()
            .find(|t| !(t.is_finite() && (0.0..=end_s).contains(*t)))
    {
        return Err(Failure::bad(format!(
            "--at {t}: must be a time within the run, 0-{end_s} s"
        )));
    }
    if !a.at.is_empty() && a.device.loop_kind != LoopKind::Continuous {
        return Err(Failure::bad(
            "--at: only for the continuous loop (the default --loop)".into(),
        ));
    }
    // Every trajectory kept at once: this one, the compared ones, the device's reference.
    let kept = 1
        + a.compare.iter().filter(|&&c| c != a.control).count() as u64
        + u64::from(a.device.loop_kind == LoopKind::Device);
    wheelset_plant::memory::check_runs(sc.duration_ns, sc.output_dt_ns, None, kept)
        .map_err(|msg| Failure::bad(format!("{}: {msg}", sc.source)))?;
    for law in std::iter::once(a.control).chain(a.compare.iter().copied()) {
        if let Some(w) = sc.law_warning(law) {
            warn(&w);
        }
    }
    if a.device.loop_kind == LoopKind::Device {
        return cmd_run_device(a, &sc);
    }
    if a.device.loop_kind == LoopKind::Core {
        return cmd_run_core(a, &sc);
    }
    let mut runs = vec![run_continuous(&sc, a.control)];
    runs.extend(compared(a, &sc));
    let main = &runs[0];
    print_summary(&sc, main);
    print_modes(&sc, a.control);
    print_at(&runs, &a.at);
    write_run_summary(&a.json, &sc, main, None)?;
    write_csv_and_plots(a, &runs)?;
    judge_divergence(a, main)
}

pub(crate) fn compared<'a>(
    a: &'a RunArgs,
    sc: &'a Scenario,
) -> impl Iterator<Item = Trajectory> + 'a {
    a.compare
        .iter()
        .filter(|&&c| c != a.control)
        .map(|&c| run_continuous(sc, c))
}

fn write_csv_and_plots(a: &RunArgs, runs: &[Trajectory]) -> Result<(), Failure> {
    if let (Some(path), Some(main)) = (&a.csv, runs.first()) {
        main.write_csv(create_file(path)?)
            .map_err(|e| io_fail(path, e))?;
        outln!("csv: {} ({} rows)", path.display(), main.records.len());
    }
    write_plots(a, runs)
}

pub(crate) fn write_plots(a: &RunArgs, runs: &[Trajectory]) -> Result<(), Failure> {
    if let Some(dir) = &a.plot {
        let files = crate::figures::write_time_histories(runs, dir).map_err(|e| io_fail(dir, e))?;
        for f in files {
            outln!("plot: {}", f.display());
        }
    }
    Ok(())
}

/// Prints the linearised modes of the scenario's plant with `law` at its operating point,
/// least damped first.
pub(crate) fn print_modes(sc: &Scenario, law: YawLaw) {
    let Some(modes) = wheelset_plant::modes::modes_at_point(&sc.params, sc.axle, sc.drive, law)
    else {
        return;
    };
    outln!(
        "modes of this plant and law at pure rolling on straight track, f11 {:.1} MN, f22 {:.1} MN (least damped first; structural zero left out):",
        sc.params.f11 * 1e-6,
        sc.params.f22 * 1e-6
    );
    for m in modes {
        let shares: Vec<String> = wheelset_plant::modes::GROUPS
            .iter()
            .zip(m.participation)
            .filter(|(_, x)| *x >= 0.05)
            .map(|(g, x)| format!("{g} {x:.2}"))
            .collect();
        outln!(
            "  {:<16} {:>7.2} Hz  zeta {:+.3}  lambda {:+.2} {:+.2}j 1/s; participation: {}",
            m.mode.name,
            m.mode.freq_hz,
            m.mode.zeta,
            m.mode.re,
            m.mode.im,
            shares.join(", ")
        );
    }
}

/// `--at`: the state of every run at each time (nearest output sample), then each
/// run's peaks. `y/y0` is the displacement over the pure rolling line (1 = on it).
pub(crate) fn print_at(runs: &[Trajectory], at: &[f64]) {
    if at.is_empty() {
        return;
    }
    outln!(
        "{:>6} {:<8} {:>9} {:>9} {:>7} {:>9} {:>11} {:>8} {:>8} {:>8}",
        "t_s",
        "control",
        "y_mm",
        "y0_mm",
        "y/y0",
        "T_psi_Nm",
        "T_spring_Nm",
        "Fx_R_N",
        "Fx_L_N",
        "Fy_N"
    );
    for &t in at {
        for tr in runs {
            let Some(r) = tr.at(t) else { continue };
            outln!(
                "{:>6.3} {:<8} {:>9.4} {:>9.4} {:>7.3} {:>9.1} {:>11.1} {:>8.1} {:>8.1} {:>8.1}",
                r.t_s,
                tr.info.control,
                r.y_m * 1e3,
                r.y0_m * 1e3,
                if r.y0_m != 0.0 {
                    r.y_m / r.y0_m
                } else {
                    f64::NAN
                },
                r.t_psi_nm,
                r.t_spring_nm,
                r.fx_r_n,
                r.fx_l_n,
                r.fy_n
            );
        }
    }
    for tr in runs {
        let [y, t_psi, fx, fy] = peaks(tr);
        outln!(
            "peaks, {}: |y| {y:.4} mm, |T_psi| {t_psi:.1} N m, |F_x| {fx:.1} N, |F_y| {fy:.1} N",
            tr.info.control
        );
    }
}

/// The peaks of a run: `|y|` (mm), `|T_psi|` (N m), `|F_x|` of either wheel (N), `|F_y|` (N).
fn peaks(tr: &Trajectory) -> [f64; 4] {
    let max = |f: fn(&Record) -> f64| tr.records.iter().map(f).fold(0.0f64, |a, b| a.max(b.abs()));
    [
        max(|r| r.y_m) * 1e3,
        max(|r| r.t_psi_nm),
        max(|r| r.fx_r_n.abs().max(r.fx_l_n.abs())),
        max(|r| r.fy_n),
    ]
}

/// `--loop core`: the f64 control core on the plant; with `--plot` and `[[adhesion]]`
/// sections also `adhesion.svg` with and without protection.
pub(crate) fn cmd_run_core(a: &RunArgs, sc: &Scenario) -> Result<(), Failure> {
    use wheelset_loop::core::run_core;
    let fail = |e: wheelset_loop::core::CoreError| Failure::bad(e.to_string());
    if a.sections_table {
        let on = run_core::<f64>(sc, a.control, true).map_err(fail)?;
        let off = run_core::<f64>(sc, a.control, false).map_err(fail)?;
        let shown = format!(
            "cargo sim run --scenario {} --control {} --loop core --sections-table",
            a.scenario,
            a.control.name()
        );
        let table =
            wheelset_plant::traction::sections_table(sc, &on.0, &off.0, &shown).unwrap_or_default();
        outln!("{}", table.trim_end());
        return Ok(());
    }
    let wsp = a.device.wsp != Some(OnOff::Off);
    let (tr, c) = run_core::<f64>(sc, a.control, wsp).map_err(fail)?;
    print_summary(sc, &tr);
    let verdict = judge_divergence(a, &tr);
    outln!(
        "wheel-slip protection {}: {} events, {} ticks acting",
        if wsp { "on" } else { "off" },
        c.wsp_events,
        c.wsp_ticks
    );
    write_run_summary(&a.json, sc, &tr, Some(wsp))?;
    let mut runs = vec![tr];
    if a.plot.is_some() {
        runs.extend(a.compare.iter().map(|&k| run_continuous(sc, k)));
    }
    write_csv_and_plots(a, &runs)?;
    if let Some(dir) = &a.plot {
        if !sc.adhesion.is_empty() {
            use crate::figures::FigureRun;
            let (other, oc) = run_core::<f64>(sc, a.control, !wsp).map_err(fail)?;
            let this = (&runs[0], &c);
            let (on, off) = if wsp {
                (this, (&other, &oc))
            } else {
                ((&other, &oc), this)
            };
            let slip_on =
                wheelset_loop::device_loop::control_config(&sc.params, a.control, sc.drive)
                    .wsp
                    .slip_on_mps;
            let runs =
                [("protection on", on), ("protection off", off)].map(|(label, (tr, core))| {
                    FigureRun {
                        label,
                        tr,
                        set_point: &core.set_point,
                    }
                });
            let f =
                crate::figures::write_figure(&runs, slip_on, dir).map_err(|e| io_fail(dir, e))?;
            outln!("plot: {}", f.display());
        }
    }
    verdict
}

/// The summary JSON of a run (`--json`) with the `adhesion` object; prints the sections table.
pub(crate) fn write_run_summary(
    path: &Option<PathBuf>,
    sc: &Scenario,
    tr: &Trajectory,
    wsp: Option<bool>,
) -> Result<(), Failure> {
    let adhesion = wheelset_plant::traction::summary(sc, tr);
    if let Some(a) = &adhesion {
        outln!(
            "adhesion: runaway {}, slip peak {:.3} m/s",
            a.runaway,
            a.slip_peak_mps
        );
        outln!("  t0-t1 s      condition  mu_peak  mu_used_mean  utilisation  slip_peak_mps");
        for s in &a.sections {
            outln!(
                "  {:>5.1}-{:<5.1}  {:<9}  {:>7.4}  {:>12.4}  {:>11.3}  {:>13.3}",
                s.t0,
                s.t1,
                s.condition,
                s.mu_peak,
                s.mu_used_mean,
                s.utilisation,
                s.slip_peak_mps
            );
        }
    }
    let Some(path) = path else {
        return Ok(());
    };
    let json = serde_json::json!({
        "scenario": sc.name,
        "source": sc.source,
        "run": tr.info,
        "wsp": wsp,
        "adhesion": adhesion,
    });
    write_json(path, &json, true, "json:")
}

pub(crate) fn print_summary(sc: &Scenario, tr: &Trajectory) {
    let p = &sc.params;
    outln!(
        "scenario {} ({}), control {}, {} s, RK4 dt {} s, {} steps",
        sc.name,
        sc.source,
        tr.info.control,
        sc.duration_ns as f64 * 1e-9,
        tr.info.dt_s,
        tr.info.steps
    );
    outln!(
        "plant: axle {}, drive {}, yaw spring {}; project defaults used: k_lat {} N/m, k_t {:.4e} N m/rad, k_gear {:.4e} N m/rad, PI Ti {} s",
        sc.axle,
        sc.drive,
        tr.info.control == "passive",
        p.k_lat,
        p.k_t(),
        p.k_gear(),
        p.pi_ti
    );
    let [y, t_psi, fx, fy] = peaks(tr);
    outln!(
        "max |y| {y:.4} mm, max |T_psi| {t_psi:.1} N m, max |F_x| {fx:.1} N, max |F_y| {fy:.1} N"
    );
    if let Some(stop) = wheelset_plant::outcome::stop_of(tr) {
        outln!("WARNING: {stop}");
    }
    if let Some(last) = tr.records.last() {
        outln!(
            "end: v {:.4} m/s, i_a {:.2} A, u_a {:.1} V",
            last.v_mps,
            last.i_a_a,
            last.u_a_v
        );
    }
}
