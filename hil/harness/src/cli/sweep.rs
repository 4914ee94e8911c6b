//! `hil sweep` and `hil sweep merge`: the closed loop over a parameter grid.

use std::io::IsTerminal;
use std::path::PathBuf;

use clap::{Args, Subcommand};
use hil::budget::Budgets;
use hil::run::{RunOptions, Target};
use wheelset_loop::sim_link::{Faults, LinkConfig};
use wheelset_report::Verdict;

use super::{input, load_params, run_error, unavailable, Control, Failure};

#[derive(Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub(crate) struct SweepCmd {
    #[command(subcommand)]
    sub: Option<SweepSub>,
    #[command(flatten)]
    args: SweepArgs,
}

#[derive(Subcommand)]
pub(crate) enum SweepSub {
    /// Joins the documents of `hil sweep --shard I/N` runs into the document a single
    /// run of the whole grid writes.
    Merge(MergeArgs),
}

#[derive(Args)]
pub(crate) struct MergeArgs {
    /// The shards' JSON documents (any order).
    #[arg(required = true, value_name = "FILE")]
    files: Vec<PathBuf>,
    /// Write the merged document here.
    #[arg(long, required = true, value_name = "OUT")]
    json: PathBuf,
    /// Also write the campaign's report (table and heat maps) into this directory.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,
}

#[derive(Args)]
pub(crate) struct SweepArgs {
    /// One axis of the grid: `KEY=FROM..TO:N` (N linearly spaced values, both ends
    /// included) or `KEY=VALUE`; KEY is any parameter key (SI units). `f11` sets `f22`
    /// too unless `f22` is an axis. Repeatable; the last axis varies fastest.
    #[arg(long = "param", value_name = "KEY=FROM..TO:N", required = true)]
    axes: Vec<hil::sweep::Axis>,
    /// Built-in scenario or a scenario TOML file.
    #[arg(long, default_value = "curve")]
    scenario: String,
    /// Base parameter file (TOML, as `hil run --params`); each point's values apply on
    /// top, the scenario's [params] on top of those.
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
    /// Yaw control law of the device (and of the reference).
    #[arg(long, value_enum, default_value = "lead")]
    control: Control,
    /// Where the device runs: inproc or qemu (one QEMU per thread).
    #[arg(long, default_value = "inproc", value_parser = parse_sweep_target)]
    target: Target,
    /// The QEMU target's link, as `hil run --qemu-link`: `uart` or `bulk` (the same
    /// records, faster).
    #[arg(long, default_value = "uart", value_parser = super::run::parse_channel)]
    qemu_link: wheelset_targets::qemu::Channel,
    /// Link faults at every point, e.g. `ber=1e-4,drop=0.01` (in-process link only).
    #[arg(long, default_value = "")]
    faults: Faults,
    /// Seed of the link's faults, the same at every point.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Budget file (TOML; see `hil::budget`).
    #[arg(long)]
    budget: Option<PathBuf>,
    /// Override one budget (repeatable), as `hil run --set`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Run only shard I of N (the points i with i mod N = I, from 0); join the parts
    /// with `hil sweep merge`. `auto`: I and N from a Slurm array task
    /// (SLURM_ARRAY_TASK_ID, _MIN, _STEP, _COUNT; the default inside one); `auto/N`: I
    /// from Kubernetes' JOB_COMPLETION_INDEX (or Slurm's); `all`: every point, whatever
    /// the environment.
    #[arg(long, value_name = "I/N|auto|auto/N|all")]
    shard: Option<hil::sweep::ShardSpec>,
    /// Threads (default: every core allowed).
    #[arg(long, value_name = "N")]
    jobs: Option<usize>,
    /// Write the campaign's document (JSON): one record per point.
    #[arg(long, required = true, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Write the report (Markdown table, heat maps of the verdicts and of peak |y|) into
    /// this directory.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,
    /// Never show the progress bar.
    #[arg(long)]
    quiet: bool,
}

