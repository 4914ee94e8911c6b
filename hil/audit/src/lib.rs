//! `hil audit`: the fixed-point accuracy audit of the control core per controller at the
//! configured rates and Q formats (`docs/audit.md`; one module per part), each figure
//! judged against [`Tolerances`] (exit code 1 on any fail). `hil audit` parses
//! [`AuditArgs`] (one `clap::Args` for the command line and the library) and calls [`run`].
#![deny(missing_docs)]

pub mod args;
pub mod bounds;
mod checks;
pub mod closed;
pub mod diagnose;
mod formats;
pub mod limits;
pub mod model;
pub mod on_target;
mod per_controller;
mod plots;
pub mod qdyn;
pub mod ranges;
mod readme_block;
mod recordings;
mod response;
mod scenarios;
pub mod tolerances;
pub mod wcpg;
mod writeup;
mod writeup_sections;

use wheelset_control::{Config, ConfigError, Fx, Sample};

pub use args::{config_of, AuditArgs, AuditError};
use checks::all_checks;
pub use model::{
    Audit, CoefRow, ControllerAudit, DcGain, FreqPoint, GainPhase, PoleZero, Recommendation, Roots,
    Sweep, Worst,
};
use per_controller::{audit_controller, grid, NAMED_HZ};
pub use tolerances::{counts_words, Check, Status, Tolerances};

use args::{command_line, formats_of};
use qdyn::{Formats, QDyn};
use ranges::{observe, Observed, Scenario};
use response::Kind;
use tolerances::judge;

/// Every accuracy figure of sample type `T` (no recommendation, no sweep).
pub(crate) struct Core {
    pub(crate) controllers: Vec<ControllerAudit>,
    pub(crate) observed: Observed,
}

/// Run the per-controller audits and the scenario observation with `T`.
pub(crate) fn core<T: Sample>(
    cfg: &Config,
    tol: &Tolerances,
    fmt: &Formats,
    scenarios: &[Scenario],
    freqs_of: &dyn Fn(f64) -> Vec<(f64, bool)>,
) -> Result<Core, ConfigError> {
    let lsb = fmt.signal.lsb();
    let controllers = Kind::active(cfg)
        .iter()
        .map(|&k| audit_controller::<T>(k, cfg, tol, lsb, &freqs_of(k.rate_hz(cfg))))
        .collect::<Result<Vec<_>, _>>()?;
    let observed = observe::<T>(cfg, scenarios, fmt.signal, &|c| *c)?;
    Ok(Core {
        controllers,
        observed,
    })
}

/// Run the core with the instrumented type at `fmt` (counting arithmetic saturations).
pub(crate) fn core_dyn(
    cfg: &Config,
    tol: &Tolerances,
    fmt: Formats,
    scenarios: &[Scenario],
    freqs_of: &dyn Fn(f64) -> Vec<(f64, bool)>,
) -> Result<Core, ConfigError> {
    let (mut c, n) = counted(fmt, || core::<QDyn>(cfg, tol, &fmt, scenarios, freqs_of))?;
    c.observed.arithmetic_saturations = Some(n);
    Ok(c)
}

/// `f`'s result and the arithmetic saturations the instrumented type counted in it, at `fmt`.
fn counted<R>(
    fmt: Formats,
    f: impl FnOnce() -> Result<R, ConfigError>,
) -> Result<(R, u64), ConfigError> {
    qdyn::with_formats(fmt, || {
        qdyn::take_saturations();
        Ok((f()?, qdyn::take_saturations()))
    })
}

/// The proofs ([`bounds`]) for sample type `T` (inside [`qdyn::with_formats`] for the
/// instrumented type), with the observed ranges and the observed rounding errors.
fn proofs_for<T: Sample>(
    cfg: &Config,
    fmt: Formats,
    observed: &Observed,
    scenarios: &[Scenario],
) -> Result<bounds::Proofs, ConfigError> {
    let k = bounds::Quantised::of::<T>(cfg)?;
    let err = bounds::observed_errors::<T>(cfg, &k, scenarios)?;
    Ok(bounds::prove(cfg, &k, fmt.signal, observed, err))
}

