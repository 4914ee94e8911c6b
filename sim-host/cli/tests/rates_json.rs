//! `sim-host rates --json`: the link's budget and the designed points over it in one
//! `link` object.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

#[test]
fn the_rates_document_keeps_the_link_budget_beside_the_designed_points() {
    let dir = std::env::temp_dir().join(format!("wheelset-rates-json-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("rates.json");
    let v = common::run_json(&["rates"], &path);
    let _ = std::fs::remove_dir_all(&dir);
    let link = &v["link"];
    for key in [
        "bytes_in",
        "bytes_out",
        "max_utilisation",
        "baud",
        "latency_ns",
        "points",
        "max_delay_ticks",
    ] {
        assert!(link.get(key).is_some(), "link.{key} missing: {link}");
    }
    assert!(link["bytes_in"].as_u64().unwrap() > 0 && link["bytes_out"].as_u64().unwrap() > 0);
    assert!(!link["points"].as_array().unwrap().is_empty());
}
