//! `hil sweep` on job arrays: the shard from Slurm's array variables and Kubernetes'
//! `JOB_COMPLETION_INDEX`, bad or conflicting shard settings refused with exit 2 naming
//! the flag and the variable, documents written atomically (a killed writer leaves no
//! half document), and `merge` refusing missing, duplicated and foreign shards by name.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use hil::sweep::{resolve, Shard, ShardSpec};

/// The variables of the job arrays, removed from every child so that a test run inside
/// a Slurm job or a pod stays hermetic.
const ARRAY_VARS: [&str; 7] = [
    "SLURM_ARRAY_TASK_ID",
    "SLURM_ARRAY_TASK_MIN",
    "SLURM_ARRAY_TASK_MAX",
    "SLURM_ARRAY_TASK_STEP",
    "SLURM_ARRAY_TASK_COUNT",
    "JOB_COMPLETION_INDEX",
    "HIL_SWEEP_TEST_HOLD",
];

const SHORT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/short.toml");
/// 8 points.
const GRID: [&str; 4] = ["--param", "f11=3e6..1e7:2", "--param", "lambda=0.1..0.4:4"];

/// A job array's variables, `(name, value)`.
type Vars = Vec<(String, String)>;
/// One row: `(flags, environment, words the refusal must carry)`.
type Row<'a> = (&'a [&'a str], &'a [(&'a str, &'a str)], &'a [&'a str]);

