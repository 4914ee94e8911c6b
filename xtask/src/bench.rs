//! `cargo xtask fw-bench [--json FILE] [--check]`: the QEMU benchmark firmware, fixed
//! point and f32, on the Cortex-M4F (`mps2-an386`) and Cortex-M3 (`mps2-an385`); its
//! `FWBENCH` lines become a table, the JSON and the pages' figures ([`pages`]: rewritten,
//! or compared with `--check`). Fails when the Cortex-M4 fixed-point tick's mean exceeds
//! [`TICK_MEAN_BUDGET_INSTRUCTIONS`].

use std::path::PathBuf;
use std::process::Command;

mod pages;

use crate::{build_firmware, ensure_targets, have_qemu, Firmware, FW_TARGET, M3_TARGET};
use wheelset_targets::qemu::TICK_MEAN_BUDGET_INSTRUCTIONS;

/// One `fw-bench` configuration (the core is QEMU's CPU too).
struct BenchConfig {
    core: &'static str,
    numeric: &'static str,
    fw: Firmware,
    machine: &'static str,
}

/// The four configurations, in the order of the JSON and the table.
fn bench_configs() -> [BenchConfig; 4] {
    [
        ("cortex-m4", "fixed", "wheelset-qemu-bench.elf"),
        ("cortex-m4", "f32", "wheelset-qemu-bench-f32.elf"),
        ("cortex-m3", "fixed", "wheelset-qemu-bench-m3.elf"),
        ("cortex-m3", "f32", "wheelset-qemu-bench-m3-f32.elf"),
    ]
    .map(|(core, numeric, elf)| {
        let m3 = core == "cortex-m3";
        let features = if numeric == "f32" {
            "board-qemu,f32"
        } else {
            "board-qemu"
        };
        BenchConfig {
            core,
            numeric,
            fw: Firmware {
                bin: "wheelset-qemu-bench",
                features,
                elf,
                target: if m3 { M3_TARGET } else { FW_TARGET },
                board: "qemu",
            },
            machine: if m3 { "mps2-an385" } else { "mps2-an386" },
        }
    })
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct MinMeanMax {
    min: u64,
    mean: u64,
    max: u64,
}

/// What one bench run reports (its `FWBENCH` line).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct BenchResult {
    law: MinMeanMax,
    tick: MinMeanMax,
    stack_peak_bytes: u64,
}

/// Parses `FWBENCH law <min> <mean> <max> tick <min> <mean> <max> stack <bytes>`.
fn parse_bench(output: &str) -> Result<BenchResult, String> {
    let line = output
        .lines()
        .find_map(|l| l.trim().strip_prefix("FWBENCH "))
        .ok_or("the bench printed no FWBENCH line")?;
    let w: Vec<&str> = line.split_whitespace().collect();
    let bad = |what: String| format!("FWBENCH line `{line}`: {what}");
    if w.len() != 10 {
        return Err(bad(format!("{} fields, expected 10", w.len())));
    }
    for (i, k) in [(0, "law"), (4, "tick"), (8, "stack")] {
        if w[i] != k {
            return Err(bad(format!("expected `{k}` at field {i}")));
        }
    }
    let num = |i: usize| {
        w[i].parse::<u64>()
            .map_err(|_| bad(format!("field {i} is not a number")))
    };
    let mmm = |i: usize| -> Result<MinMeanMax, String> {
        Ok(MinMeanMax {
            min: num(i)?,
            mean: num(i + 1)?,
            max: num(i + 2)?,
        })
    };
    Ok(BenchResult {
        law: mmm(1)?,
        tick: mmm(5)?,
        stack_peak_bytes: num(9)?,
    })
}

/// The JSON: `{"cortex-m4":{"fixed":{..},"f32":{..}},"cortex-m3":{..}}`, each with `law`
/// and `tick` (`min`, `mean`, `max`), `stack_peak_bytes`, `machine` and `target`.
fn bench_json(results: &[(&BenchConfig, BenchResult)]) -> String {
    let mmm = |m: &MinMeanMax| {
        format!(
            "{{\"min\":{},\"mean\":{},\"max\":{}}}",
            m.min, m.mean, m.max
        )
    };
    let per_core: Vec<String> = results
        .chunk_by(|a, b| a.0.core == b.0.core)
        .map(|core_results| {
            let core = core_results.first().map_or("", |r| r.0.core);
            let builds: Vec<String> = core_results
                .iter()
                .map(|(c, r)| {
                    format!(
                        "\"{}\":{{\"law\":{},\"tick\":{},\"stack_peak_bytes\":{},\
                         \"machine\":\"{}\",\"target\":\"{}\"}}",
                        c.numeric,
                        mmm(&r.law),
                        mmm(&r.tick),
                        r.stack_peak_bytes,
                        c.machine,
                        c.fw.target
                    )
                })
                .collect();
            format!("\"{core}\":{{{}}}", builds.join(","))
        })
        .collect();
    format!("{{{}}}\n", per_core.join(","))
}

