//! `sim-host modes`: the modal analysis along the creep sweep.

use serde::{Serialize, Serializer};
use std::path::PathBuf;
use wheelset_plant::modes::{creep_grid, sweep_case, Case, CaseSweep};
use wheelset_report::outln;

use super::{io_fail, load_params, warn, Failure};

#[derive(clap::Args)]
pub(crate) struct ModesArgs {
    /// Analyse only this case (default: all four).
    #[arg(long, value_enum)]
    case: Option<Case>,
    /// Points of the sweep, evenly spaced over 1-10 MN (1, 2, 5 and 10 MN are always
    /// included exactly).
    #[arg(long, default_value_t = 1000, allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(2..=1_000_000))]
    points: u32,
    /// Write the results as JSON here (directories created).
    #[arg(long)]
    json: PathBuf,
    /// Write one root-locus SVG per case into this directory.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Parameter file (TOML, any subset of the parameters).
    #[arg(long)]
    params: Option<PathBuf>,
}

pub(crate) fn progress(total: u64, msg: &str) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let pb = indicatif::ProgressBar::new(total);
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} points ({eta})")
    {
        pb.set_style(style.progress_chars("=> "));
    }
    pb.set_message(msg.to_string());
    pb
}

pub(crate) fn cmd_modes(a: &ModesArgs) -> Result<(), Failure> {
    let p = load_params(&a.params)?;
    let cases: Vec<Case> = a.case.map_or(Case::ALL.to_vec(), |c| vec![c]);
    wheelset_plant::memory::check_modes(u64::from(a.points), cases.len() as u64)
        .map_err(Failure::bad)?;
    super::check_outputs(
        &[("--json", Some(a.json.as_path()))],
        &[("--plot", a.plot.as_deref())],
    )?;
    let grid = creep_grid(a.points as usize);
    let pb = progress((grid.len() * cases.len()) as u64, "modal sweep");
    let mut sweeps = Vec::new();
    for &case in &cases {
        let sw = sweep_case(&p, case, &grid, || pb.inc(1))
            .map_err(|e| Failure::failed(e.to_string()))?;
        sweeps.push(sw);
    }
    pb.finish_and_clear();
    outln!(
        "modal sweep: v = {} m/s, f11 = f22 over {} points in 1-10 MN; kinematic frequency v sqrt(lambda/(r0 Lg))/2pi = {:.3} Hz",
        p.v,
        grid.len(),
        p.kinematic_hz()
    );
    outln!(
        "the structural zero eigenvalue (free rolling at any speed) is excluded from every verdict"
    );
    for sw in &sweeps {
        // Conditioning at the reported points: eig(A) against eig(A^T).
        let worst = [1e6, 2e6, 5e6, 1e7]
            .iter()
            .filter_map(|&c| {
                wheelset_plant::finite::eigen_disagreement(&sw.case.matrix(&p, c).0).map(|d| (d, c))
            })
            .fold((0.0f64, 0.0), |a, b| if b.0 > a.0 { b } else { a });
        if worst.0 > wheelset_plant::finite::ILL_CONDITIONED {
            warn(&format!(
                "case ({}): the eigenvalue problem is ill-conditioned with these parameters: the \
                 eigenvalues of A and A^T differ by {:.1e} (relative) at {} MN, so the modes below \
                 carry only about {} correct digits",
                sw.case.id(),
                worst.0,
                worst.1 * 1e-6,
                (-worst.0.log10()).floor().max(0.0)
            ));
        }
        outln!("case ({}): {}", sw.case.id(), sw.case.label());
        for c in [1e6, 2e6, 5e6, 1e7] {
            let Some(k) = sw.index_of(c) else { continue };
            let modes: Vec<String> = sw
                .modes_at(k)
                .iter()
                .map(|m| format!("{} {:.2} Hz zeta {:.3}", m.name, m.freq_hz, m.zeta))
                .collect();
            let z = sw.structural_zero(k).map_or(f64::NAN, |l| l.norm());
            outln!(
                "  {:>4.0} MN {}: {} | structural zero |lambda| = {z:.1e}",
                c * 1e-6,
                if sw.stable_at(k) {
                    "stable  "
                } else {
                    "UNSTABLE"
                },
                modes.join("; ")
            );
        }
        if sw.crossings.is_empty() {
            outln!("  no crossing in 1-10 MN");
        }
        for c in &sw.crossings {
            outln!(
                "  crossing: {} at {:.4} MN, {:.2} Hz, unstable {}",
                c.mode,
                c.creep_n * 1e-6,
                c.freq_hz,
                if c.unstable_below { "below" } else { "above" }
            );
        }
    }
    let derived = serde_json::json!({
        "k_t": p.k_t(), "k_gear": p.k_gear(), "y0_at_2300m": p.pure_rolling_y(1.0 / 2300.0)
    });
    let params = serde_json::to_value(&p).map_err(|e| Failure::failed(e.to_string()))?;
    let file = ModesFile {
        cases: Cases(&sweeps),
        derived: &derived,
        kinematic_hz: p.kinematic_hz(),
        note: "structural zero eigenvalue (free rolling at any speed) reported as structural_zero and excluded from stability verdicts",
        params: &params,
        speed_mps: p.v,
    };
    super::write_json(&a.json, &file, false, "json:")?;
    if let Some(dir) = &a.plot {
        for sw in &sweeps {
            let f = crate::figures::write_root_locus(sw, dir).map_err(|e| io_fail(dir, e))?;
            outln!("plot: {}", f.display());
        }
    }
    Ok(())
}

/// The modes file: keys in alphabetical order as serde_json writes a `Value` map.
#[derive(Serialize)]
struct ModesFile<'a> {
    cases: Cases<'a>,
    derived: &'a serde_json::Value,
    kinematic_hz: f64,
    note: &'a str,
    params: &'a serde_json::Value,
    speed_mps: f64,
}

/// The cases' sweeps, each made into its JSON form only as it is written.
struct Cases<'a>(&'a [CaseSweep]);

impl Serialize for Cases<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.0.iter().map(CaseSweep::to_json))
    }
}
