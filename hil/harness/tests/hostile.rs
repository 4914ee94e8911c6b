//! The hostile-input suite of `hil`: a table of command lines, the exit code
//! each must give, and words its output must carry. Every command runs under a timeout,
//! so a regression to a hang fails the row instead of hanging the suite.

#![allow(clippy::unwrap_used)]

use std::io::Read;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Longest any row may take.
const TIMEOUT: Duration = Duration::from_secs(120);

/// Runs `hil ARGS` (with `envs`) under [`TIMEOUT`]: `(exit code, stdout + stderr)`,
/// `None` on a timeout (the process is killed).
fn run(args: &[String], envs: &[(&str, String)]) -> Option<(i32, String)> {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hil"));
    cmd.args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    for (k, v) in envs {
        cmd.env(k, v);
    }
    let mut child = cmd.spawn().unwrap();
    let mut out = child.stdout.take().unwrap();
    let mut err = child.stderr.take().unwrap();
    let t_out = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = out.read_to_string(&mut s);
        s
    });
    let t_err = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    let start = Instant::now();
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Some((
        status.code().unwrap_or(-1),
        t_out.join().unwrap() + &t_err.join().unwrap(),
    ))
}

fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hil-hostile-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let w = |name: &str, text: &str| std::fs::write(dir.join(name), text).unwrap();
    w("short.toml", "duration_s = 0.2\n");
    w("meant.toml", "duration_s = 0.2\nlaws = [\"passive\"]\n");
    w("garbage.elf", "this is not firmware\n");
    w(
        "budget.toml",
        "[timing]\ncpu_max = { warn = \"x\", fail = 1.0 }\n",
    );
    w(
        "budget_key.toml",
        "[timing]\ncpu_maximum = { warn = 0.1, fail = 1.0 }\n",
    );
    std::fs::write(dir.join("big.toml"), vec![b'#'; 2 << 20]).unwrap();
    dir
}

struct Row {
    args: &'static str,
    code: i32,
    want: &'static [&'static str],
}

const ROWS: &[Row] = &[
    // Input files through the one reader.
    Row { args: "run --budget /dev/zero", code: 2, want: &["/dev/zero", "character device"] },
    Row { args: "run --budget {F}/big.toml", code: 2, want: &["above the input file limit"] },
    Row { args: "run --scenario /dev/zero", code: 2, want: &["/dev/zero", "character device"] },
    Row { args: "run --scenario {F}", code: 2, want: &["a directory"] },
    // TOML errors name the key as written, with the line.
    Row { args: "run --budget {F}/budget.toml", code: 2, want: &["line 2", "cpu_max", "invalid type"] },
    Row { args: "run --budget {F}/budget_key.toml", code: 2, want: &["cpu_maximum", "unknown field"] },
    // `--set` is validated as a whole: a consistent warn/fail pair passes in both
    // orders, an inconsistent one is refused in both, naming the key.
    Row {
        args: "run --scenario {F}/short.toml --quiet --set timing.cpu_max.warn=0.9 --set timing.cpu_max.fail=0.95",
        code: 0,
        want: &["verdict: pass"],
    },
    Row {
        args: "run --scenario {F}/short.toml --quiet --set timing.cpu_max.fail=0.95 --set timing.cpu_max.warn=0.9",
        code: 0,
        want: &["verdict: pass"],
    },
    Row {
        args: "run --scenario {F}/short.toml --set timing.cpu_max.warn=0.9 --set timing.cpu_max.fail=0.85",
        code: 2,
        want: &["--set", "timing.cpu_max", "warn <= fail"],
    },
    Row {
        args: "run --scenario {F}/short.toml --set timing.cpu_max.fail=0.85 --set timing.cpu_max.warn=0.9",
        code: 2,
        want: &["--set", "timing.cpu_max", "warn <= fail"],
    },
    // Fault rates are capped.
    Row { args: "run --faults burst=1e308:6", code: 2, want: &["burst", "maximum"] },
    Row { args: "run --faults=outage=1e308:1", code: 2, want: &["outage", "at most"] },
    Row { args: "run --faults ber=2", code: 2, want: &["ber=2", "[0, 1)"] },
    // Negative numbers name the flag.
    Row { args: "run --cpu-hz -1", code: 2, want: &["--cpu-hz -1", "positive"] },
    Row { args: "run --baud -5", code: 2, want: &["--baud", "-5"] },
    // A scenario meant for other laws warns before the run.
    Row {
        args: "run --scenario {F}/meant.toml --control gain --quiet",
        code: 0,
        want: &["warning: scenario meant is meant for --control passive", "verdict"],
    },
    // Outputs that cannot be written are refused before the run (no summary printed).
    Row {
        args: "run --scenario {F}/short.toml --csv {F}/short.toml/run.csv",
        code: 2,
        want: &["--csv", "short.toml/run.csv", "cannot create its directory"],
    },
    Row { args: "run --scenario {F}/short.toml --json {F}", code: 2, want: &["--json", "is a directory"] },
    Row {
        args: "run --scenario {F}/short.toml --report {F}/short.toml",
        code: 2,
        want: &["--report", "not a directory"],
    },
    Row { args: "audit --no-target --json {F}", code: 2, want: &["--json", "is a directory"] },
    // A base rate the device refuses is refused in words about the rate asked for.
    Row { args: "run --scenario {F}/short.toml --rate-hz 50", code: 2, want: &["--rate-hz 50: ", "at least 500 Hz"] },
    // A delay outside the designs, a latency that is not a time, a link too slow for the
    // delay: refused before the run.
    Row { args: "run --delay-ticks 0", code: 2, want: &["--delay-ticks 0", "designed for"] },
    Row { args: "run --delay-ticks 4", code: 2, want: &["--delay-ticks 4", "designed for"] },
    Row { args: "run --latency-us nan", code: 2, want: &["--latency-us", "finite"] },
    Row { args: "run --target qemu --latency-us 5", code: 2, want: &["--latency-us", "real one"] },
    Row {
        args: "run --latency-us 300",
        code: 2,
        want: &["link budget exceeded", "more ticks of delay"],
    },
    Row {
        args: "run --rate-hz 1000 --delay-ticks 2",
        code: 2,
        want: &["--delay-ticks 2", "no lead or gain holds the yaw loop"],
    },
    // A repeated fault key is refused, naming it (only outages repeat).
    Row { args: "run --faults ber=1e-3,ber=1e-2", code: 2, want: &["ber=1e-2", "`ber` is given twice"] },
    Row { args: "run --faults drop=0.1,ber=1e-4,drop=0.2", code: 2, want: &["`drop` is given twice"] },
];

