//! `hil sweep` on a real Slurm: the test starts a one-node cluster on this machine
//! (Debian's `slurm-wlm` and `munge`: its own `munged`, `slurmctld` and `slurmd` with a
//! generated `slurm.conf`, every file under one temporary directory, the daemons
//! stopped when the test ends, passed or not), then
//!
//! 1. submits `hil/slurm/sweep.sbatch` as an array of 4 tasks numbered `1-7:2` (8 grid
//!    points, 4 shards, in process) and `merge.sbatch` after it, and checks the merged
//!    document equals the single run's byte for byte;
//! 2. submits the same campaign with `hil/slurm/submit.sh`, catches one task while it
//!    runs (held by the `HIL_SWEEP_TEST_HOLD` hook between its temporary file and the
//!    rename), requeues it with `scontrol requeue`, checks the killed attempt left no
//!    document and the merge still waits, lets the task run again, and checks the
//!    merged document is still the single run's, byte for byte;
//! 3. submits it once more with task 2's `hil` exiting 3 (failed for good), sees the
//!    merge's dependency fail, and recovers as `submit.sh` says: `scancel` the merge,
//!    `submit.sh --rerun 2`, and the new merge is the single run's, byte for byte.
//!
//! Ignored by default (it needs root and the two packages): `REQUIRE_SLURM=1 cargo test
//! -p hil --test slurm -- --ignored` runs it and fails if the cluster does not start;
//! without `REQUIRE_SLURM=1` a machine without Slurm skips it with a message. `.ci/run`
//! installs the packages and runs it that way.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::cell::RefCell;
use std::fmt::Write as _;
use std::os::unix::fs::PermissionsExt as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const HIL: &str = env!("CARGO_BIN_EXE_hil");
const SHORT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/short.toml");
const SCRIPTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../slurm");
/// The campaign: 8 points.
const FLAGS: [&str; 6] = [
    "--scenario",
    SHORT,
    "--param",
    "f11=3e6..1e7:2",
    "--param",
    "lambda=0.1..0.4:4",
];
/// Longest wait for a daemon to come up or a job to reach a state (a guard against a
/// hang, not a measure: the whole test takes tens of seconds).
const PATIENCE: Duration = Duration::from_secs(180);
/// The programs the cluster needs.
const PROGRAMS: [&str; 9] = [
    "munged",
    "slurmctld",
    "slurmd",
    "sbatch",
    "scontrol",
    "squeue",
    "scancel",
    "sinfo",
    "hostname",
];

/// A one-node Slurm of this machine's CPUs (at most 2) under `dir`.
struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
    /// `(name, process)`, in start order; stopped in reverse.
    daemons: RefCell<Vec<(&'static str, Child)>>,
}

fn on_path(p: &str) -> bool {
    std::env::var_os("PATH").is_some_and(|path| {
        std::env::split_paths(&path).any(|d| d.join(p).is_file())
            || ["/usr/sbin", "/sbin"]
                .iter()
                .any(|d| Path::new(d).join(p).is_file())
    })
}

fn program(p: &str) -> PathBuf {
    for d in std::env::var_os("PATH")
        .map(|p| std::env::split_paths(&p).collect::<Vec<_>>())
        .unwrap_or_default()
        .into_iter()
        .chain(["/usr/sbin".into(), "/sbin".into()])
    {
        if d.join(p).is_file() {
            return d.join(p);
        }
    }
    PathBuf::from(p)
}

fn free_port() -> Result<u16, String> {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .map_err(|e| format!("no free TCP port: {e}"))
}

/// The last `n` lines of a file.
fn tail(path: &Path, n: usize) -> String {
    let t = std::fs::read_to_string(path).unwrap_or_else(|e| format!("({e})"));
    let lines: Vec<&str> = t.lines().collect();
    lines[lines.len().saturating_sub(n)..].join("\n")
}