fn bench_table(results: &[(&BenchConfig, BenchResult)]) -> String {
    let mut t = String::from(
        "| core | build | law min | law mean | law max | tick min | tick mean | tick max | stack peak B |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    for (c, r) in results {
        t.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            c.core,
            c.numeric,
            r.law.min,
            r.law.mean,
            r.law.max,
            r.tick.min,
            r.tick.mean,
            r.tick.max,
            r.stack_peak_bytes
        ));
    }
    t
}

/// `fw-bench` arguments: `[--json FILE] [--check]`, as `(json, check)`.
pub(crate) fn parse_bench_args(args: &[String]) -> Result<(Option<PathBuf>, bool), String> {
    let usage = "usage: cargo xtask fw-bench [--json FILE] [--check]";
    let check = args.iter().any(|a| a == "--check");
    let rest: Vec<&String> = args.iter().filter(|a| *a != "--check").collect();
    match rest.as_slice() {
        [] => Ok((None, check)),
        [flag, file] if *flag == "--json" && !file.starts_with("--") => {
            Ok((Some(PathBuf::from(file)), check))
        }
        [flag] if *flag == "--json" => Err(format!("fw-bench: --json needs a FILE ({usage})")),
        _ => Err(format!(
            "fw-bench: unknown arguments `{}` ({usage})",
            args.join(" ")
        )),
    }
}

/// The pages' `fw-bench` figures from this run: rewritten, or with `check` compared.
fn sync_pages(
    results: &[(&BenchConfig, BenchResult)],
    outputs: &[String],
    check: bool,
) -> Result<(), String> {
    let root = crate::workspace_root();
    let heads: Vec<String> = results
        .iter()
        .map(|(c, _)| {
            let core = c.core.replace("cortex-", "").to_uppercase();
            format!("{core} {}", c.numeric)
        })
        .collect();
    let block = pages::table(&heads, outputs);
    let (law, tick) = results
        .iter()
        .find(|(c, _)| c.core == "cortex-m4" && c.numeric == "fixed")
        .map(|(_, r)| (r.law.mean, r.tick.mean))
        .ok_or("fw-bench: no Cortex-M4 fixed-point result")?;
    let row = pages::readme_row(law, tick, TICK_MEAN_BUDGET_INSTRUCTIONS);
    let list = crate::readme::pages(&root)?;
    let (new, changed) = pages::update(&list, &block, &row)?;
    if changed.is_empty() {
        eprintln!("xtask: the pages' fw-bench figures match this run");
        return Ok(());
    }
    if check {
        return Err(format!(
            "fw-bench: the figures of {} differ from this run (`cargo xtask fw-bench` \
             rewrites them)",
            changed.join(", ")
        ));
    }
    for ((path, old), text) in list.iter().zip(&new) {
        if old != text {
            let p = root.join(path);
            std::fs::write(&p, text).map_err(|e| format!("cannot write {}: {e}", p.display()))?;
            eprintln!("xtask: {path}: fw-bench figures rewritten");
        }
    }
    Ok(())
}

/// Builds and runs the QEMU benchmark firmware; prints the table, writes `json` if given.
pub(crate) fn fw_bench(json: Option<PathBuf>, check: bool) -> Result<(), String> {
    ensure_targets()?;
    let configs = bench_configs();
    let elfs = build_firmware(configs.iter().map(|c| &c.fw))?;
    if !have_qemu() {
        return Err("qemu-system-arm is not installed: `apt-get install qemu-system-arm`".into());
    }
    let mut results = Vec::new();
    let mut outputs = Vec::new();
    for (c, (elf, _)) in configs.iter().zip(&elfs) {
        let mut cmd = Command::new(crate::qemu_cmd::QEMU_BIN);
        cmd.args(crate::qemu_cmd::qemu_args(
            c.machine,
            c.core,
            &elf.to_string_lossy(),
            crate::qemu_cmd::SerialTo::Null,
        ));
        eprintln!("xtask: {cmd:?}");
        let out = cmd
            .output()
            .map_err(|e| format!("cannot start {cmd:?}: {e}"))?;
        let text = String::from_utf8_lossy(&out.stdout);
        // The human-readable lines, prefixed with the configuration.
        for l in text.lines().filter(|l| !l.starts_with("FWBENCH ")) {
            outln!("{} {}: {l}", c.core, c.numeric);
        }
        if !out.status.success() {
            return Err(format!(
                "{cmd:?} failed with {}: {}",
                out.status,
                String::from_utf8_lossy(&out.stderr)
            ));
        }
        let r = parse_bench(&text).map_err(|e| format!("{}: {e}", elf.display()))?;
        results.push((c, r));
        outputs.push(text.into_owned());
    }
    outln!();
    out!("{}", bench_table(&results));
    let over = over_budget(&results);
    if let Some(path) = json {
        // The folder too, as `sim-host` and `hil` make theirs.
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)
                .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        }
        std::fs::write(&path, bench_json(&results))
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        outln!("wrote {}", path.display());
    }
    let pages = sync_pages(&results, &outputs, check);
    match over {
        None => pages,
        Some(e) => Err(e),
    }
}

