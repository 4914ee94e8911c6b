//! `sim-host rates`: the sampled-data rate analysis of the firmware's loops.

use std::path::PathBuf;
use wheelset_report::{out, outln};

use super::{load_params, Failure};
use wheelset_plant::control::YawLaw;
use wheelset_plant::sampled::Model;

#[derive(clap::Args)]
pub(crate) struct RatesArgs {
    /// Yaw control mode analysed.
    #[arg(long, value_enum, default_value = "lead")]
    control: YawLaw,
    /// Plant model.
    #[arg(long, value_enum, default_value = "full")]
    model: Model,
    /// Parameter file (TOML, any subset of the parameters).
    #[arg(long)]
    params: Option<PathBuf>,
    /// Ticks of computation and transport delay on the actuation (the firmware: 1).
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    delay: usize,
    /// The fastest UART baud the link may assume: the rate table's selection criterion,
    /// and the link the designed points are judged against (the fastest it carries is
    /// chosen, with delays up to `--delay`).
    #[arg(long, default_value_t = 6_000_000, allow_negative_numbers = true)]
    max_baud: u32,
    /// One-way latency of that link, us (a USB-serial bridge: about 1000).
    #[arg(long, default_value_t = 5.0, allow_negative_numbers = true)]
    latency_us: f64,
    /// Write the table as JSON (directories created).
    #[arg(long)]
    json: Option<PathBuf>,
}

pub(crate) fn cmd_rates(a: &RatesArgs) -> Result<(), Failure> {
    use wheelset_plant::sampled::{rates, Criteria, LinkBudget};
    if a.delay > 10 {
        return Err(Failure::bad(format!(
            "--delay {}: at most 10 ticks",
            a.delay
        )));
    }
    if a.max_baud == 0 {
        return Err(Failure::bad("--max-baud 0: must be positive".into()));
    }
    let latency_ns = super::loop_device::latency_ns(a.latency_us)?;
    let p = load_params(&a.params)?;
    super::check_outputs(&[("--json", a.json.as_deref())], &[])?;
    let (mode, model) = (a.control.into(), a.model);
    let mut cfg = wheelset_control::Config {
        yaw_mode: mode,
        ..wheelset_control::Config::default()
    };
    cfg.motor.k_m = p.k_m;
    cfg.motor.n = p.n_gear;
    let criteria = Criteria {
        max_baud: a.max_baud as f64,
        ..Criteria::default()
    };
    let report = rates(&p, model, &cfg, a.delay, &LinkBudget::default(), &criteria)
        .map_err(|e| Failure::bad(format!("rate analysis: {e}")))?;
    out!("{}", report.render());
    let design = if mode == wheelset_control::YawMode::Lead && model == Model::Full {
        let base = wheelset_control::Config {
            motor: cfg.motor,
            ..wheelset_control::Config::default()
        };
        let fail = |e: String| Failure::bad(format!("design table: {e}"));
        let reference = wheelset_plant::sampled::reference_yaw(&p).map_err(fail)?;
        let rows = wheelset_plant::sampled::design_table(&p, &base).map_err(fail)?;
        outln!();
        out!(
            "{}",
            wheelset_plant::sampled::render_design(&rows, &reference)
        );
        Some(wheelset_plant::sampled::design_json(&rows))
    } else {
        None
    };
    let delay = u8::try_from(a.delay).unwrap_or(u8::MAX);
    let link = wheelset_plant::sampled::link_choice(a.max_baud, latency_ns, delay);
    outln!();
    out!("{}", link.render());
    if let Some(path) = &a.json {
        let mut json = report.to_json();
        if let Some(d) = design {
            json["design"] = d;
        }
        // The link's budget (the report's) and the designed points over it, one object.
        let mut both = link.to_json();
        if let (Some(b), Some(budget)) = (both.as_object_mut(), json["link"].as_object()) {
            for (k, v) in budget {
                b.entry(k).or_insert_with(|| v.clone());
            }
        }
        json["link"] = both;
        super::write_json(path, &json, true, "wrote")?;
    }
    Ok(())
}
