//! The hostile-input suite of `sim-host`: a table of command lines, the exit
//! code each must give, and words its message must carry. Every command runs under a
//! timeout, so a regression to a hang fails the row instead of hanging the suite; a row
//! fails when the exit code or any expected word differs.

#![allow(clippy::unwrap_used)]

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Longest any row may take (a debug build on a loaded two-core machine).
const TIMEOUT: Duration = Duration::from_secs(120);

/// Runs `sim-host ARGS` with a timeout: `(exit code, stdout + stderr)`; `None` on a
/// timeout (the process is killed).
fn run(args: &[String]) -> Option<(i32, String)> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
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
    let text = t_out.join().unwrap() + &t_err.join().unwrap();
    Some((status.code().unwrap_or(-1), text))
}

/// A scratch directory with the hostile files.
struct Files {
    dir: PathBuf,
}

impl Files {
    fn new() -> Self {
        let dir = std::env::temp_dir().join(format!("sim-host-hostile-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let w = |name: &str, text: &str| std::fs::write(dir.join(name), text).unwrap();
        w("l_a.toml", "l_a = 1e-61\n");
        w("long.toml", "duration_s = 1e5\n");
        w("s4000.toml", "duration_s = 4000.0\n");
        w("short.toml", "duration_s = 0.2\n");
        w("weak_la.toml", "duration_s = 0.2\n[params]\nl_a = 1.2e-4\n");
        w("meant.toml", "duration_s = 0.2\nlaws = [\"passive\"]\n");
        w("badlaw.toml", "duration_s = 0.2\nlaws = [\"sideways\"]\n");
        w(
            "badkey.toml",
            "duration_s = 0.2\n[params]\nl_a = \"small\"\n",
        );
        w(
            "extreme.toml",
            "v = 0.1\nk_t = 1e10\nk_gear = 1e10\ni_m = 0.01\ni_w = 1.0\nl_a = 1e-5\n\
             k_m = 100.0\nn_gear = 20.0\nm_v = 2e5\npi_kp = 1e3\npi_ti = 1e-4\nr_a = 10.0\n\
             c_lat = 1e7\nk_lat = 1e9\nk_yaw = 1e9\nm = 100.0\nj = 10.0\n",
        );
        std::fs::write(dir.join("big.toml"), vec![b'#'; 2 << 20]).unwrap();
        let fifo = dir.join("fifo.toml");
        let made = Command::new("mkfifo").arg(&fifo).status();
        assert!(made.is_ok_and(|s| s.success()), "mkfifo");
        Files { dir }
    }

    fn path(&self, name: &str) -> String {
        self.dir.join(name).display().to_string()
    }
}

impl Drop for Files {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// One row: the arguments (`{F}` = the scratch directory), the exit code, words that
/// must appear (case-sensitive) and words that must not.
struct Row {
    args: &'static str,
    code: i32,
    want: &'static [&'static str],
    not: &'static [&'static str],
}

const fn row(args: &'static str, code: i32, want: &'static [&'static str]) -> Row {
    Row {
        args,
        code,
        want,
        not: &[],
    }
}

const ROWS: &[Row] = &[
    // Plausible ranges: the eigen solver never sees l_a = 1e-61 (it hung).
    row(
        "rates --params {F}/l_a.toml",
        2,
        &["`l_a`", "plausible range", "1e-61"],
    ),
    row(
        "run --params {F}/l_a.toml",
        2,
        &["`l_a`", "plausible range"],
    ),
    row(
        "modes --params {F}/l_a.toml --json {F}/m.json",
        2,
        &["`l_a`"],
    ),
    // Memory follows the output: refused before it starts, with the estimate.
    row(
        "run --scenario {F}/long.toml",
        2,
        &["duration_s", "GiB", "lower duration_s"],
    ),
    row(
        "run --scenario {F}/long.toml --loop device",
        2,
        &["duration_s", "GiB"],
    ),
    row(
        "modes --points 1000000 --json {F}/m.json",
        2,
        &["--points 1000000", "GiB", "use at most"],
    ),
    // 4000 s fits alone (0.8 GiB) but not three runs kept together.
    row(
        "run --scenario {F}/s4000.toml --compare passive --compare gain",
        2,
        &["3 runs kept together", "lower duration_s"],
    ),
    // Non-finite and overflowing numbers.
    row(
        "run --scenario {F}/short.toml --loop device --latency-us 1e308",
        2,
        &["--latency-us", "[0, 1e6]"],
    ),
    row(
        "run --scenario {F}/short.toml --loop device --latency-us nan",
        2,
        &["--latency-us NaN"],
    ),
    row(
        "run --scenario {F}/short.toml --loop device --latency-us inf",
        2,
        &["--latency-us"],
    ),
    row(
        "run --scenario {F}/short.toml --loop device --faults burst=1e308:6",
        2,
        &["burst", "maximum"],
    ),
    row(
        "run --scenario {F}/short.toml --loop device --faults outage=1e308:1",
        2,
        &["outage", "at most"],
    ),
    row(
        "run --scenario {F}/short.toml --loop device --faults ber=2",
        2,
        &["--faults", "ber=2"],
    ),
    // Input files: FIFO, device, directory, too large.
    row(
        "run --scenario /dev/zero",
        2,
        &["/dev/zero", "character device", "not a regular file"],
    ),
    row(
        "run --params /dev/zero",
        2,
        &["/dev/zero", "character device"],
    ),
    row("run --scenario {F}/fifo.toml", 2, &["FIFO"]),
    row("run --scenario {F}", 2, &["a directory"]),
    row(
        "run --scenario {F}/big.toml",
        2,
        &["above the input file limit"],
    ),
    row(
        "rates --params {F}/big.toml",
        2,
        &["above the input file limit"],
    ),
    // Flags that do not apply to the continuous loop.
    row("run --faults ber=2", 2, &["--faults", "--loop device"]),
    row("run --rate-hz 0", 2, &["--rate-hz", "--loop device"]),
    row("run --baud 0", 2, &["--baud", "--loop device"]),
    row(
        "run --latency-us nan",
        2,
        &["--latency-us", "--loop device"],
    ),
    row("run --seed 3", 2, &["--seed", "--loop device"]),
    row("run --hold-ticks 3", 2, &["--hold-ticks", "--loop device"]),
    row(
        "run --faults ber=2 --rate-hz 0 --baud 0 --latency-us nan",
        2,
        &["--loop device"],
    ),
    // Zero rates and bauds on the device loop.
    row(
        "run --scenario {F}/short.toml --loop device --rate-hz 0",
        2,
        &["--rate-hz 0"],
    ),
    row(
        "run --scenario {F}/short.toml --loop device --baud 0",
        2,
        &["--baud 0"],
    ),
    row("rates --max-baud 0", 2, &["--max-baud 0"]),
    row("rates --latency-us -1", 2, &["--latency-us", "finite"]),
    row(
        "run --scenario {F}/short.toml --loop device --delay-ticks 4",
        2,
        &["--delay-ticks 4", "designed for"],
    ),
    row(
        "run --scenario {F}/short.toml --loop device --latency-us 300",
        2,
        &["link budget exceeded", "more ticks of delay"],
    ),
    // A base rate the device refuses is refused in words about the rate asked for.
    Row {
        args: "run --scenario {F}/short.toml --loop device --rate-hz 50",
        code: 2,
        want: &["--rate-hz 50", "at least 500 Hz"],
        not: &["monitor.rate_hz"],
    },
    // A loop the sampled-data analysis finds unstable with the file's parameters warns
    // before the run, naming the loop; a rate without a design is refused.
    row(
        "run --scenario {F}/weak_la.toml --loop device --rate-hz 5000",
        1,
        &[
            "warning: --rate-hz 5000",
            "traction current loop",
            "unstable",
            "limit-cycled",
        ],
    ),
    row(
        "run --scenario {F}/short.toml --loop device --rate-hz 4000",
        2,
        &["--rate-hz 4000", "no gains are designed for 4000 Hz"],
    ),
    // Negative numbers name the flag and what it wants.
    row(
        "run --scenario {F}/short.toml --loop device --latency-us -1",
        2,
        &["--latency-us -1", "[0, 1e6]"],
    ),
    row(
        "run --scenario {F}/short.toml --loop device --baud -5",
        2,
        &["--baud", "-5"],
    ),
    row("rates --delay -1", 2, &["--delay", "-1"]),
    row(
        "modes --points -3 --json {F}/m.json",
        2,
        &["--points", "-3"],
    ),
    // Scenario laws: a warning before the run with a law it is not meant for.
    row(
        "run --scenario {F}/meant.toml --control lead",
        0,
        &["warning: scenario meant is meant for --control passive"],
    ),
    // Fig. 9's lead diverges: exit 1 naming it, unless the run says it is meant to.
    row(
        "run --scenario beating --control lead",
        1,
        &[
            "warning: scenario beating is meant for --control passive",
            "the run diverged",
            "--expect-divergence",
        ],
    ),
    row(
        "run --scenario beating --control lead --expect-divergence",
        0,
        &["diverged as expected"],
    ),
    row(
        "run --scenario {F}/short.toml --expect-divergence",
        1,
        &["--expect-divergence: the run did not diverge"],
    ),
    Row {
        args: "run --scenario {F}/meant.toml --control passive",
        code: 0,
        want: &["scenario meant"],
        not: &["warning"],
    },
    row(
        "run --scenario {F}/badlaw.toml",
        2,
        &["laws[0]", "sideways"],
    ),
    // TOML errors name the key as written.
    row("run --scenario {F}/badkey.toml", 2, &["params.l_a"]),
    // Outputs that cannot be written are refused before the run (no summary printed).
    Row {
        args: "run --scenario {F}/short.toml --csv {F}/short.toml/run.csv",
        code: 2,
        want: &["--csv", "short.toml/run.csv", "cannot create its directory"],
        not: &["scenario short"],
    },
    Row {
        args: "run --scenario {F}/short.toml --json {F}",
        code: 2,
        want: &["--json", "is a directory"],
        not: &["scenario short"],
    },
    Row {
        args: "run --scenario {F}/short.toml --plot {F}/short.toml",
        code: 2,
        want: &["--plot", "not a directory"],
        not: &["scenario short"],
    },
    Row {
        args: "run --scenario {F}/short.toml --loop device --csv {F}/short.toml/run.csv",
        code: 2,
        want: &["--csv", "cannot create its directory"],
        not: &["scenario short"],
    },
    Row {
        args: "modes --json {F}/short.toml/m.json",
        code: 2,
        want: &["--json", "cannot create its directory"],
        not: &["case (a)"],
    },
    row("rates --json {F}", 2, &["--json", "is a directory"]),
    row(
        "adhesion --condition wet --json {F}/a.json --plot {F}/short.toml",
        2,
        &["--plot", "not a directory"],
    ),
    // A repeated fault key is refused, naming it; outages repeat.
    row(
        "run --scenario {F}/short.toml --loop device --faults ber=1e-3,ber=1e-2",
        2,
        &["ber=1e-2", "`ber` is given twice"],
    ),
    row(
        "run --scenario {F}/short.toml --loop device --faults outage=0.05:0.01,outage=0.1:0.01",
        0,
        &["scenario short"],
    ),
    // Parameters at the ends of their ranges, whose closed-loop matrix spans many orders
    // of magnitude: balanced before the QR iteration, its eigenvalues and those of its
    // transpose agree (no ill-conditioning warning; the warning's threshold is
    // unit-tested on a defective matrix in `wheelset_plant::finite`).
    Row {
        args: "modes --case d --points 20 --params {F}/extreme.toml --json {F}/m.json",
        code: 0,
        want: &["case (d)", "torsional"],
        not: &["ill-conditioned"],
    },
    Row {
        args: "modes --case d --points 20 --json {F}/m.json",
        code: 0,
        want: &["case (d)"],
        not: &["ill-conditioned"],
    },
];

#[test]
fn every_hostile_input_gets_its_exit_code_and_message() {
    let files = Files::new();
    let dir = files.dir.display().to_string();
    let mut failures = Vec::new();
    for r in ROWS {
        let line = r.args.replace("{F}", &dir);
        let args: Vec<String> = line.split(' ').map(str::to_string).collect();
        match run(&args) {
            None => failures.push(format!(
                "`sim-host {line}`: no exit within {TIMEOUT:?} (hang)"
            )),
            Some((code, text)) => {
                if code != r.code {
                    failures.push(format!(
                        "`sim-host {line}`: exit {code}, want {}\n{text}",
                        r.code
                    ));
                    continue;
                }
                for w in r.want {
                    if !text.contains(w) {
                        failures.push(format!("`sim-host {line}`: no `{w}` in\n{text}"));
                    }
                }
                for w in r.not {
                    if text.contains(w) {
                        failures.push(format!("`sim-host {line}`: unexpected `{w}` in\n{text}"));
                    }
                }
            }
        }
    }
    assert!(Path::new(&files.path("fifo.toml")).exists());
    assert!(
        failures.is_empty(),
        "{} of {} rows failed:\n{}",
        failures.len(),
        ROWS.len(),
        failures.join("\n---\n")
    );
}

/// A run that produced a non-finite number is a numerical failure (time, states), not
/// "unstable". (The command line cannot reach one any more: the plausible ranges refuse
/// the inputs that did; the parameters here bypass them.)
#[test]
fn a_nan_run_is_a_numerical_failure_not_unstable() {
    use wheelset_plant::outcome::{stop_of, Stop};
    use wheelset_plant::params::Params;
    use wheelset_plant::scenario::Scenario;
    let p = Params {
        l_a: 1e-300,
        ..Params::default()
    };
    let src = "duration_s = 0.5\n[traction]\ndemand_nm = 2460.0\nt_on_s = 0.0\n";
    let mut sc = Scenario::from_toml_str(src, "nan.toml", &Params::default()).unwrap();
    sc.params = p;
    let tr = wheelset_plant::sim::run_continuous(&sc, wheelset_plant::control::YawLaw::Lead);
    match stop_of(&tr) {
        Some(Stop::Numerical { t_s, columns }) => {
            assert!(!columns.is_empty() && t_s <= 0.5, "{t_s} {columns:?}");
            let msg = stop_of(&tr).unwrap().to_string();
            assert!(
                msg.contains("numerical failure") && !msg.contains("unstable"),
                "{msg}"
            );
        }
        other => panic!("want a numerical failure, got {other:?}"),
    }
    // A finite divergence is an unstable loop.
    let beating = Scenario::load("beating", &Params::default()).unwrap();
    assert_eq!(beating.laws, vec![wheelset_plant::control::YawLaw::Passive]);
    let tr = wheelset_plant::sim::run_continuous(&beating, wheelset_plant::control::YawLaw::Lead);
    assert!(
        matches!(stop_of(&tr), Some(Stop::Unstable { .. })),
        "{:?}",
        stop_of(&tr)
    );
}

/// The rate analysis never reaches an eigenvalue or exponential solver with a
/// non-finite matrix: with `l_a = 1e-61` (refused by the plausible ranges, bypassed
/// here) it returns an error naming `l_a` instead of looping (it hung).
#[test]
fn the_rate_analysis_refuses_a_non_finite_plant_naming_the_parameter() {
    use wheelset_plant::params::Params;
    use wheelset_plant::sampled::{rates, Criteria, LinkBudget, Model};
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let p = Params {
            l_a: 1e-61,
            ..Params::default()
        };
        let cfg = wheelset_control::Config::default();
        let r = rates(
            &p,
            Model::Full,
            &cfg,
            1,
            &LinkBudget::default(),
            &Criteria::default(),
        );
        let _ = tx.send(r.map(|_| ()));
    });
    let r = rx.recv_timeout(TIMEOUT).expect("rates returned (no hang)");
    let e = r.expect_err("a non-finite plant is refused");
    assert!(e.contains("not finite") && e.contains("`l_a`"), "{e}");
}