/// The flashed build's (Cortex-M4, fixed point) excess over the tick's budget, if any.
fn over_budget(results: &[(&BenchConfig, BenchResult)]) -> Option<String> {
    results
        .iter()
        .find(|(c, r)| {
            c.core == "cortex-m4"
                && c.numeric == "fixed"
                && r.tick.mean > TICK_MEAN_BUDGET_INSTRUCTIONS
        })
        .map(|(c, r)| {
            format!(
                "fw-bench: {} {} whole tick mean {} instructions, over the budget of {}",
                c.core, c.numeric, r.tick.mean, TICK_MEAN_BUDGET_INSTRUCTIONS
            )
        })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn the_bench_line_parses_and_bad_ones_are_named() {
        let out = "law ...\nFWBENCH law 40 45 90 tick 500 600 700 stack 1234\n";
        let r = parse_bench(out).unwrap();
        assert_eq!(
            r,
            BenchResult {
                law: MinMeanMax {
                    min: 40,
                    mean: 45,
                    max: 90
                },
                tick: MinMeanMax {
                    min: 500,
                    mean: 600,
                    max: 700
                },
                stack_peak_bytes: 1234
            }
        );
        assert!(parse_bench("nothing").unwrap_err().contains("no FWBENCH"));
        assert!(parse_bench("FWBENCH law 1 2 x tick 1 2 3 stack 4")
            .unwrap_err()
            .contains("field 3"));
        assert!(parse_bench("FWBENCH law 1 2 3 tock 1 2 3 stack 4")
            .unwrap_err()
            .contains("`tick`"));
    }

    #[test]
    fn the_tick_mean_of_the_flashed_build_is_held_to_its_budget() {
        let configs = bench_configs();
        let at = |mean: u64| BenchResult {
            law: MinMeanMax {
                min: 1,
                mean: 1,
                max: 1,
            },
            tick: MinMeanMax {
                min: mean,
                mean,
                max: mean,
            },
            stack_peak_bytes: 1,
        };
        let b = TICK_MEAN_BUDGET_INSTRUCTIONS;
        // Only the Cortex-M4 fixed-point build (the first) is held to it.
        let ok: Vec<_> = configs
            .iter()
            .zip([b, b + 1, b + 1, b + 1])
            .map(|(c, m)| (c, at(m)))
            .collect();
        assert_eq!(over_budget(&ok), None);
        let over: Vec<_> = configs
            .iter()
            .zip([b + 1, b, b, b])
            .map(|(c, m)| (c, at(m)))
            .collect();
        let e = over_budget(&over).unwrap();
        assert!(
            e.contains("cortex-m4 fixed") && e.contains(&format!("{}", b + 1)),
            "{e}"
        );
    }

    #[test]
    fn the_json_has_the_issue_structure() {
        let configs = bench_configs();
        let r = |k: u64| BenchResult {
            law: MinMeanMax {
                min: k,
                mean: k + 1,
                max: k + 2,
            },
            tick: MinMeanMax {
                min: 10 * k,
                mean: 10 * k + 1,
                max: 10 * k + 2,
            },
            stack_peak_bytes: 100 * k,
        };
        let results: Vec<_> = configs
            .iter()
            .zip([1, 2, 3, 4])
            .map(|(c, k)| (c, r(k)))
            .collect();
        let j = bench_json(&results);
        assert!(j.starts_with(
            "{\"cortex-m4\":{\"fixed\":{\"law\":{\"min\":1,\"mean\":2,\"max\":3},\
             \"tick\":{\"min\":10,\"mean\":11,\"max\":12},\"stack_peak_bytes\":100,"
        ));
        assert!(j.contains(
            "\"cortex-m3\":{\"fixed\":{\"law\":{\"min\":3,\"mean\":4,\"max\":5},\
             \"tick\":{\"min\":30,\"mean\":31,\"max\":32},\"stack_peak_bytes\":300,"
        ));
        assert!(j.contains("},\"f32\":{\"law\":{\"min\":4,"));
        let t = bench_table(&results);
        assert_eq!(t.lines().count(), 6);
        assert!(t.contains("| cortex-m3 | f32 | 4 | 5 | 6 | 40 | 41 | 42 | 400 |"));
    }

    #[test]
    fn bench_arguments() {
        let a = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert_eq!(parse_bench_args(&a(&[])), Ok((None, false)));
        assert_eq!(
            parse_bench_args(&a(&["--json", "x.json"])),
            Ok((Some(PathBuf::from("x.json")), false))
        );
        assert_eq!(
            parse_bench_args(&a(&["--check", "--json", "x.json"])),
            Ok((Some(PathBuf::from("x.json")), true))
        );
        assert!(parse_bench_args(&a(&["--json"]))
            .unwrap_err()
            .contains("needs a FILE"));
        assert!(parse_bench_args(&a(&["--jsn", "x"]))
            .unwrap_err()
            .contains("unknown"));
    }
}