/// Run the audit as `hil audit` does; returns the exit code (0 pass/warn, 1 fail).
pub fn run(args: &AuditArgs) -> Result<u8, AuditError> {
    // The outputs are checked before the audit's minutes of work, not after.
    if let Some(p) = &args.json {
        wheelset_report::output::check_file_flag("--json", p).map_err(AuditError::Usage)?;
    }
    if let Some(d) = &args.report {
        wheelset_report::output::check_dir_flag("--report", d).map_err(AuditError::Usage)?;
    }
    let audit = build(args)?;
    if let Some(p) = &args.json {
        let s = serde_json::to_string_pretty(&audit)
            .map_err(|e| AuditError::io(p)(std::io::Error::other(e)))?;
        write(p, &s)?;
    }
    if let Some(dir) = &args.report {
        writeup::write_report(&audit, dir)?;
    }
    if args.readme_block {
        wheelset_report::out!("{}", readme_block::block(&audit));
    } else {
        wheelset_report::out!(
            "{}",
            writeup::summary(&audit, args.report.as_deref(), args.quiet)
        );
    }
    Ok(if audit.verdict == Status::Fail { 1 } else { 0 })
}

/// Write `s` to `p`, creating the parent directory.
pub(crate) fn write(p: &std::path::Path, s: &str) -> Result<(), AuditError> {
    if let Some(d) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d).map_err(AuditError::io(d))?;
    }
    std::fs::write(p, s).map_err(AuditError::io(p))
}