fn dir(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("sweep_shard_env")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn command(args: &[&str], env: &[(&str, &str)]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_hil"));
    for v in ARRAY_VARS {
        c.env_remove(v);
    }
    c.args(args).envs(env.iter().copied());
    c
}

fn hil(args: &[&str], env: &[(&str, &str)]) -> Output {
    command(args, env).output().expect("hil starts")
}

/// `hil sweep` over [`GRID`] on the short scenario, writing `json` (on one thread
/// unless `extra` says).
fn sweep(json: &Path, extra: &[&str], env: &[(&str, &str)]) -> Output {
    let mut a = vec![
        "sweep",
        "--scenario",
        SHORT,
        "--quiet",
        "--json",
        json.to_str().unwrap(),
    ];
    a.extend(GRID);
    a.extend(extra);
    if !extra.contains(&"--jobs") {
        a.extend(["--jobs", "1"]);
    }
    hil(&a, env)
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn ok(o: &Output) -> String {
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", text(o));
    text(o)
}

/// Slurm's variables for task `id` of `--array=min-max:step`.
fn slurm(id: usize, min: usize, max: usize, step: usize) -> Vars {
    vec![
        ("SLURM_ARRAY_TASK_ID".into(), id.to_string()),
        ("SLURM_ARRAY_TASK_MIN".into(), min.to_string()),
        ("SLURM_ARRAY_TASK_MAX".into(), max.to_string()),
        ("SLURM_ARRAY_TASK_STEP".into(), step.to_string()),
        (
            "SLURM_ARRAY_TASK_COUNT".into(),
            ((max - min) / step + 1).to_string(),
        ),
    ]
}

fn lookup(vars: &[(String, String)]) -> impl Fn(&str) -> Option<String> + '_ {
    let m: HashMap<&str, &str> = vars.iter().map(|(k, v)| (k.as_str(), v.as_str())).collect();
    move |k| m.get(k).map(|v| (*v).to_string())
}

#[test]
fn slurm_arrays_of_any_first_id_and_step_are_the_shards_0_to_n_minus_1() {
    // --array=1-8, 0-3, 1-4 and 1-15:2 (the variables Slurm 22.05 sets for them).
    for (min, max, step) in [(1, 8, 1), (0, 3, 1), (1, 4, 1), (1, 15, 2), (5, 5, 1)] {
        let n = (max - min) / step + 1;
        let mut got = Vec::new();
        for id in (min..=max).step_by(step) {
            let vars = slurm(id, min, max, step);
            for flag in [None, Some(ShardSpec::Auto { count: None })] {
                let s = resolve(flag, &lookup(&vars)).unwrap();
                assert_eq!(s.map(|s| s.count), Some(n), "{id} of {min}-{max}:{step}");
                got.push(s.unwrap().index);
            }
            // The same shard given as a flag or as auto/N agrees with the array.
            let s = resolve(None, &lookup(&vars)).unwrap().unwrap();
            assert_eq!(
                resolve(Some(ShardSpec::Fixed(s)), &lookup(&vars)),
                Ok(Some(s))
            );
            assert_eq!(
                resolve(Some(ShardSpec::Auto { count: Some(n) }), &lookup(&vars)),
                Ok(Some(s))
            );
            // `all` ignores the array.
            assert_eq!(resolve(Some(ShardSpec::All), &lookup(&vars)), Ok(None));
        }
        got.dedup();
        assert_eq!(got, (0..n).collect::<Vec<_>>(), "{min}-{max}:{step}");
    }
    // Kubernetes: the index from JOB_COMPLETION_INDEX, the count from auto/N.
    let k8s = vec![("JOB_COMPLETION_INDEX".to_string(), "3".to_string())];
    assert_eq!(
        resolve(Some(ShardSpec::Auto { count: Some(8) }), &lookup(&k8s)),
        Ok(Some(Shard { index: 3, count: 8 }))
    );
    assert_eq!(
        resolve(Some("3/8".parse().unwrap()), &lookup(&k8s)),
        Ok(Some(Shard { index: 3, count: 8 }))
    );
    // Outside an array: the flag alone; no flag, every point.
    assert_eq!(resolve(None, &lookup(&[])), Ok(None));
    assert_eq!(
        resolve(Some("1/3".parse().unwrap()), &lookup(&[])),
        Ok(Some(Shard { index: 1, count: 3 }))
    );
    // An empty variable is unset (a shell's `export VAR=`).
    let empty = vec![("SLURM_ARRAY_TASK_ID".to_string(), String::new())];
    assert_eq!(resolve(None, &lookup(&empty)), Ok(None));
}

#[test]
fn bad_and_conflicting_shard_settings_say_which_and_why() {
    let with = |mut v: Vars, k: &str, val: &str| {
        v.retain(|(key, _)| key != k);
        if !val.is_empty() {
            v.push((k.to_string(), val.to_string()));
        }
        v
    };
    let k8s = |i: &str| vec![("JOB_COMPLETION_INDEX".to_string(), i.to_string())];
    let cases: Vec<(Option<&str>, Vars, Vec<&str>)> = vec![
        // --array=1,2,5: Slurm reports MIN 1, MAX 5, STEP 1, COUNT 3.
        (
            None,
            with(slurm(5, 1, 3, 1), "SLURM_ARRAY_TASK_MAX", "5"),
            vec![
                "SLURM_ARRAY_TASK_MAX=5",
                "not one range with one step",
                "--array=0-2",
            ],
        ),
        // An ID off the step, below MIN, past the count.
        (
            None,
            with(slurm(1, 1, 15, 2), "SLURM_ARRAY_TASK_ID", "4"),
            vec!["SLURM_ARRAY_TASK_ID=4", "not a task of the array 1-15:2"],
        ),
        (
            None,
            with(slurm(1, 1, 15, 2), "SLURM_ARRAY_TASK_ID", "0"),
            vec!["SLURM_ARRAY_TASK_ID=0", "not a task"],
        ),
        (
            None,
            with(slurm(1, 1, 15, 2), "SLURM_ARRAY_TASK_ID", "17"),
            vec!["SLURM_ARRAY_TASK_ID=17", "not a task"],
        ),
        // A variable missing or not a number.
        (
            Some("auto"),
            with(slurm(1, 1, 8, 1), "SLURM_ARRAY_TASK_COUNT", ""),
            vec!["SLURM_ARRAY_TASK_COUNT", "is not"],
        ),
        (
            None,
            with(slurm(1, 1, 8, 1), "SLURM_ARRAY_TASK_STEP", "two"),
            vec!["SLURM_ARRAY_TASK_STEP=two", "whole number"],
        ),
        (
            None,
            with(slurm(1, 1, 8, 1), "SLURM_ARRAY_TASK_STEP", "0"),
            vec!["SLURM_ARRAY_TASK_STEP=0", "at least 1"],
        ),
        (
            None,
            k8s("-1"),
            vec!["JOB_COMPLETION_INDEX=-1", "whole number"],
        ),
        // Kubernetes without a count.
        (
            None,
            k8s("2"),
            vec!["JOB_COMPLETION_INDEX=2", "--shard auto/N"],
        ),
        (
            Some("auto"),
            k8s("2"),
            vec!["JOB_COMPLETION_INDEX=2", "auto/N"],
        ),
        (
            Some("auto/2"),
            k8s("2"),
            vec!["--shard auto/2", "not below N = 2"],
        ),
        // Flag against environment: both named.
        (
            Some("1/4"),
            slurm(3, 1, 4, 1),
            vec!["--shard 1/4", "SLURM_ARRAY_TASK_ID=3", "shard 2/4"],
        ),
        (
            Some("2/5"),
            slurm(3, 1, 4, 1),
            vec!["--shard 2/5", "SLURM_ARRAY_TASK_COUNT=4"],
        ),
        (
            Some("auto/8"),
            slurm(3, 1, 4, 1),
            vec!["--shard auto/8", "SLURM_ARRAY_TASK_COUNT=4", "4 tasks"],
        ),
        (
            Some("0/4"),
            k8s("1"),
            vec!["--shard 0/4", "JOB_COMPLETION_INDEX=1"],
        ),
        // Two arrays that disagree.
        (
            None,
            [slurm(2, 1, 4, 1), k8s("3")].concat(),
            vec![
                "SLURM_ARRAY_TASK_ID=2",
                "JOB_COMPLETION_INDEX=3",
                "different shards",
            ],
        ),
        // auto outside an array.
        (
            Some("auto"),
            vec![],
            vec!["--shard auto", "not in a job array"],
        ),
        (
            Some("auto/4"),
            vec![],
            vec!["--shard auto", "not in a job array"],
        ),
    ];
    for (flag, vars, words) in &cases {
        let spec = flag.map(|f| f.parse::<ShardSpec>().unwrap());
        let e = resolve(spec, &lookup(vars)).unwrap_err();
        for w in words {
            assert!(e.contains(w), "{flag:?} {vars:?}: `{w}` not in: {e}");
        }
    }
    for (spec, words) in [
        ("auto/0", "at least 1"),
        ("auto/x", "auto/N"),
        ("some", "auto, auto/N or all"),
        ("2/2", "below N"),
    ] {
        let e = spec.parse::<ShardSpec>().unwrap_err();
        assert!(e.contains(words), "{spec}: {e}");
    }
}

/// The hostile-input rows of `hil sweep`'s shard settings: each command line, with its
/// environment, exits 2 and names what is wrong, before any point runs.
#[test]
fn bad_shard_settings_exit_2_naming_the_flag_and_the_variable() {
    let d = dir("rows");
    let json = d.join("x.json");
    let j = json.to_str().unwrap();
    let list = [
        ("SLURM_ARRAY_TASK_ID", "5"),
        ("SLURM_ARRAY_TASK_MIN", "1"),
        ("SLURM_ARRAY_TASK_MAX", "5"),
        ("SLURM_ARRAY_TASK_STEP", "1"),
        ("SLURM_ARRAY_TASK_COUNT", "3"),
    ];
    let task3of4 = [
        ("SLURM_ARRAY_TASK_ID", "3"),
        ("SLURM_ARRAY_TASK_MIN", "1"),
        ("SLURM_ARRAY_TASK_MAX", "4"),
        ("SLURM_ARRAY_TASK_STEP", "1"),
        ("SLURM_ARRAY_TASK_COUNT", "4"),
    ];
    let rows: &[Row] = &[
        (
            &["--shard", "auto"],
            &[],
            &["--shard auto", "not in a job array"],
        ),
        (&["--shard", "x"], &[], &["--shard", "auto, auto/N or all"]),
        (&["--shard", "auto/0"], &[], &["--shard", "at least 1"]),
        (
            &[],
            &list,
            &["--shard", "SLURM_ARRAY_TASK_MAX=5", "not one range"],
        ),
        (
            &["--shard", "1/4"],
            &task3of4,
            &["--shard 1/4", "SLURM_ARRAY_TASK_ID=3"],
        ),
        (
            &["--shard", "auto/8"],
            &task3of4,
            &["--shard auto/8", "SLURM_ARRAY_TASK_COUNT=4"],
        ),
        (
            &[],
            &[("JOB_COMPLETION_INDEX", "1")],
            &["JOB_COMPLETION_INDEX=1", "--shard auto/N"],
        ),
        (
            &["--shard", "auto/4"],
            &[("JOB_COMPLETION_INDEX", "one")],
            &["JOB_COMPLETION_INDEX=one", "whole number"],
        ),
        (
            &["--shard", "auto"],
            &[("SLURM_ARRAY_TASK_ID", "2")],
            &["SLURM_ARRAY_TASK_MIN", "is not"],
        ),
    ];
    for (args, env, words) in rows {
        let mut a = vec!["sweep", "--quiet", "--json", j, "--param", "f11=3e6"];
        a.extend(args.iter());
        let out = hil(&a, env);
        let t = text(&out);
        assert_eq!(out.status.code(), Some(2), "{args:?} {env:?}: {t}");
        for w in *words {
            assert!(t.contains(w), "{args:?} {env:?}: `{w}` not in {t}");
        }
        assert!(!json.exists(), "{args:?} {env:?}: wrote a document");
    }
}

#[test]
fn shards_from_slurm_and_kubernetes_variables_merge_into_the_single_run_byte_for_byte() {
    let d = dir("env");
    let whole = d.join("whole.json");
    ok(&sweep(&whole, &[], &[]));
    // --array=1-7:2 (4 tasks): each task finds its shard without a --shard flag.
    let mut files = Vec::new();
    for id in [7, 3, 1, 5] {
        let f = d.join(format!("slurm-{id}.json"));
        let vars = slurm(id, 1, 7, 2);
        let env: Vec<(&str, &str)> = vars.iter().map(|(k, v)| (k.as_str(), v.as_str())).collect();
        let out = ok(&sweep(&f, &[], &env));
        let want = format!("shard: {}/4 (from the job array", (id - 1) / 2);
        assert!(out.contains(&want), "{out}");
        files.push(f);
    }
    let merged = d.join("merged.json");
    let mut a = vec!["sweep", "merge"];
    a.extend(files.iter().map(|f| f.to_str().unwrap()));
    a.extend(["--json", merged.to_str().unwrap()]);
    ok(&hil(&a, &[]));
    assert_eq!(
        std::fs::read_to_string(&whole).unwrap(),
        std::fs::read_to_string(&merged).unwrap()
    );
    // Kubernetes: JOB_COMPLETION_INDEX 0..2 with --shard auto/3.
    let mut files = Vec::new();
    for i in 0..3 {
        let f = d.join(format!("k8s-{i}.json"));
        let idx = i.to_string();
        ok(&sweep(
            &f,
            &["--shard", "auto/3"],
            &[("JOB_COMPLETION_INDEX", &idx)],
        ));
        let doc: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
        assert_eq!(doc["shard"]["index"], i);
        assert_eq!(doc["shard"]["count"], 3);
        files.push(f);
    }
    let mut a = vec!["sweep", "merge"];
    a.extend(files.iter().map(|f| f.to_str().unwrap()));
    a.extend(["--json", merged.to_str().unwrap()]);
    ok(&hil(&a, &[]));
    assert_eq!(
        std::fs::read_to_string(&whole).unwrap(),
        std::fs::read_to_string(&merged).unwrap()
    );
    // `--shard all` inside an array task: the whole grid, the single run's document.
    let all = d.join("all.json");
    let vars = slurm(3, 1, 7, 2);
    let env: Vec<(&str, &str)> = vars.iter().map(|(k, v)| (k.as_str(), v.as_str())).collect();
    ok(&sweep(&all, &["--shard", "all"], &env));
    assert_eq!(
        std::fs::read_to_string(&whole).unwrap(),
        std::fs::read_to_string(&all).unwrap()
    );
}

#[test]
fn the_header_identifies_the_build_and_the_input_files_by_content() {
    let d = dir("identity");
    let whole = d.join("whole.json");
    ok(&sweep(&whole, &[], &[]));
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&whole).unwrap()).unwrap();
    let id = &doc["sweep"]["identity"];
    let sha = |p: &Path| hil::sweep::sha256_of(std::fs::File::open(p).unwrap()).unwrap();
    assert_eq!(id["hil_sha256"], sha(Path::new(env!("CARGO_BIN_EXE_hil"))));
    assert_eq!(id["scenario_sha256"], sha(Path::new(SHORT)));
    assert_eq!(id["hil_version"], env!("CARGO_PKG_VERSION"));
    assert!(id["elf_sha256"].is_null() && id["params_sha256"].is_null());
    // The SHA-256 of "abc" (FIPS 180-2, appendix B.1).
    assert_eq!(
        hil::sweep::sha256_of(&b"abc"[..]).unwrap(),
        "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
    );
    // No timing in the document: two runs on different thread counts are equal.
    let again = d.join("again.json");
    ok(&sweep(&again, &["--jobs", "2"], &[]));
    assert_eq!(
        std::fs::read_to_string(&whole).unwrap(),
        std::fs::read_to_string(&again).unwrap()
    );
}

