//! What is flashed is what is tested: the Cargo features of the device crates in every
//! board build against the builds the tests run (the host's `cargo test --workspace` and
//! the device-feature run), resolved by `cargo tree`. They may differ only in the
//! features of [`ON_PURPOSE`]; any other difference fails ([`check`], run by `cargo
//! xtest` before anything is built).

use std::collections::{BTreeMap, BTreeSet};

use crate::{cargo, Firmware, DEVICE_CRATES};

/// The packages `cargo xtest` tests a second time with the device's features (without
/// the `std` the workspace's host crates turn on in the wire crate).
pub const DEVICE_TEST_PACKAGES: &[&str] = &["wheelset-proto", "wheelset-runtime"];

/// The features a board build may have that a tested build lacks, or the reverse, and
/// why each changes nothing the device does with a frame.
pub const ON_PURPOSE: &[(&str, &str)] = &[
    (
        "defmt",
        "`defmt::Format` for the firmware's log; no code path of the device depends on it",
    ),
    (
        "fault-inject",
        "the test-only InjectStall / InjectHardFault, honoured by the QEMU builds only \
         (checked: no other board build has it)",
    ),
    (
        "std",
        "the wire crate's host conveniences (error impls, the SI conversions); its bytes are \
         handled by the same code with and without it, tested by the device-feature run too",
    ),
];

/// Features of each crate of a build, as cargo resolves them.
pub type Features = BTreeMap<String, BTreeSet<String>>;

/// The features of [`DEVICE_CRATES`] in `cargo tree`'s `{p}|{f}` lines; a crate that
/// appears with two different sets is an error.
pub fn parse_tree(out: &str) -> Result<Features, String> {
    let mut found = Features::new();
    for line in out.lines() {
        let Some((package, features)) = line.split_once('|') else {
            continue;
        };
        let Some(name) = package.split_whitespace().next() else {
            continue;
        };
        if !DEVICE_CRATES.contains(&name) {
            continue;
        }
        let features = features.trim().trim_end_matches("(*)").trim();
        let set: BTreeSet<String> = features
            .split(',')
            .map(str::trim)
            .filter(|f| !f.is_empty() && *f != "default")
            .map(String::from)
            .collect();
        match found.get(name) {
            Some(seen) if *seen != set => {
                return Err(format!(
                    "{name} is resolved with two feature sets in one build: {seen:?} and {set:?}"
                ))
            }
            _ => {
                found.insert(name.to_string(), set);
            }
        }
    }
    for name in DEVICE_CRATES {
        if !found.contains_key(name) {
            return Err(format!("{name} is not in the resolved build"));
        }
    }
    Ok(found)
}