/// The test hook of `hil::sweep::atomic::write_atomic`: while the file named by this
/// variable exists, a document waits between its temporary file and the rename.
const HOLD_VAR: &str = "HIL_SWEEP_TEST_HOLD";

/// An environment variable as text (a non-UTF-8 value is kept lossily, so that its
/// parse fails naming it rather than reading as unset).
fn env_var(name: &str) -> Option<String> {
    std::env::var_os(name).map(|v| v.to_string_lossy().into_owned())
}

pub(crate) fn parse_sweep_target(s: &str) -> Result<Target, String> {
    super::inproc_or_qemu(
        s,
        "a sweep starts its own QEMUs (--target qemu), not one started by hand",
        "a sweep runs on inproc or qemu (one board cannot run a grid in parallel)",
    )
}

pub(crate) fn cmd_sweep(c: &SweepCmd, command: &str) -> Result<Verdict, Failure> {
    use hil::sweep;
    let write =
        |doc: &sweep::SweepDoc, json: &std::path::Path, report_dir: Option<&std::path::Path>| {
            let hold = std::env::var_os(HOLD_VAR).map(std::path::PathBuf::from);
            let text = hil::report::to_json(doc).map_err(|e| input(e.to_string()))?;
            sweep::atomic::write_atomic(json, text.as_bytes(), hold.as_deref()).map_err(input)?;
            say!("json: {}", json.display());
            if let Some(d) = report_dir {
                let files = hil::sweep::document::write_sweep_report(doc, d, command);
                for f in super::written(d, files)? {
                    say!("report: {}", f.display());
                }
            }
            for r in &doc.records {
                let checks: Vec<&str> = r.failing.iter().map(|c| c.check.as_str()).collect();
                say!(
                    "  {:>4}  {}: {}, peak |y| {:.3} mm{}{}",
                    r.index,
                    r.params
                        .iter()
                        .map(|(k, v)| format!("{k} = {}", hil::sweep::document::value_label(*v)))
                        .collect::<Vec<_>>()
                        .join(", "),
                    r.verdict,
                    r.peak_abs_y_m * 1e3,
                    r.diverged_at_s
                        .map_or(String::new(), |t| format!(", diverged at {t:.3} s")),
                    if checks.is_empty() {
                        String::new()
                    } else {
                        format!("; not passed: {}", checks.join(", "))
                    }
                );
            }
            let s = &doc.summary;
            say!(
                "hil sweep: {} of {} points{}: {} pass, {} warn, {} fail",
                doc.records.len(),
                doc.sweep.points,
                doc.shard
                    .map_or(String::new(), |sh| format!(" (shard {sh})")),
                s.pass,
                s.warn,
                s.fail
            );
            Ok(if s.fail > 0 {
                Verdict::Fail
            } else {
                Verdict::Pass
            })
        };
    if let Some(SweepSub::Merge(m)) = &c.sub {
        let mut parts = Vec::new();
        for f in &m.files {
            let name = f.display().to_string();
            let text = wheelset_plant::input::read_input(f).map_err(|e| input(e.to_string()))?;
            let doc = serde_json::from_str(&text)
                .map_err(|e| input(format!("{name}: not a sweep document: {e}")))?;
            parts.push((name, doc));
        }
        let doc = sweep::merge(&parts).map_err(input)?;
        return write(&doc, &m.json, m.report.as_deref());
    }
    let a = &c.args;
    let json = a
        .json
        .as_deref()
        .ok_or_else(|| input("--json FILE: needed"))?;
    let points = sweep::check_axes(&a.axes).map_err(input)?;
    let shard = sweep::resolve(a.shard, &env_var).map_err(input)?;
    let jobs = match a.jobs {
        Some(0) => return Err(input("--jobs 0: at least one thread")),
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get),
    };
    super::check_link_flags(&a.target, a.qemu_link, &a.faults)?;
    let budgets = Budgets::load(a.budget.as_deref(), &a.sets).map_err(input)?;
    let params = load_params(a.params.as_deref())?;
    let identity = identity(a)?;
    let law = a.control.law_for(&a.scenario, &params);
    let campaign = sweep::Campaign {
        base: RunOptions {
            target: a.target.clone(),
            qemu_link: a.qemu_link,
            scenario: a.scenario.clone(),
            control: law,
            faults_spec: a.faults.to_string(),
            budgets,
            link: LinkConfig {
                faults: a.faults.clone(),
                seed: a.seed,
                ..LinkConfig::default()
            },
            realtime: wheelset_targets::realtime::os::Want::none(),
            params,
            ..RunOptions::default()
        },
        header: sweep::Header {
            scenario: a.scenario.clone(),
            control: law,
            target: a.target.to_string(),
            faults: a.faults.to_string(),
            seed: a.seed,
            params_file: a.params.as_ref().map(|p| p.display().to_string()),
            budget_file: a.budget.as_ref().map(|p| p.display().to_string()),
            sets: a.sets.clone(),
            axes: a.axes.clone(),
            follows: sweep::followers(&a.axes),
            points,
            identity,
        },
    };
    let bar = (!a.quiet && std::io::stderr().is_terminal()).then(|| {
        use indicatif::{ProgressBar, ProgressStyle};
        let style = ProgressStyle::with_template(
            "{msg} [{bar:40}] {pos}/{len} points ({elapsed}, eta {eta})",
        );
        ProgressBar::new(0)
            .with_style(style.unwrap_or_else(|_| ProgressStyle::default_bar()))
            .with_message(format!("hil sweep {} on {jobs} threads", a.scenario))
    });
    let mut tick = |done: usize, total: usize| {
        if let Some(pb) = &bar {
            pb.set_length(total as u64);
            pb.set_position(done as u64);
        }
    };
    if let Some(sh) = shard.filter(|_| !matches!(a.shard, Some(sweep::ShardSpec::Fixed(_)))) {
        say!("shard: {sh} (from the job array's environment)");
    }
    let (doc, cost) = sweep::run_campaign(&campaign, shard, jobs, &mut tick).map_err(run_error)?;
    if let Some(pb) = &bar {
        pb.finish_and_clear();
    }
    // Standard error only (a figure of the machine): the shards' documents merge byte for byte.
    eprintln!("hil sweep: throughput: {cost} ({jobs} threads)");
    write(&doc, json, a.report.as_deref())
}