/// Merges `files` into `out`: the output.
fn merge(files: &[&Path], out: &Path) -> Output {
    let mut a = vec!["sweep", "merge"];
    a.extend(files.iter().map(|f| f.to_str().unwrap()));
    a.extend(["--json", out.to_str().unwrap()]);
    hil(&a, &[])
}

fn refused(out: &Output, words: &[&str]) {
    let t = text(out);
    assert_eq!(out.status.code(), Some(2), "{t}");
    for w in words {
        assert!(t.contains(w), "`{w}` not in {t}");
    }
}

#[test]
fn merge_refuses_a_missing_duplicated_or_foreign_shard_naming_it() {
    let d = dir("merge");
    let params = d.join("p.toml");
    std::fs::write(&params, "v = 80.0\n").unwrap();
    let p = params.to_str().unwrap();
    let s: Vec<PathBuf> = (0..4).map(|i| d.join(format!("s{i}.json"))).collect();
    for (i, f) in s.iter().enumerate() {
        ok(&sweep(
            f,
            &["--params", p, "--shard", &format!("{i}/4")],
            &[],
        ));
    }
    let out = d.join("merged.json");
    let names: Vec<String> = s.iter().map(|f| f.display().to_string()).collect();

    // Missing: shard 2 (points 2 and 6).
    refused(
        &merge(&[&s[0], &s[1], &s[3]], &out),
        &["shard 2/4", "missing", "2, 6"],
    );
    refused(
        &merge(&[&s[0], &s[3]], &out),
        &["shards 1/4, 2/4", "missing"],
    );
    // Duplicated: the same shard in two files, both named.
    let copy = d.join("s1-copy.json");
    std::fs::copy(&s[1], &copy).unwrap();
    refused(
        &merge(&[&s[0], &s[1], &copy, &s[2], &s[3]], &out),
        &[
            "shard 1/4",
            "more than one",
            &names[1],
            copy.to_str().unwrap(),
        ],
    );
    // Foreign: shard 2 run again after the parameter file changed (same path, same
    // flags): refused by the content's digest.
    let redo = d.join("s2-redo.json");
    std::fs::write(&params, "v = 82.0\n").unwrap();
    ok(&sweep(&redo, &["--params", p, "--shard", "2/4"], &[]));
    refused(
        &merge(&[&s[0], &s[1], &redo, &s[3]], &out),
        &[
            "another campaign",
            redo.to_str().unwrap(),
            "sweep.identity.params_sha256",
        ],
    );
    // Foreign: another seed; another split of the same campaign.
    let seed = d.join("s3-seed.json");
    std::fs::write(&params, "v = 80.0\n").unwrap();
    ok(&sweep(
        &seed,
        &["--params", p, "--shard", "3/4", "--seed", "2"],
        &[],
    ));
    refused(
        &merge(&[&s[0], &s[1], &s[2], &seed], &out),
        &[
            "another campaign",
            seed.to_str().unwrap(),
            "sweep.seed",
            "(1 vs 2)",
        ],
    );
    let third = d.join("third.json");
    ok(&sweep(&third, &["--params", p, "--shard", "0/3"], &[]));
    refused(
        &merge(&[&s[0], &s[1], &third], &out),
        &[&names[0], "shard 0/4", third.to_str().unwrap(), "shard 0/3"],
    );
    // A shard whose records are not its own (an edited document).
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&s[3]).unwrap()).unwrap();
    v["records"][0]["index"] = 2.into();
    let edited = d.join("s3-edited.json");
    std::fs::write(&edited, v.to_string()).unwrap();
    refused(
        &merge(&[&s[0], &s[1], &s[2], &edited], &out),
        &[edited.to_str().unwrap(), "shard 3/4", "point 2"],
    );
    assert!(!out.exists(), "a refused merge wrote its output");
    // The four parts in any order: the single run.
    ok(&merge(&[&s[3], &s[1], &s[0], &s[2]], &out));
    let whole = d.join("whole.json");
    ok(&sweep(&whole, &["--params", p], &[]));
    assert_eq!(
        std::fs::read_to_string(&whole).unwrap(),
        std::fs::read_to_string(&out).unwrap()
    );
}

