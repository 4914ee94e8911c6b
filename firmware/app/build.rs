//! 1. The default runtime compiled with the firmware's own control code into exact
//!    constants (`$OUT_DIR/default_runtime.rs`): no float maths on the device.
//! 2. Link set-up for the board build ([`link_setup`]).
use std::{
    env, fs,
    path::{Path, PathBuf},
};

use wheelset_runtime::{RuntimeBits, RuntimeConfig};

/// The default runtime, compiled for the build's sample type, as Rust source.
fn default_runtime() -> String {
    let cfg = RuntimeConfig::default();
    let bits = if env::var_os("CARGO_FEATURE_F32").is_some() {
        RuntimeBits::try_new::<f32>(&cfg)
    } else {
        RuntimeBits::try_new::<wheelset_control::Fx>(&cfg)
    };
    match bits {
        // The derived `Debug` of these plain structs is Rust expression syntax.
        Ok(b) => format!("pub const DEFAULT_RUNTIME: RuntimeBits = {b:#?};\n"),
        Err(e) => {
            println!("cargo:warning=the default configuration does not compile: {e}");
            std::process::exit(1);
        }
    }
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=CARGO_FEATURE_F32");
    let out = PathBuf::from(env::var_os("OUT_DIR").unwrap_or_default());
    if let Err(e) = fs::write(out.join("default_runtime.rs"), default_runtime()) {
        println!("cargo:warning=cannot write default_runtime.rs: {e}");
        std::process::exit(1);
    }
    if env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        if let Err(e) = link_setup(&out) {
            println!("cargo:warning={e}");
            std::process::exit(1);
        }
    }
}

/// The board's memory map: the linker takes `INCLUDE memory.x` from its working directory
/// first (the F446's), so a board with its own map links with `$OUT_DIR/link-<name>.x`.
fn link_setup(out: &Path) -> Result<(), String> {
    let boards: Vec<String> = env::vars()
        .filter_map(|(k, _)| Some(k.strip_prefix("CARGO_FEATURE_BOARD_")?.to_lowercase()))
        .collect();
    let [board] = boards.as_slice() else {
        return Err(format!(
            "the firmware needs exactly one `board-*` feature (firmware/app/Cargo.toml), \
             not {boards:?}: use `cargo fw`"
        ));
    };
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let dir = manifest.join("src/board").join(board);
    let write = |name: &str, text: &str| {
        fs::write(out.join(name), text).map_err(|e| format!("cannot write {name}: {e}"))
    };
    let read = |path: &Path| {
        println!("cargo:rerun-if-changed={}", path.display());
        fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))
    };
    if dir.join("device.x").exists() {
        write("device.x", &read(&dir.join("device.x"))?)?;
    }
    let script = if dir.join("memory.x").exists() {
        let script = format!("link-{board}.x");
        write(
            &script,
            &(read(&dir.join("memory.x"))? + "\nINCLUDE link.x\n"),
        )?;
        let none = out.join("memory-none.x");
        write(
            "memory-none.x",
            "/* The top-level memory.x, remapped away (build.rs). */\n",
        )?;
        for pattern in ["memory.x", "*/memory.x"] {
            println!(
                "cargo:rustc-link-arg-bins=--remap-inputs={pattern}={}",
                none.display()
            );
        }
        script
    } else {
        write("memory.x", &read(&manifest.join("../../memory.x"))?)?;
        "link.x".to_string()
    };
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=--nmagic");
    // Identical code folding: the generic runtime's many identical instances share flash.
    println!("cargo:rustc-link-arg-bins=--icf=all");
    println!("cargo:rustc-link-arg-bins=-T{script}");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    Ok(())
}