/// The line `hil run` prints once its run is over: a refused input never shows it.
const SUMMARY: &str = "hil run: target";

#[test]
fn every_hostile_input_gets_its_exit_code_and_message() {
    let dir = scratch("rows");
    let d = dir.display().to_string();
    let mut failures = Vec::new();
    for r in ROWS {
        let line = r.args.replace("{F}", &d);
        let args: Vec<String> = line.split(' ').map(str::to_string).collect();
        match run(&args, &[]) {
            None => failures.push(format!("`hil {line}`: no exit within {TIMEOUT:?} (hang)")),
            Some((code, text)) => {
                if code != r.code {
                    failures.push(format!(
                        "`hil {line}`: exit {code}, want {}\n{text}",
                        r.code
                    ));
                    continue;
                }
                for w in r.want {
                    if !text.contains(w) {
                        failures.push(format!("`hil {line}`: no `{w}` in\n{text}"));
                    }
                }
                if r.code == 2 && text.contains(SUMMARY) {
                    failures.push(format!("`hil {line}`: refused after the run\n{text}"));
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        failures.is_empty(),
        "{} of {} rows failed:\n{}",
        failures.len(),
        ROWS.len(),
        failures.join("\n---\n")
    );
}

/// `--faults=SPEC` (the `=` form) is recorded in the JSON as the faults applied.
#[test]
fn the_equals_form_of_faults_is_recorded_as_applied() {
    let dir = scratch("faults");
    let json = dir.join("run.json");
    let args: Vec<String> = [
        "run",
        "--scenario",
        &dir.join("short.toml").display().to_string(),
        "--quiet",
        "--faults=drop=0.05",
        "--json",
        &json.display().to_string(),
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let (_, text) = run(&args, &[]).expect("no hang");
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).expect("json");
    let faults = doc
        .pointer("/faults")
        .or_else(|| doc.pointer("/run/faults"));
    assert_eq!(
        faults.and_then(|f| f.as_str()),
        Some("drop=0.05"),
        "{text}\n{doc:#}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A garbage firmware image is refused before QEMU is launched: "not an ELF for the
/// target", exit 3 (the target cannot be used). Needs `qemu-system-arm` (the check for
/// QEMU itself comes first).
#[test]
fn a_garbage_firmware_image_is_not_an_elf_for_the_target() {
    let qemu = Command::new("qemu-system-arm")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status();
    if !qemu.is_ok_and(|s| s.success()) {
        eprintln!("qemu-system-arm not installed: the ELF check row is not run");
        return;
    }
    let dir = scratch("elf");
    let elf = dir.join("garbage.elf").display().to_string();
    for sub in ["run", "golden"] {
        let args = vec![sub.to_string(), "--target".into(), "qemu".into()];
        let (code, text) = run(&args, &[("WHEELSET_QEMU_ELF", elf.clone())]).expect("no hang");
        assert_eq!(code, 3, "hil {sub}: {text}");
        assert!(
            text.contains("not an ELF for the target"),
            "hil {sub}: {text}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