/// `cargo tree` with `args`: the resolved features of [`DEVICE_CRATES`].
fn resolve(what: &str, args: &[&str]) -> Result<Features, String> {
    let mut cmd = cargo();
    cmd.args(["tree", "--prefix", "none", "--format", "{p}|{f}"])
        .args(args)
        .current_dir(crate::workspace_root());
    let out = cmd
        .output()
        .map_err(|e| format!("cannot run {cmd:?}: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "{cmd:?} failed: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    parse_tree(&String::from_utf8_lossy(&out.stdout)).map_err(|e| format!("{what}: {e}"))
}

/// The features of a board build, as `cargo fw` builds it.
pub fn board_build(fw: &Firmware) -> Result<Features, String> {
    resolve(
        fw.elf,
        &[
            "-p",
            "wheelset-fw",
            "--features",
            fw.features,
            "--target",
            fw.target,
            "-e",
            "normal",
        ],
    )
}

/// The tested builds: `cargo test --workspace` on the host, and the device-feature run.
pub fn tested_builds() -> Result<Vec<(&'static str, Features)>, String> {
    let workspace = resolve(
        "cargo test --workspace",
        &["--workspace", "-e", "normal,dev"],
    )?;
    let mut device_args = vec!["-e", "normal,dev"];
    for p in DEVICE_TEST_PACKAGES {
        device_args.extend(["-p", p]);
    }
    let device = resolve("the device-feature run", &device_args)?;
    Ok(vec![
        ("cargo test --workspace", workspace),
        ("the device-feature run", device),
    ])
}

/// What differs between a board build and a tested build beyond [`ON_PURPOSE`], and a
/// fault injection outside QEMU's build: one line each.
pub fn compare(
    board: &str,
    qemu: bool,
    built: &Features,
    tested_name: &str,
    tested: &Features,
) -> Vec<String> {
    let allowed = |f: &str| ON_PURPOSE.iter().any(|(name, _)| *name == f);
    let empty = BTreeSet::new();
    let mut problems = Vec::new();
    for krate in DEVICE_CRATES {
        let b = built.get(krate).unwrap_or(&empty);
        let t = tested.get(krate).unwrap_or(&empty);
        for f in b.difference(t).filter(|f| !allowed(f)) {
            problems.push(format!(
                "{board}: {krate} has `{f}`, which {tested_name} does not"
            ));
        }
        for f in t.difference(b).filter(|f| !allowed(f)) {
            problems.push(format!(
                "{board}: {krate} lacks `{f}`, which {tested_name} has"
            ));
        }
        if !qemu && b.contains("fault-inject") {
            problems.push(format!(
                "{board}: {krate} has `fault-inject`, which only the QEMU builds may have"
            ));
        }
    }
    problems
}

/// Every board build against every tested build (see the module docs).
pub fn check(builds: &[&Firmware]) -> Result<(), String> {
    let tested = tested_builds()?;
    let mut problems = Vec::new();
    for fw in builds {
        let built = board_build(fw)?;
        let qemu = fw.board == "qemu";
        for (name, t) in &tested {
            problems.extend(compare(fw.elf, qemu, &built, name, t));
        }
    }
    problems.sort();
    problems.dedup();
    if problems.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "a board build is not the tested build (features that may differ: {}):\n  {}",
            ON_PURPOSE
                .iter()
                .map(|(f, _)| *f)
                .collect::<Vec<_>>()
                .join(", "),
            problems.join("\n  ")
        ))
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn features(rows: &[(&str, &[&str])]) -> Features {
        rows.iter()
            .map(|(k, fs)| (k.to_string(), fs.iter().map(|f| f.to_string()).collect()))
            .collect()
    }

    #[test]
    fn cargo_trees_lines_are_read() {
        let out = "wheelset-fw v0.1.0 (/w/firmware/app)|board-qemu,default\n\
                   wheelset-control v0.1.0 (/w/firmware/control)|defmt\n\
                   wheelset-proto v0.1.0 (/w/firmware/proto)|default,defmt\n\
                   wheelset-proto v0.1.0 (/w/firmware/proto)|default,defmt (*)\n\
                   wheelset-runtime v0.1.0 (/w/firmware/runtime)|defmt,fault-inject\n\
                   heapless v0.9.3|\n";
        let f = parse_tree(out).unwrap();
        assert_eq!(
            f,
            features(&[
                ("wheelset-control", &["defmt"]),
                ("wheelset-proto", &["defmt"]),
                ("wheelset-runtime", &["defmt", "fault-inject"]),
            ])
        );
        // One crate with two feature sets, or a crate missing: errors.
        let two = format!("{out}wheelset-proto v0.1.0 (/w/firmware/proto)|std\n");
        assert!(parse_tree(&two).unwrap_err().contains("two feature sets"));
        let missing = "wheelset-proto v0.1.0 (/w)|\nwheelset-control v0.1.0 (/w)|\n";
        assert!(parse_tree(missing)
            .unwrap_err()
            .contains("wheelset-runtime is not"));
    }

    #[test]
    fn a_protection_switched_off_in_a_board_build_fails() {
        let tested = features(&[
            ("wheelset-runtime", &["wsp"]),
            ("wheelset-proto", &["std"]),
            ("wheelset-control", &[]),
        ]);
        // The on-purpose differences pass, in either direction.
        let board = features(&[
            ("wheelset-runtime", &["defmt", "fault-inject", "wsp"]),
            ("wheelset-proto", &["defmt"]),
            ("wheelset-control", &["defmt"]),
        ]);
        assert!(compare("q.elf", true, &board, "t", &tested).is_empty());
        // A feature the board lacks (or has alone) is named.
        let off = features(&[
            ("wheelset-runtime", &["defmt"]),
            ("wheelset-proto", &["monitor"]),
            ("wheelset-control", &[]),
        ]);
        let p = compare("n.elf", false, &off, "t", &tested);
        assert_eq!(p.len(), 2, "{p:?}");
        assert!(p[0].contains("wheelset-proto has `monitor`"), "{p:?}");
        assert!(p[1].contains("wheelset-runtime lacks `wsp`"), "{p:?}");
        // The fault injection outside QEMU's builds is named.
        let p = compare("n.elf", false, &board, "t", &tested);
        assert_eq!(p.len(), 1, "{p:?}");
        assert!(p[0].contains("only the QEMU builds"), "{p:?}");
    }

    /// The real builds: every board build (and the f32 measurement builds) against the
    /// tested builds, as cargo resolves them now.
    #[test]
    fn every_board_build_has_the_tested_features() {
        let builds: Vec<&Firmware> = crate::FIRMWARE.iter().chain(crate::FIRMWARE_F32).collect();
        check(&builds).unwrap();
        // And the resolution is what the docs say: the board builds have no `std`,
        // the workspace's tests have it, the device-feature run does not.
        let tested = tested_builds().unwrap();
        let has_std = |f: &Features| f["wheelset-proto"].contains("std");
        assert!(has_std(&tested[0].1) && !has_std(&tested[1].1));
        for fw in crate::FIRMWARE {
            let b = board_build(fw).unwrap();
            assert!(!has_std(&b), "{}", fw.elf);
            assert!(b["wheelset-runtime"].contains("defmt"), "{}", fw.elf);
        }
    }
}
