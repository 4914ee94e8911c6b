//! `sim-host adhesion`: Polach's creep characteristic of a rail condition.

use std::path::PathBuf;
use wheelset_plant::adhesion::Condition;
use wheelset_report::outln;

use super::{io_fail, load_params, write_json, Failure};

#[derive(clap::Args)]
pub(crate) struct AdhesionArgs {
    /// Rail condition.
    #[arg(long, value_enum)]
    condition: Condition,
    /// Speed, m/s (default: the parameters' `v`, 83.3).
    #[arg(long = "v-mps")]
    v_mps: Option<f64>,
    /// Points over creepage 0..0.2 (at least 200).
    #[arg(long, default_value_t = 401, value_parser = clap::value_parser!(u32).range(200..=1_000_000))]
    points: u32,
    /// Write the characteristic as JSON here (directories created).
    #[arg(long)]
    json: PathBuf,
    /// Write `adhesion-<condition>.svg` into this directory.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Parameter file (TOML, any subset of the parameters: `q`, `f11`, `v` ...).
    #[arg(long)]
    params: Option<PathBuf>,
}

pub(crate) fn cmd_adhesion(a: &AdhesionArgs) -> Result<(), Failure> {
    let p = load_params(&a.params)?;
    let v = a.v_mps.unwrap_or(p.v);
    if !(v.is_finite() && (0.1..=200.0).contains(&v)) {
        return Err(Failure::bad(format!(
            "--v-mps {v}: must be within [0.1, 200] m/s"
        )));
    }
    super::check_outputs(
        &[("--json", Some(a.json.as_path()))],
        &[("--plot", a.plot.as_deref())],
    )?;
    let ch = wheelset_plant::traction::characteristic(a.condition, v, &p, a.points as usize);
    outln!(
        "adhesion {}: v {} m/s, Q {:.1} N, f11 {:.3e} N, mu0 {} A {} B {} s/m kA {} kS {}; peak F/Q {:.4} at creepage {:.5} (slip {:.3} m/s)",
        ch.condition, ch.v_mps, ch.q_n, ch.f11_n, ch.law.mu0, ch.law.a, ch.law.b, ch.law.ka, ch.law.ks,
        ch.mu_peak, ch.creepage_peak, ch.slip_peak_mps
    );
    outln!("source: {}", ch.source);
    let json = serde_json::to_value(&ch).map_err(|e| Failure::failed(e.to_string()))?;
    write_json(&a.json, &json, true, "json:")?;
    if let Some(dir) = &a.plot {
        std::fs::create_dir_all(dir).map_err(|e| io_fail(dir, e))?;
        let path = dir.join(format!("adhesion-{}.svg", ch.condition));
        crate::figures::characteristic(&ch)
            .save(&path)
            .map_err(|e| io_fail(&path, e))?;
        outln!("plot: {}", path.display());
    }
    Ok(())
}