impl Cluster {
    /// Starts munged, slurmctld and slurmd and waits for the node to be idle. The error
    /// says what did not start, with the daemons' logs.
    fn start() -> Result<Self, String> {
        if let Some(p) = PROGRAMS.iter().find(|p| !on_path(p)) {
            return Err(format!("{p} not found (apt-get install slurm-wlm munge)"));
        }
        let dir = std::env::temp_dir().join(format!("hil-slurm-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        for d in ["munge", "state", "spool", "log"] {
            std::fs::create_dir_all(dir.join(d)).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        let c = Cluster {
            conf: dir.join("slurm.conf"),
            dir,
            daemons: RefCell::new(Vec::new()),
        };
        c.start_daemons()
            .map_err(|e| format!("{e}\n{}", c.diagnosis()))?;
        Ok(c)
    }

    fn start_daemons(&self) -> Result<(), String> {
        let d = self.dir.clone();
        // munge: its own key and socket, so nothing of the machine's is used or touched.
        let key = d.join("munge/munge.key");
        let made = Command::new(program("mungekey"))
            .args(["--create", "--keyfile"])
            .arg(&key)
            .status()
            .is_ok_and(|s| s.success());
        if !made {
            // mungekey is newer than some munge packages: 1 KiB of randomness will do.
            use std::io::Read;
            let mut bytes = vec![0u8; 1024];
            std::fs::File::open("/dev/urandom")
                .and_then(|mut f| f.read_exact(&mut bytes))
                .map_err(|e| format!("cannot make a munge key: {e}"))?;
            std::fs::write(&key, bytes).map_err(|e| format!("{}: {e}", key.display()))?;
        }
        let chmod =
            |p: &Path, mode: &str| Command::new("chmod").arg(mode).arg(p).status().map(|_| ());
        chmod(&key, "600").map_err(|e| format!("chmod: {e}"))?;
        chmod(&d.join("munge"), "700").map_err(|e| format!("chmod: {e}"))?;
        let socket = d.join("munge/socket");
        let log = |name: &str| {
            std::fs::File::create(d.join("log").join(name))
                .map(Stdio::from)
                .map_err(|e| format!("{name}: {e}"))
        };
        self.spawn(
            "munged",
            Command::new(program("munged"))
                .args(["--foreground", "--force"])
                .arg(format!("--socket={}", socket.display()))
                .arg(format!("--key-file={}", key.display()))
                .arg(format!("--pid-file={}", d.join("munge/pid").display()))
                .arg(format!("--log-file={}", d.join("log/munged.log").display()))
                .arg(format!("--seed-file={}", d.join("munge/seed").display()))
                // In the foreground munged logs to stderr.
                .stderr(log("munged.out")?),
        )?;
        self.wait_until("munged's socket", || Ok(socket.exists()))?;

        let host = Command::new("hostname")
            .arg("-s")
            .output()
            .ok()
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
            .filter(|h| !h.is_empty())
            .ok_or("hostname -s gave no name")?;
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get().min(2));
        let (ctld_port, d_port) = (free_port()?, free_port()?);
        let conf = format!(
            "# A one-node cluster for hil/harness/tests/slurm.rs: everything under {dir}.
ClusterName=hiltest
SlurmctldHost={host}(127.0.0.1)
SlurmctldPort={ctld_port}
SlurmdPort={d_port}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
# cred_expire: a requeued job waits this long before it runs again (the default, 120
# s, would dominate the test): a new attempt's credential must postdate the revoked one.
AuthInfo=socket={socket},cred_expire=5
StateSaveLocation={dir}/state
SlurmdSpoolDir={dir}/spool
SlurmctldPidFile={dir}/slurmctld.pid
SlurmdPidFile={dir}/slurmd.pid
SlurmctldLogFile={dir}/log/slurmctld.log
SlurmdLogFile={dir}/log/slurmd.log
# No systemd and no cgroups here: processes tracked through /proc, no task binding.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SwitchType=switch/none
SchedulerType=sched/builtin
# The scheduler also runs on every submission and completion; its periodic pass (60 s
# by default) is what starts a requeued job once its wait is over.
SchedulerParameters=sched_interval=1
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
# Finished jobs stay visible to scontrol for the whole test.
MinJobAge=600
NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN
PartitionName=main Nodes=ALL Default=YES MaxTime=INFINITE State=UP
",
            dir = d.display(),
            socket = socket.display(),
        );
        std::fs::write(&self.conf, conf).map_err(|e| format!("{}: {e}", self.conf.display()))?;
        let mut ctld = Command::new(program("slurmctld"));
        ctld.args(["-D", "-i", "-f"])
            .arg(&self.conf)
            .stdout(log("slurmctld.out")?)
            .stderr(log("slurmctld.err")?);
        self.spawn("slurmctld", &mut ctld)?;
        self.wait_until("slurmctld", || {
            Ok(self
                .run("scontrol", &["ping"])
                .is_ok_and(|o| o.contains("UP")))
        })?;
        let mut slurmd = Command::new(program("slurmd"));
        slurmd
            .args(["-D", "-f"])
            .arg(&self.conf)
            .args(["-N", &host])
            .stdout(log("slurmd.out")?)
            .stderr(log("slurmd.err")?);
        self.spawn("slurmd", &mut slurmd)?;
        self.wait_until("the node to be idle", || {
            Ok(self
                .run("sinfo", &["-h", "-o", "%T"])
                .is_ok_and(|o| o.trim() == "idle"))
        })
    }

    fn spawn(&self, name: &'static str, cmd: &mut Command) -> Result<(), String> {
        let child = cmd
            .env("SLURM_CONF", &self.conf)
            .stdin(Stdio::null())
            .spawn()
            .map_err(|e| format!("{name}: cannot start: {e}"))?;
        self.daemons.borrow_mut().push((name, child));
        Ok(())
    }

    /// Polls `ready` until it holds; fails when a daemon has exited or after
    /// [`PATIENCE`].
    fn wait_until(
        &self,
        what: &str,
        mut ready: impl FnMut() -> Result<bool, String>,
    ) -> Result<(), String> {
        let start = Instant::now();
        loop {
            if ready()? {
                return Ok(());
            }
            for (name, child) in self.daemons.borrow_mut().iter_mut() {
                if let Ok(Some(st)) = child.try_wait() {
                    return Err(format!("waiting for {what}: {name} exited ({st})"));
                }
            }
            if start.elapsed() > PATIENCE {
                return Err(format!("no {what} within {PATIENCE:?}"));
            }
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// A Slurm client command against this cluster.
    fn command(&self, prog: &str) -> Command {
        let mut c = Command::new(program(prog));
        c.env("SLURM_CONF", &self.conf).stdin(Stdio::null());
        c
    }

    /// Runs a client command: its stdout, or an error with its stderr.
    fn run(&self, prog: &str, args: &[&str]) -> Result<String, String> {
        let o = self
            .command(prog)
            .args(args)
            .output()
            .map_err(|e| format!("{prog}: {e}"))?;
        if o.status.success() {
            Ok(String::from_utf8_lossy(&o.stdout).into_owned())
        } else {
            Err(format!(
                "{prog} {}: {}{}",
                args.join(" "),
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            ))
        }
    }

    /// `KEY=VALUE` of `scontrol show job ID`.
    fn job_field(&self, id: &str, key: &str) -> Result<String, String> {
        let t = self.run("scontrol", &["show", "job", id])?;
        t.split_whitespace()
            .find_map(|w| w.strip_prefix(&format!("{key}=")).map(str::to_string))
            .ok_or_else(|| format!("job {id}: no {key} in {t}"))
    }

    /// Waits for job `id` to complete; the error has its state and the logs.
    fn wait_completed(&self, id: &str) -> Result<(), String> {
        let mut last = String::new();
        let r = self.wait_until(&format!("job {id} to complete"), || {
            last = self.job_field(id, "JobState")?;
            match last.as_str() {
                "COMPLETED" => Ok(true),
                "PENDING" | "RUNNING" | "COMPLETING" | "CONFIGURING" | "REQUEUED" => Ok(false),
                s => Err(format!("job {id} ended {s}")),
            }
        });
        r.map_err(|e| format!("{e} (last state {last})"))
    }

    /// The daemons' logs and the jobs' logs, for a failure's message.
    fn diagnosis(&self) -> String {
        let mut s = format!("cluster directory {}\n", self.dir.display());
        let logs = self.dir.join("log");
        let mut files: Vec<PathBuf> = std::fs::read_dir(&logs)
            .map(|r| r.filter_map(|e| e.ok().map(|e| e.path())).collect())
            .unwrap_or_default();
        for sub in ["stepped/logs", "held/logs", "failed/logs"] {
            if let Ok(r) = std::fs::read_dir(self.dir.join(sub)) {
                files.extend(r.filter_map(|e| e.ok().map(|e| e.path())));
            }
        }
        files.sort();
        for f in files {
            let _ = writeln!(s, "--- {}\n{}", f.display(), tail(&f, 15));
        }
        if let Ok(q) = self.run("squeue", &["-a"]) {
            let _ = writeln!(s, "--- squeue\n{q}");
        }
        s
    }
}

impl Drop for Cluster {
    /// Cancels every job, then stops slurmd, slurmctld and munged (SIGTERM, then SIGKILL
    /// after 10 s). The directory is removed after a pass and kept after a failure.
    fn drop(&mut self) {
        let _ = std::fs::remove_file(self.dir.join("hold"));
        if let Ok(q) = self.run("squeue", &["-h", "-o", "%i"]) {
            let ids: Vec<&str> = q.split_whitespace().collect();
            if !ids.is_empty() {
                let _ = self.run("scancel", &ids);
                let start = Instant::now();
                while start.elapsed() < Duration::from_secs(20)
                    && self
                        .run("squeue", &["-h", "-o", "%i"])
                        .is_ok_and(|q| !q.trim().is_empty())
                {
                    std::thread::sleep(Duration::from_millis(200));
                }
            }
        }
        while let Some((_, mut child)) = self.daemons.borrow_mut().pop() {
            let _ = Command::new("kill")
                .args(["-TERM", &child.id().to_string()])
                .status();
            let start = Instant::now();
            while start.elapsed() < Duration::from_secs(10) && matches!(child.try_wait(), Ok(None))
            {
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = child.kill();
            let _ = child.wait();
        }
        if std::thread::panicking() {
            eprintln!("slurm test: kept {} for inspection", self.dir.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

/// Fails with the cluster's logs.
macro_rules! check {
    ($c:expr, $r:expr) => {
        match $r {
            Ok(v) => v,
            Err(e) => panic!("{e}\n{}", $c.diagnosis()),
        }
    };
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// `hil/slurm/submit.sh OPTIONS -- FLAGS` with `HIL_SWEEP_TEST_HOLD=hold`: what it
/// printed.
impl Cluster {
    fn submit(&self, options: &[&str], hold: &Path) -> Result<String, String> {
        let o = self
            .command("bash")
            .arg(format!("{SCRIPTS}/submit.sh"))
            .args(options)
            .arg("--")
            .args(FLAGS)
            .env("HIL_SWEEP_TEST_HOLD", hold)
            .output()
            .map_err(|e| format!("submit.sh: {e}"))?;
        let said = String::from_utf8_lossy(&o.stdout).into_owned();
        if o.status.success() {
            Ok(said)
        } else {
            Err(format!(
                "submit.sh {}: {said}{}",
                options.join(" "),
                String::from_utf8_lossy(&o.stderr)
            ))
        }
    }
}

/// The job ID after `label` in submit.sh's output (`array job: 12 (...)`).
fn id_after(said: &str, label: &str) -> String {
    said.lines()
        .find_map(|l| l.strip_prefix(label))
        .and_then(|r| r.split_whitespace().next())
        .map(str::to_string)
        .unwrap_or_else(|| panic!("no `{label}` in {said}"))
}

#[test]
#[ignore = "starts a one-node Slurm (root, slurm-wlm, munge): REQUIRE_SLURM=1 cargo test -p hil --test slurm -- --ignored"]
fn a_sweep_on_a_one_node_slurm_merges_into_the_single_run_through_a_requeue_and_a_rerun() {
    let required = std::env::var("REQUIRE_SLURM").is_ok_and(|v| v == "1");
    let t0 = Instant::now();
    let c = match Cluster::start() {
        Ok(c) => c,
        Err(e) if required => panic!("REQUIRE_SLURM=1, but the one-node Slurm did not start: {e}"),
        Err(e) => {
            eprintln!("slurm test skipped (REQUIRE_SLURM=1 makes this a failure): {e}");
            return;
        }
    };
    eprintln!("slurm: cluster up in {:.1} s", t0.elapsed().as_secs_f64());

    // The single run, outside Slurm.
    let whole = c.dir.join("whole.json");
    let mut single = Command::new(HIL);
    single
        .args(["sweep", "--quiet", "--shard", "all", "--json"])
        .arg(&whole)
        .args(FLAGS);
    let o = single.output().unwrap();
    assert!(
        matches!(o.status.code(), Some(0 | 1)),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let whole = read(&whole);

    // 1. The array by hand, IDs 1, 3, 5, 7: the shards 0..3 of 4.
    let out = c.dir.join("stepped");
    std::fs::create_dir_all(out.join("logs")).unwrap();
    let o = out.display().to_string();
    let export = format!("--export=ALL,HIL={HIL}");
    let mut args = vec![
        "--parsable".to_string(),
        "--array=1-7:2".into(),
        export.clone(),
        format!("--output={o}/logs/shard-%a.log"),
        format!("{SCRIPTS}/sweep.sbatch"),
        o.clone(),
    ];
    args.extend(FLAGS.iter().map(|s| s.to_string()));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let array = check!(c, c.run("sbatch", &args)).trim().to_string();
    let merge = check!(
        c,
        c.run(
            "sbatch",
            &[
                "--parsable",
                &format!("--dependency=afterok:{array}"),
                &export,
                &format!("--output={o}/logs/merge.log"),
                &format!("{SCRIPTS}/merge.sbatch"),
                &o,
            ],
        )
    )
    .trim()
    .to_string();
    check!(c, c.wait_completed(&merge));
    assert_eq!(
        read(&out.join("sweep.json")),
        whole,
        "the merged document of the array 1-7:2 is not the single run's"
    );
    for i in 0..4 {
        let doc: serde_json::Value =
            serde_json::from_str(&read(&out.join(format!("shards/shard-{i}.json")))).unwrap();
        assert_eq!(doc["shard"]["index"], i);
        assert_eq!(doc["shard"]["count"], 4);
    }
    eprintln!(
        "slurm: array 1-7:2 and merge done at {:.1} s",
        t0.elapsed().as_secs_f64()
    );

    // 2. submit.sh, with every task held before its rename; one is requeued there.
    let out = c.dir.join("held");
    let hold = c.dir.join("hold");
    std::fs::write(&hold, "").unwrap();
    let said = check!(
        c,
        c.submit(
            &["-n", "4", "-o", &out.display().to_string(), "--hil", HIL],
            &hold
        )
    );
    let (array, merge) = (
        id_after(&said, "array job: "),
        id_after(&said, "merge job: "),
    );
    // A task held between its temporary file and the rename: running, document unwritten.
    let shards = out.join("shards");
    let mut held = None;
    check!(
        c,
        c.wait_until("a held task", || {
            held = std::fs::read_dir(&shards)
                .map_err(|e| e.to_string())?
                .filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .find_map(|n| {
                    n.strip_prefix(".shard-")
                        .and_then(|r| r.split('.').next())
                        .and_then(|i| i.parse::<usize>().ok())
                });
            Ok(held.is_some())
        })
    );
    let i = held.unwrap();
    let task = format!("{array}_{i}");
    assert_eq!(check!(c, c.job_field(&task, "JobState")), "RUNNING");
    check!(c, c.run("scontrol", &["requeue", &task]));
    check!(
        c,
        c.wait_until(&format!("{task} to be pending again"), || Ok(c
            .job_field(&task, "JobState")?
            == "PENDING"))
    );
    let doc = shards.join(format!("shard-{i}.json"));
    assert!(
        !doc.exists(),
        "the killed attempt of {task} left {}",
        doc.display()
    );
    assert_eq!(check!(c, c.job_field(&merge, "JobState")), "PENDING");
    assert_eq!(check!(c, c.job_field(&merge, "Reason")), "Dependency");
    std::fs::remove_file(&hold).unwrap();
    check!(c, c.wait_completed(&merge));
    assert_eq!(check!(c, c.job_field(&task, "Restarts")), "1");
    assert_eq!(check!(c, c.job_field(&task, "JobState")), "COMPLETED");
    let log = read(&out.join(format!("logs/shard-{i}.log")));
    assert!(
        log.contains("(restart 0)") && log.contains("(restart 1)"),
        "the log of {task} does not show both attempts:\n{log}"
    );
    assert_eq!(
        read(&out.join("sweep.json")),
        whole,
        "the merged document with {task} requeued is not the single run's"
    );
    eprintln!(
        "slurm: submit.sh with {task} requeued while running: merged byte for byte at {:.1} s\n\
         slurm: the log of {task}:\n{log}",
        t0.elapsed().as_secs_f64()
    );

    // 3. A task that fails for good (its hil exits 3, as with a missing QEMU): the merge
    // can never run; the recovery of submit.sh: cancel it, rerun the shard, merge again.
    let out = c.dir.join("failed");
    let wrapper = c.dir.join("hil-failing-task-2");
    std::fs::write(
        &wrapper,
        format!(
            "#!/bin/bash\n[ \"${{SLURM_ARRAY_TASK_ID:-}}\" = 2 ] && exit 3\nexec {HIL} \"$@\"\n"
        ),
    )
    .unwrap();
    std::fs::set_permissions(&wrapper, std::fs::Permissions::from_mode(0o755)).unwrap();
    let o = out.display().to_string();
    let w = wrapper.display().to_string();
    let said = check!(c, c.submit(&["-n", "4", "-o", &o, "--hil", &w], &hold));
    let (array, merge) = (
        id_after(&said, "array job: "),
        id_after(&said, "merge job: "),
    );
    let failed = format!("{array}_2");
    check!(
        c,
        c.wait_until(&format!("{failed} to fail"), || Ok(c
            .job_field(&failed, "JobState")?
            == "FAILED"))
    );
    check!(
        c,
        c.wait_until("the merge's dependency to fail", || Ok(c
            .job_field(&merge, "Reason")?
            == "DependencyNeverSatisfied"))
    );
    check!(c, c.run("scancel", &[&merge]));
    let said = check!(
        c,
        c.submit(&["--rerun", "2", "-n", "4", "-o", &o, "--hil", HIL], &hold)
    );
    let rerun = id_after(&said, "rerun job: ");
    let merge = id_after(&said, "merge job: ");
    check!(c, c.wait_completed(&merge));
    assert_eq!(check!(c, c.job_field(&rerun, "JobState")), "COMPLETED");
    assert_eq!(
        read(&out.join("sweep.json")),
        whole,
        "the merged document after the rerun of shard 2 is not the single run's"
    );
    eprintln!(
        "slurm: task {failed} failed for good, shard 2 rerun by submit.sh --rerun, merged byte \
         for byte at {:.1} s",
        t0.elapsed().as_secs_f64()
    );
}