/// Under error bursts (which destroy delimiters and merge frames into one reject) the
/// reject breakdown counts frames and sums to the rejected total, both directions.
#[test]
fn the_reject_breakdown_sums_to_the_total_under_bursts() {
    let dir = std::env::temp_dir().join(format!("sim-host-bursts-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let sc = dir.join("short.toml");
    std::fs::write(&sc, "duration_s = 0.5\n").unwrap();
    let args: Vec<String> = [
        "run",
        "--scenario",
        sc.to_str().unwrap(),
        "--loop",
        "device",
        "--faults",
        "burst=400:6",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let (code, text) = run(&args).expect("no hang");
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(code, 0, "{text}");
    let num = |line: &str, key: &str| -> u64 {
        let i = line
            .find(key)
            .unwrap_or_else(|| panic!("no `{key}` in {line}"))
            + key.len();
        line[i..]
            .trim_start()
            .split(|c: char| !c.is_ascii_digit())
            .next()
            .and_then(|d| d.parse().ok())
            .unwrap_or_else(|| panic!("no number after `{key}` in {line}"))
    };
    let mut seen = 0;
    for line in text
        .lines()
        .filter(|l| l.contains("> device: sent") || l.contains("> host: sent"))
    {
        seen += 1;
        assert!(line.contains("[adds up]"), "{line}");
        let total = num(line, "+ rejected");
        let parts: u64 = ["crc", "cobs", "version", "length", "postcard"]
            .iter()
            .map(|k| num(line, &format!("{k} ")))
            .sum();
        assert!(total > 0, "bursts must cause rejects: {line}");
        assert_eq!(parts, total, "{line}");
    }
    assert_eq!(seen, 2, "{text}");
}