/// The campaign's identity: the digests of this binary, of the ELF under QEMU and of the
/// scenario, parameter and budget files. An unreadable input file is a bad flag (exit
/// 2); an unreadable ELF or binary, a target that cannot be used (exit 3).
fn identity(a: &SweepArgs) -> Result<hil::sweep::Identity, Failure> {
    use hil::sweep::{exe_sha256, file_sha256};
    let file = |flag: &str, p: &Option<PathBuf>| {
        p.as_deref()
            .map(file_sha256)
            .transpose()
            .map_err(|e| input(format!("{flag}: {e}")))
    };
    let scenario = std::path::Path::new(&a.scenario);
    Ok(hil::sweep::Identity {
        hil_version: env!("CARGO_PKG_VERSION").to_string(),
        hil_sha256: exe_sha256().map_err(unavailable)?,
        elf_sha256: match a.target {
            Target::Qemu => Some(
                file_sha256(&wheelset_targets::qemu::QemuConfig::default_elf())
                    .map_err(|e| unavailable(format!("the firmware ELF: {e}")))?,
            ),
            _ => None,
        },
        // A built-in scenario is part of the binary; an unknown name is refused by the run.
        scenario_sha256: if wheelset_plant::scenario::BUILTIN
            .iter()
            .any(|(n, _)| *n == a.scenario)
            || !scenario.exists()
        {
            None
        } else {
            Some(file_sha256(scenario).map_err(|e| input(format!("--scenario: {e}")))?)
        },
        params_sha256: file("--params", &a.params)?,
        budget_sha256: file("--budget", &a.budget)?,
    })
}