/// Compute the whole audit (no output written).
pub fn build(args: &AuditArgs) -> Result<Audit, AuditError> {
    let fmt = formats_of(args)?;
    let cfg = config_of(args);
    let params = args.params.as_ref().map(|p| p.params.clone());
    let params = params.unwrap_or_default();
    cfg.validate()?;
    let tol = Tolerances::default();
    let mut scenarios = ranges::synthetic(&cfg);
    let mut scenario_notes = Vec::new();
    if args.no_plant {
        scenario_notes.push("closed-loop plant scenarios skipped (--no-plant)".to_string());
    } else {
        let (s, n) = recordings::scenarios(&cfg, &params);
        scenarios.extend(s);
        scenario_notes.extend(n);
    }
    let production = fmt == Formats::PRODUCTION;
    let c = if production {
        let mut c = core::<Fx>(&cfg, &tol, &fmt, &scenarios, &grid)?;
        // Fx's silent saturations, counted by the instrumented type (bit-identical here).
        let o = counted(fmt, || {
            observe::<QDyn>(&cfg, &scenarios, fmt.signal, &|c| *c)
        })?;
        c.observed.arithmetic_saturations = Some(o.1);
        c
    } else {
        core_dyn(&cfg, &tol, fmt, &scenarios, &grid)?
    };
    let mut checks = all_checks(&c, &tol, &cfg);
    if let Some(n) = c.observed.arithmetic_saturations {
        checks.push(
            judge(
                "all",
                "saturations inside the fixed-point arithmetic (instrumented run)",
                n as f64,
                (0.0, 0.0),
                "operations",
                "saturating operations",
            )
            .with_remedy(
                "an operation saturated inside the arithmetic although its operands fit: more \
             integer bits (audit a candidate with --signal-q I.F, a larger I); the report's \
             ranges table shows which signal is nearest its limit",
            ),
        );
    }
    let sweep = (!args.no_sweep && !args.readme_block)
        .then(|| formats::sweep(&cfg, &tol, &fmt, &c.controllers));
    let proofs = if production {
        proofs_for::<Fx>(&cfg, fmt, &c.observed, &scenarios)?
    } else {
        qdyn::with_formats(fmt, || {
            proofs_for::<QDyn>(&cfg, fmt, &c.observed, &scenarios)
        })?
    };
    checks.extend(checks::proof_checks(&proofs, &tol));
    let closed_loop = if args.no_plant || args.no_closed_loop {
        scenario_notes
            .push("closed-loop audit skipped (--no-plant or --no-closed-loop)".to_string());
        None
    } else {
        let lead_err = proofs.error_bounds.first().map(|e| e.proven).unwrap_or(0.0);
        let k = bounds::Quantised::of::<Fx>(&cfg)?;
        match (
            closed::limit_cycle(lead_err, &params),
            closed::margins(&cfg, &k, &params),
        ) {
            (Ok(lc), Ok(m)) => {
                checks.extend(checks::closed_loop_checks(&lc, &m, &cfg, &params));
                Some(closed::ClosedLoopAudit {
                    limit_cycle: lc,
                    margins: m,
                    note: "the fixed-point runtime in the loop with the plant through the \
                           wire (curve, lead), against the continuous f64 reference"
                        .into(),
                })
            }
            (Err(e), _) | (_, Err(e)) => {
                scenario_notes.push(format!("closed-loop audit not run: {e}"));
                checks.push(Check::not_run(
                    "yaw_lead",
                    "closed-loop audit (limit cycle, margins)",
                    &e,
                    "the device run or the margins' plant failed at this operating point \
                     (--params): run `hil run --params FILE` to see the loop, or pass \
                     --no-closed-loop to audit without it",
                ));
                None
            }
        }
    };
    let diagnosis = if production {
        let steps = scenarios.iter().find(|s| s.name == "full_scale_steps");
        Some(diagnose::Diagnosis {
            pi: steps
                .map(|sc| diagnose::pi_attribution(&cfg, sc))
                .transpose()?,
            lead_amplitude: diagnose::lead_amplitude(&cfg, &tol)?,
        })
    } else {
        None
    };
    if let Some(p) = diagnosis.as_ref().and_then(|d| d.pi.as_ref()) {
        let item = format!("u_a max error vs f64, scenario {}", p.scenario);
        for c in checks.iter_mut().filter(|c| c.item == item) {
            c.reason += &format!(
                "; by experiment: {} (of {:.1} LSB)",
                p.shares_text(),
                p.baseline_lsb,
            );
            c.remedy.clone_from(&p.remedy);
        }
    }
    let target = if args.no_target {
        on_target::TargetReport::without(
            on_target::TargetOutcome::Skipped,
            "target: not run (--no-target)",
        )
    } else if !production {
        on_target::TargetReport::without(
            on_target::TargetOutcome::NotApplicable,
            "target: not applicable (the firmware runs the production formats)",
        )
    } else {
        let w: Vec<(&Scenario, f64)> = [("full_scale_steps", 0.0), ("chirp", 0.0), ("curve", 4.8)]
            .into_iter()
            .filter_map(|(n, from)| Some((scenarios.iter().find(|s| s.name == n)?, from)))
            .collect();
        on_target::compare(&w, args.target_ticks, &cfg)
    };
    for r in &target.runs {
        let mut c = judge(
            "all",
            &format!(
                "target vs host Actuation frames, scenario {} ({} ticks)",
                r.scenario, r.ticks
            ),
            r.mismatches as f64,
            (0.0, 0.0),
            "frames",
            "frames differing",
        );
        c.reason = format!(
            "{} of {} frames differ between QEMU and the host (max code difference T_psi {} \
             dNm, u_a {} cV); target vs f64 max {:.1}/{:.1} wire LSB, host vs f64 {:.1}/{:.1}",
            r.mismatches,
            r.ticks,
            r.max_code_diff.0,
            r.max_code_diff.1,
            r.target_vs_f64_wire_lsb.0,
            r.target_vs_f64_wire_lsb.1,
            r.host_vs_f64_wire_lsb.0,
            r.host_vs_f64_wire_lsb.1
        );
        checks.push(c.with_remedy(
            "a frame that differs is the firmware computing otherwise than the host's \
             runtime on the same bytes: rebuild the firmware from this tree (`cargo fw`), \
             then find the first differing tick with `hil run --target qemu` and the QEMU \
             tests of `cargo xtest`",
        ));
    }
    const TARGET_ITEM: &str = "target (QEMU) vs host Actuation frames";
    match target.outcome {
        on_target::TargetOutcome::NotRun => checks.push(Check::not_run(
            "all",
            TARGET_ITEM,
            target.note.trim_start_matches("target: not run: "),
            "build the firmware (`cargo fw` writes target/fw/wheelset-qemu.elf, or set \
             WHEELSET_QEMU_ELF) and install qemu-system-arm, then run the audit again; or \
             say --no-target to audit the host alone",
        )),
        on_target::TargetOutcome::Failed => checks.push(Check {
            status: Status::Fail,
            not_run: false,
            reason: target.note.clone(),
            ..Check::not_run(
                "all",
                TARGET_ITEM,
                "",
                "the firmware under QEMU stopped answering the audit's Sensor frames: run \
                 `hil run --target qemu` to see where, and the QEMU tests of `cargo xtest`",
            )
        }),
        _ => {}
    }
    let verdict = checks
        .iter()
        .map(|c| c.status)
        .max()
        .unwrap_or(Status::Pass);
    Ok(Audit {
        command: command_line(args),
        base_rate_hz: cfg.base_rate_hz,
        formats: fmt,
        sample_type: if production {
            "wheelset_control::Fx (Q4.28) with Coef (Q1.31): the production type".into()
        } else {
            format!(
                "instrumented fixed point, signals {} coefficients {}",
                fmt.signal, fmt.coef
            )
        },
        tolerances: tol,
        controllers: c.controllers,
        observed: c.observed,
        scenarios: scenarios
            .iter()
            .map(|s| (s.name.clone(), s.source.clone(), s.ticks.len()))
            .collect(),
        scenario_notes,
        bounds: proofs.bounds,
        error_bounds: proofs.error_bounds,
        linear_parts: proofs.linear_parts,
        proof_statement: proofs.statement,
        overflow_free: proofs.overflow_free,
        recommendations: proofs.recommendations,
        closed_loop,
        diagnosis,
        sweep,
        target,
        checks,
        verdict,
    })
}