#[test]
fn a_writer_killed_before_its_rename_leaves_no_document_and_a_rerun_completes_it() {
    let d = dir("atomic");
    let hold = d.join("hold");
    std::fs::write(&hold, "").unwrap();
    let json = d.join("shard-1.json");
    let mut a = vec![
        "sweep",
        "--scenario",
        SHORT,
        "--quiet",
        "--jobs",
        "1",
        "--shard",
        "1/4",
        "--json",
        json.to_str().unwrap(),
    ];
    a.extend(GRID);
    let mut child = command(&a, &[("HIL_SWEEP_TEST_HOLD", hold.to_str().unwrap())])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let tmp = d.join(format!(".shard-1.json.{}.tmp", child.id()));
    let start = Instant::now();
    while !tmp.exists() {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "the held writer never wrote {}",
            tmp.display()
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "the held writer exited"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    // Held between the temporary file and the rename: killed there, as a scheduler's
    // requeue does.
    assert!(!json.exists());
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(!json.exists(), "a killed writer left {}", json.display());
    let whole_tmp: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&tmp).unwrap()).unwrap();
    assert_eq!(whole_tmp["shard"]["index"], 1);
    // Run again (the requeued task): the document, whole.
    ok(&sweep(&json, &["--shard", "1/4"], &[]));
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(doc["records"].as_array().unwrap().len(), 2);
    // A merge takes files by name: the leftover temporary file is not a shard's name.
    let left: Vec<String> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("shard-"))
        .collect();
    assert_eq!(left, vec!["shard-1.json".to_string()]);
}
