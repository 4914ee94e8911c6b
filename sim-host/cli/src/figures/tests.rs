//! The figures' titles: the root locus names where the stability changes (not the
//! 10 MN end), and the time histories name the paper's figure of their scenario only.
//! Every figure drawn here passes the layout lint (no label over another or off the
//! canvas; data beyond a fixed axis is marked by the plotting module): the time
//! histories, the four root loci and the three creep characteristics.

use super::{characteristic, write_root_locus, write_time_histories};
use wheelset_plant::adhesion::Condition;
use wheelset_plant::control::YawLaw;
use wheelset_plant::modes::{creep_grid, sweep_case, Case};
use wheelset_plant::params::Params;
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::run_continuous;

/// Asserts that the SVG file at `path` has no overlapping or cut-off label.
fn assert_laid_out(path: &std::path::Path) {
    let svg = std::fs::read_to_string(path).expect("read");
    let problems = wheelset_report::svg::lint::problems(&svg);
    assert!(problems.is_empty(), "{}: {problems:#?}", path.display());
}

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("sim-host-figures-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

#[test]
fn root_locus_subtitle_states_the_bisected_crossing() {
    let p = Params::default();
    let sw = sweep_case(&p, Case::B, &creep_grid(60), || {}).expect("sweep");
    let c = sw.crossings.first().expect("case (b) crosses");
    let dir = tmp("locus");
    let f = write_root_locus(&sw, &dir).expect("written");
    assert_laid_out(&f);
    let svg = std::fs::read_to_string(f).expect("read");
    let want = format!("kinematic crosses at {:.2} MN", c.creep_n * 1e-6);
    assert!(svg.contains(&want), "no `{want}` in the subtitle");
    assert!(!svg.contains("crosses: 10 MN"));
    // Case (a) does not cross in 1-10 MN and says so.
    let sa = sweep_case(&p, Case::A, &creep_grid(60), || {}).expect("sweep");
    assert!(sa.crossings.is_empty());
    let fa = write_root_locus(&sa, &dir).expect("written");
    assert_laid_out(&fa);
    let svg = std::fs::read_to_string(fa).expect("read");
    assert!(svg.contains("no stability change in 1-10 MN"));
}

#[test]
fn time_histories_name_the_figure_of_their_scenario() {
    let p = Params::default();
    let sc = Scenario::load("curve", &p).expect("built in");
    let (lead, passive) = (
        run_continuous(&sc, YawLaw::Lead),
        run_continuous(&sc, YawLaw::Passive),
    );
    let dir = tmp("compare");
    for f in write_time_histories(&[lead, passive], &dir).expect("written") {
        assert_laid_out(&f);
    }
    for (scenario, law, lateral, not) in [
        (
            "beating",
            YawLaw::Passive,
            "pure rolling line y0 (Fig. 9)",
            "(Fig. 6)",
        ),
        (
            "curve",
            YawLaw::Lead,
            "pure rolling line y0 (Fig. 6)",
            "(Fig. 9)",
        ),
    ] {
        let sc = Scenario::load(scenario, &p).expect("built in");
        let tr = run_continuous(&sc, law);
        let dir = tmp(scenario);
        write_time_histories(&[tr], &dir).expect("written");
        let svg = std::fs::read_to_string(dir.join("lateral.svg")).expect("read");
        assert!(svg.contains(lateral), "{scenario}: no `{lateral}`");
        assert!(!svg.contains(not), "{scenario}: `{not}` in lateral.svg");
    }
}

#[test]
fn every_root_locus_and_characteristic_is_laid_out() {
    let p = Params::default();
    let dir = tmp("all-loci");
    for case in [Case::C, Case::D] {
        let sw = sweep_case(&p, case, &creep_grid(60), || {}).expect("sweep");
        assert_laid_out(&write_root_locus(&sw, &dir).expect("written"));
    }
    for c in [Condition::Dry, Condition::Wet, Condition::Low] {
        let ch = wheelset_plant::traction::characteristic(c, p.v, &p, 200);
        let svg = characteristic(&ch).to_svg();
        let problems = wheelset_report::svg::lint::problems(&svg);
        assert!(problems.is_empty(), "{c:?}: {problems:#?}");
    }
}
