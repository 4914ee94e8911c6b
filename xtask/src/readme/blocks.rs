//! The table of the generated blocks of the README and the book ([`BLOCKS`]).

/// The binaries the README's aliases run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bin {
    /// `cargo sim` (`sim-host`).
    Sim,
    /// `cargo hil` (`hil`).
    Hil,
}

impl Bin {
    fn alias(self) -> &'static str {
        match self {
            Bin::Sim => "cargo sim",
            Bin::Hil => "cargo hil",
        }
    }
    /// The binary's file name.
    pub(super) fn file(self) -> &'static str {
        match self {
            Bin::Sim => "sim-host",
            Bin::Hil => "hil",
        }
    }
}

/// Which lines of a command's standard output a block keeps.
#[derive(Debug, Clone, Copy)]
pub enum Keep {
    /// Every line.
    All,
    /// Every line but those containing one of these (machine-dependent figures).
    AllBut(&'static [&'static str]),
    /// Only the lines starting with one of these (a long report's summary lines).
    Starting(&'static [&'static str]),
    /// The output is Markdown: the block is the output verbatim (it says its command).
    Markdown,
}

impl Keep {
    pub(super) fn keeps(self, line: &str) -> bool {
        match self {
            Keep::All | Keep::Markdown => true,
            Keep::Starting(p) => p.iter().any(|p| line.starts_with(p)),
            Keep::AllBut(p) => !p.iter().any(|p| line.contains(p)),
        }
    }
}

/// One generated block: its name in the markers, the command and what it keeps.
#[derive(Debug, Clone, Copy)]
pub struct Block {
    /// The name in `<!-- generated:NAME -->`.
    pub name: &'static str,
    /// The binary.
    pub bin: Bin,
    /// Its arguments, separated by spaces (no argument holds a space).
    pub args: &'static str,
    /// The exit code the command is expected to end with.
    pub exit: i32,
    /// The lines of standard output kept.
    pub keep: Keep,
    /// Quote standard error instead of standard output (a refusal's message).
    pub stderr: bool,
}

impl Block {
    /// The command as the README shows it: the alias and the arguments.
    pub fn shown(&self) -> String {
        std::iter::once(self.bin.alias())
            .chain(self.argv())
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// The arguments one by one.
    pub fn argv(&self) -> impl Iterator<Item = &'static str> {
        self.args.split_whitespace()
    }

    const fn exit(self, code: i32) -> Self {
        Self { exit: code, ..self }
    }

    const fn keep(self, keep: Keep) -> Self {
        Self { keep, ..self }
    }

    /// Quotes standard error (a refusal's message).
    const fn stderr(self) -> Self {
        Self {
            stderr: true,
            ..self
        }
    }
}

/// A `cargo sim` block: every line kept, exit 0, standard output.
pub(super) const fn sim(name: &'static str, args: &'static str) -> Block {
    Block {
        name,
        bin: Bin::Sim,
        args,
        exit: 0,
        keep: Keep::All,
        stderr: false,
    }
}

/// The lines of `hil soak`'s summary that depend on the machine.
const SOAK_MACHINE_DEPENDENT: &[&str] = &["s wall", "peak RSS"];

/// A `cargo hil` block: every line but the [`MACHINE_DEPENDENT`] ones, exit 0, stdout.
pub(super) const fn hil(name: &'static str, args: &'static str) -> Block {
    Block {
        name,
        bin: Bin::Hil,
        args,
        exit: 0,
        keep: Keep::AllBut(MACHINE_DEPENDENT),
        stderr: false,
    }
}

/// Lines whose figures depend on the machine or its load.
pub(super) const MACHINE_DEPENDENT: &[&str] = &["wall", "host_tick", "host time", "exchanges/s"];

/// Every generated block of the README and the book (each in one page).
pub const BLOCKS: &[Block] = &[
    // The README: the main job as a newcomer types it.
    hil("main-job", "--json out/hil.json --report out/report"),
    // Plant simulator: Figs. 2-5, 6-8, 9.
    sim("modes", "modes --json out/modes.json --plot out/modes"),
    sim("fig6-8", "run --scenario curve --control lead --compare passive --csv out/curve.csv --plot out/fig6-8 --at 4.9 --at 11.9"),
    sim("fig9", "run --scenario beating --control passive --csv out/beating.csv --plot out/fig9"),
    sim("fig9-lead", "run --scenario beating --control lead --expect-divergence"),
    // Adhesion-limited traction.
    sim("adhesion-dry", "adhesion --condition dry --json out/adh-dry.json --plot out/adh"),
    sim("adhesion-wet", "adhesion --condition wet --json out/adh-wet.json --plot out/adh"),
    sim("adhesion-low", "adhesion --condition low --json out/adh-low.json --plot out/adh"),
    sim("low-adhesion-on", "run --scenario low-adhesion --control lead --loop core --wsp on --json out/low-on.json --csv out/low-on.csv --plot out/low"),
    sim("low-adhesion-off", "run --scenario low-adhesion --control lead --loop core --wsp off --expect-divergence --json out/low-off.json"),
    // The sections with and without protection (Markdown: `wheelset_plant::traction::sections_table`).
    sim("low-adhesion-table", "run --scenario low-adhesion --control lead --loop core --sections-table").keep(Keep::Markdown),
    hil("actuator-fault", "run --scenario actuator-fault --report out/af"),
    // The drive check on a traction current loop the device runs unstable.
    hil("drive-alarm", "run --params sim-host/params/l-a-1.2e-4.toml").exit(1).keep(Keep::Starting(&["numerics", "verdict", "  monitor", "  drive:"])),
    // The closed loop over the simulated link.
    sim("device-clean", "run --scenario curve --control lead --loop device --csv out/device.csv"),
    sim("device-faults-seed1", "run --scenario curve --control lead --loop device --faults ber=1e-3,drop=0.1,outage=8.0:0.05 --seed 1"),
    sim("device-acceleration", "run --scenario curve --control lead --loop device --lateral acceleration").keep(Keep::Starting(&["vs continuous reference"])),
    sim("device-baud-refused", "run --scenario curve --control lead --loop device --baud 115200").exit(2).stderr(),
    sim("rates", "rates"),
    // The designed points over a USB-serial bridge, and the pipelined runs.
    sim("rates-usb", "rates --max-baud 921600 --latency-us 1000 --delay 3").keep(Keep::Starting(&["== the designed points", "chosen ("])),
    sim("rates-usb-hs", "rates --max-baud 3000000 --latency-us 250 --delay 3").keep(Keep::Starting(&["chosen ("])),
    sim("device-usb-passive", "run --scenario curve --control passive --loop device --rate-hz 500 --delay-ticks 2 --baud 921600 --latency-us 1000").keep(Keep::Starting(&["monitor:", "vs continuous reference"])),
    sim("device-usb-hs", "run --scenario curve --control lead --loop device --rate-hz 2000 --delay-ticks 2 --baud 3000000 --latency-us 250").keep(Keep::Starting(&["monitor:", "vs continuous reference"])),
    // The fixed-point audit (Markdown: `wheelset_audit::readme_block`).
    hil("audit", "audit --no-target --readme-block").keep(Keep::Markdown),
    // Its margins with a softer lead: the loop lines and the verdict.
    hil("audit-lead5", "audit --no-target --no-sweep --params sim-host/params/lead-gain-5.toml").keep(Keep::Starting(&["  yaw (lead):", "  traction (PI):", "verdict"])),
    // The harness, in process.
    hil("hil", ""),
    hil("hil-faults", "run --faults ber=1e-4,drop=0.01").exit(1),
    hil("hil-wrong-sign", "run --device-fault wrong-sign").exit(1),
    hil("hil-slow", "run --device-fault slow:300").exit(1),
    hil("hil-jitter", "run --device-fault jitter:40").exit(1),
    hil("hil-corrupt", "run --device-fault corrupt:10").exit(1),
    hil("hil-gain", "run --control gain"),
    hil("hil-beating", "run --scenario beating").exit(1),
    hil("hil-short", "run --scenario hil/harness/tests/data/short.toml"),
    // The soak: a broken device caught and the shorter run that replays it.
    hil("soak-defect", "soak --seed 7 --minutes 10 --defect corrupt:150000")
        .exit(1)
        .keep(Keep::AllBut(SOAK_MACHINE_DEPENDENT)),
    hil("soak-replay", "soak --seed 7 --minutes 1 --defect corrupt:150000")
        .exit(1)
        .keep(Keep::AllBut(SOAK_MACHINE_DEPENDENT)),
    hil("golden", "golden"),
    // Any operating point and campaigns over the envelope.
    hil("hil-params-3mn", "run --params sim-host/params/creep-3mn.toml"),
    hil("hil-params-conicity", "run --params sim-host/params/conicity-0.4.toml"),
    hil("hil-sweep", "sweep --param f11=1e6..1e7:5 --param lambda=0.05..0.4:4 --json out/sweep.json --report out/sweep").exit(1).keep(Keep::All),
];
